"""da_lidar_eval --scenes as a user runs it: --jobs gives the scores of one process, --objects
writes every scored object once, with the issue's limits applied by hand, and never overwrites."""
import csv
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from data_association_ros.bag import lidar_eval, lidar_seeds
from data_association_ros.bag.lidar_eval import main
from data_association_ros.bag.lidar_random_scene import OTHER_LIDARS
from data_association_ros.bag.lidar_seeds import OBJECT_COLUMNS, evaluate_kind
from data_association_ros.core.lidar import TrackerConfig

SEEDS = [3000, 3001]   # car_moving with the 360 deg, 10 Hz LiDAR: 5 cars, across the seam too


def test_two_processes_score_as_one_and_every_object_is_written(tmp_path, capsys, monkeypatch):
    serial = evaluate_kind('car_moving', SEEDS, TrackerConfig(), lidar=OTHER_LIDARS['360_10hz'])
    out = tmp_path / 'objects.csv'
    pools = []

    class Pool(ProcessPoolExecutor):
        def __init__(self, workers, **options):
            pools.append(workers)
            super().__init__(workers, **options)
    monkeypatch.setattr(lidar_eval, 'ProcessPoolExecutor', Pool)
    assert main(['--scenes', 'car_moving', '--seeds', '3000,3001', '--lidar', '360_10hz',
                 '--jobs', '2', '--objects', str(out)]) == 0
    assert pools == [2]   # one pool of two processes served the seeds
    table = capsys.readouterr().out
    with open(out, newline='') as f:
        rows = list(csv.reader(f))
    assert tuple(rows[0]) == OBJECT_COLUMNS
    rows = [dict(zip(OBJECT_COLUMNS, row)) for row in rows[1:]]
    assert len(rows) == len(serial.objects) > 0
    summary = [line for line in table.splitlines() if line.startswith('| car_moving')]
    cells = [cell.strip() for cell in summary[0].strip('|').split('|')]
    assert cells[:2] == ['car_moving (seeds 3000-3001)', str(len(rows))]
    for row, (seed, object_id, s) in zip(rows, serial.objects):
        assert (row['kind'], row['lidar'], int(row['seed']), int(row['object'])) == \
            ('car_moving', '360_10hz', seed, object_id)
        assert int(row['scans']) == s.scans and int(row['id_switches']) == s.id_switches
        np.testing.assert_allclose(
            [float(row[c]) for c in ('coverage', 'position_rmse_m', 'heading_rmse_deg',
                                     'velocity_rmse_mps')],
            [s.coverage, s.position_rmse, s.heading_rmse_deg, s.velocity_rmse], atol=1e-3)
        # issue 21's limits for a full-size car: 0.3 m, 5 deg, 0.8 m/s, no id switch
        limits = (s.position_rmse <= 0.3, s.heading_rmse_deg <= 5.0, s.velocity_rmse <= 0.8)
        assert [int(row[c]) for c in ('within_position', 'within_heading',
                                      'within_velocity')] == list(map(int, limits))
        assert int(row['passes']) == int(all(limits) and s.id_switches == 0)
    # the table's "objects within all three, no id switch [%]"
    assert cells[8] == f"{100 * np.mean([int(row['passes']) for row in rows]):.0f}"


def test_an_existing_objects_file_is_refused_and_kept(tmp_path, capsys):
    out = tmp_path / 'objects.csv'
    out.write_text('an earlier run\n')
    assert main(['--scenes', 'race', '--seeds', '100', '--objects', str(out)]) == 2
    assert 'File exists' in capsys.readouterr().err
    assert out.read_text() == 'an earlier run\n'


def test_a_run_cut_short_leaves_no_objects_file(tmp_path, monkeypatch):
    out = tmp_path / 'objects.csv'

    def interrupted(*args, **kwargs):
        assert out.exists()   # opened (header written) before the first kind
        raise KeyboardInterrupt
    monkeypatch.setattr(lidar_seeds, 'evaluate_kind', interrupted)
    with pytest.raises(KeyboardInterrupt):
        main(['--scenes', 'race', '--seeds', '100', '--objects', str(out)])
    assert not out.exists()


def test_a_parameter_given_wins_over_the_kinds_preset(monkeypatch, capsys):
    """-p nearest_cutoff=0.2 on an F1Tenth kind: the preset sets 0.1, and the value given is
    the one the seeds run with (it was silently replaced by the preset's); the preset's other
    values and the defaults stay; an invalid value is refused before any seed runs."""
    seen = []

    def spy(kind, seed, config, lidar):
        seen.append((kind, seed, config))
        return [], np.zeros(1)
    monkeypatch.setattr(lidar_seeds, 'evaluate_seed', spy)
    assert main(['--scenes', 'race,car_static', '--seeds', '100', '-p', 'nearest_cutoff=0.2',
                 '-p', 'min_pairs=4']) == 0
    (race_kind, _, race), (car_kind, _, car) = seen
    assert (race_kind, car_kind) == ('race', 'car_static')
    assert (race.nearest_cutoff, race.min_pairs) == (0.2, 4)
    assert (race.size_class, race.fine, race.boundary_spacing) == ('f1tenth', 'nearest', 0.05)
    assert (car.nearest_cutoff, car.min_pairs, car.size_class) == (0.2, 4, 'car')
    assert car.fine == TrackerConfig().fine and TrackerConfig().nearest_cutoff != 0.2
    capsys.readouterr()
    seen.clear()
    assert main(['--scenes', 'race', '--seeds', '100', '-p', 'nearest_cutoff=-1']) == 2
    assert 'nearest_cutoff' in capsys.readouterr().err and not seen
