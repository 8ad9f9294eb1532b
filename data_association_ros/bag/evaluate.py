"""da_bag_eval: score association answers against a bag's ground truth.

    da_bag_eval BAG                 every applicable algorithm through the live node (replay)
    da_bag_eval BAG --offline       the same pipeline on the bag without DDS (fast, for sweeps)
    da_bag_eval BAG OUT             score a recording made by da_bag_replay

Scores: pairing precision and recall, correct and false NEW answers, clutter accepted as a pair,
answered messages, the landmarks announced on new_landmarks (right, false, of which duplicates,
true new landmarks missed, median delay in scans from first sighting; see NewLandmarkScore),
latency (median/p99, live only) and, offline, scans per second.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, Optional

import numpy as np

from msg_adapters import cloud_to_array

from ..pipelines.association import stamp_ns
from . import topics
from .offline import node_config, offline_answers, truth_by_stamp, truth_positions_by_stamp
from .parameter_arguments import parse_assignments
from .reader import BagError, BagReader
from .scoring import NewLandmarkScore, Score

DEFAULT_ALGORITHMS = ('euclidean_nn', 'mahalanobis_nn', 'maximum_likelihood', 'gnn', 'jcbb')


def bag_algorithms(bag: Path) -> tuple[str, ...]:
    """The algorithms a bag's metadata names as applicable (all point algorithms if none)."""
    from .make_bags import ALGORITHMS_KEY
    from .rosbag2_metadata import read_custom_data
    custom = read_custom_data(bag)
    if custom.get(ALGORITHMS_KEY):
        return tuple(custom[ALGORITHMS_KEY].split(','))
    return DEFAULT_ALGORITHMS


def read_truth(bag: Path) -> tuple[BagReader, dict[int, np.ndarray]]:
    """The reader and {stamp ns: true assignment}; BagError when the bag cannot be scored."""
    reader = BagReader(bag)
    reader.require([topics.OBSERVATIONS, topics.GROUND_TRUTH])
    truth = truth_by_stamp((m.topic, m.msg) for m in reader.messages([topics.GROUND_TRUTH]))
    return reader, truth


def read_truth_xy(bag: Path) -> dict[int, np.ndarray]:
    """{stamp ns: true x, y (K, 2)} of the bag's ground truth."""
    reader = BagReader(bag)
    return truth_positions_by_stamp((m.topic, m.msg) for m in reader.messages(
        [topics.GROUND_TRUTH]))


def score_recording(truth: dict[int, np.ndarray], recording: BagReader,
                    truth_xy: Optional[dict[int, np.ndarray]] = None) -> Score:
    """Score /correspondences of a recording (and its /new_landmarks when `truth_xy` is
    given); latency = answer log time - observation log time (both wall clock in a
    da_bag_replay recording)."""
    sent: dict[int, int] = {}
    answers: dict[int, tuple[np.ndarray, int]] = {}
    announced = []
    wanted = [topics.OBSERVATIONS, topics.CORRESPONDENCES] + (
        [topics.NEW_LANDMARKS] if topics.NEW_LANDMARKS in recording.topics else [])
    for message in recording.messages(wanted):
        stamp = stamp_ns(message.msg.header)
        if message.topic == topics.OBSERVATIONS:
            sent[stamp] = message.log_time_ns
        elif message.topic == topics.NEW_LANDMARKS:
            announced.append((stamp, cloud_to_array(message.msg)))
        else:
            answers[stamp] = (cloud_to_array(message.msg)['landmark'].astype(np.int64),
                              message.log_time_ns)
    score = Score(landmarks=score_new_landmarks(truth, truth_xy, announced)
                  if truth_xy is not None else None)
    for stamp, true in sorted(truth.items()):
        answer, received = answers.get(stamp, (None, None))
        latency = (received - sent[stamp]) / 1e6 if answer is not None and stamp in sent \
            else None
        score.add(true, answer, latency)
    return score


def evaluate_offline(bag: Path, algorithm: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """Score of `algorithm` run offline on `bag`, with scans per second."""
    reader, truth = read_truth(bag)
    present = [t for t in topics.INPUT_TOPICS if t in reader.topics]
    messages = [(m.topic, m.msg) for m in reader.messages(present)]
    started = time.perf_counter()
    answers = offline_answers(messages, node_config(algorithm, overrides))
    elapsed = time.perf_counter() - started
    announced = [(stamp, cloud_to_array(answer.new_landmarks))
                 for stamp, answer in sorted(answers.items()) if answer.new_landmarks is not None]
    score = Score(landmarks=score_new_landmarks(truth, read_truth_xy(bag), announced))
    for stamp, true in sorted(truth.items()):
        answer = answers.get(stamp)
        score.add(true, None if answer is None else answer.association.assignment)
    return {**score.summary(), 'scans_per_s': len(truth) / elapsed if elapsed else math.inf}


def score_new_landmarks(truth: dict[int, np.ndarray], truth_xy: dict[int, np.ndarray],
                        announced: list[tuple[int, np.ndarray]]) -> NewLandmarkScore:
    """NewLandmarkScore of the decoded new_landmarks messages [(stamp, points)] in time order."""
    score = NewLandmarkScore(truth, truth_xy)
    for stamp, points in sorted(announced, key=lambda item: item[0]):
        if stamp in score.scan_of:
            score.add(stamp, points)
    return score


def evaluate_live(bag: Path, algorithm: str, overrides: dict[str, Any], rate: float,
                  out: Optional[Path] = None) -> dict[str, Any]:
    """Score of `algorithm` through the live node (da_bag_replay); recording kept in `out`."""
    from .replay import recording_custom_data, replay, write_recording
    _, truth = read_truth(bag)
    node_config(algorithm, overrides)  # check the parameters before starting anything
    result = replay(bag, algorithm, overrides, rate, progress=True)
    with tempfile.TemporaryDirectory() as scratch:
        target = out or Path(scratch) / 'recording'
        write_recording(target, result, recording_custom_data(bag, algorithm, overrides))
        summary = score_recording(truth, BagReader(target), read_truth_xy(bag)).summary()
    summary['node_alive'] = result.node_alive
    summary['node_rss_mb'] = [round(kb / 1024, 1) for kb in result.node_rss_kb]
    return summary


COLUMNS = (('algorithm', 'algorithm', '{}'), ('pair_precision', 'precision', '{:.3f}'),
           ('pair_recall', 'recall', '{:.3f}'), ('new_correct', 'new_ok', '{}'),
           ('new_false', 'new_false', '{}'), ('clutter_paired', 'clutter', '{}'),
           ('answered', 'answered', '{}'), ('landmarks_right', 'lm_ok', '{}'),
           ('landmarks_false', 'lm_false', '{}'), ('landmarks_duplicate', 'lm_dup', '{}'),
           ('landmarks_missed', 'lm_missed', '{}'), ('confirm_delay_scans', 'delay', '{:.1f}'))
LIVE_COLUMNS = (('latency_median_ms', 'p50_ms', '{:.2f}'), ('latency_p95_ms', 'p95_ms', '{:.2f}'),
                ('latency_p99_ms', 'p99_ms', '{:.2f}'))
OFFLINE_COLUMNS = (('scans_per_s', 'scans/s', '{:.0f}'),)
LEGEND = """\
precision, recall: correct pairs / pairs made, / true pairs; new_ok, new_false: NEW answers for
observations of landmarks not yet in the map, for anything else; clutter: clutter returns
paired / clutter returns; answered: observation messages answered / sent; lm_ok, lm_false,
lm_dup, lm_missed: landmarks announced on new_landmarks that are right, false (of which
duplicates), true new landmarks never announced; delay: median scans from first sighting to
announcement; p50_ms, p95_ms, p99_ms: latency publish -> correspondences; -: not applicable"""
CONFIRM_NOTE = """\
lm_false is high with confirm_hits 1 (announce at once): every NEW answer, e.g. a clutter return
outside every gate, becomes a landmark. With -p confirm_hits:=2 a landmark is announced only
once seen on 2 of confirm_window scans (docs/confirmation.md)."""


def cell(value: Any, fmt: str) -> str:
    """`value` formatted, '-' when missing or NaN."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return '-'
    return fmt.format(value)


def format_table(rows: list[dict[str, Any]], offline: bool) -> str:
    """A plain-text table, one row per algorithm, one-word headers, columns as wide as their
    widest cell (first column left-aligned, the others right-aligned)."""
    columns = COLUMNS + (OFFLINE_COLUMNS if offline else LIVE_COLUMNS)
    table = [[title for _, title, _ in columns]]
    for row in rows:
        row = {**row, 'answered': f'{row["answered"]}/{row["messages"]}',
               'clutter_paired': f'{row["clutter_paired"]}/{row["clutter"]}'}
        table.append([cell(row.get(key), fmt) for key, _, fmt in columns])
    widths = [max(len(line[k]) for line in table) for k in range(len(columns))]
    return '\n'.join('  '.join(text.ljust(width) if k == 0 else text.rjust(width)
                               for k, (text, width) in enumerate(zip(line, widths))).rstrip()
                      for line in table)


def recording_info(out: Path) -> tuple[str, str]:
    """(algorithm, 'OUT: BAG replayed with ALGORITHM, parameters {...}') from the metadata of
    a da_bag_replay recording; (OUT's name, 'OUT: no replay metadata ...') without it."""
    from .replay import RECORDED_ALGORITHM_KEY, RECORDED_BAG_KEY, RECORDED_PARAMETERS_KEY
    from .rosbag2_metadata import read_custom_data
    custom = read_custom_data(out) if out.is_dir() else {}
    if RECORDED_ALGORITHM_KEY not in custom:
        return out.name, f'{out}: no replay metadata (algorithm and parameters unknown)'
    algorithm = custom[RECORDED_ALGORITHM_KEY]
    return algorithm, (f'{out}: {custom.get(RECORDED_BAG_KEY, "?")} replayed with {algorithm}, '
                       f'parameters {custom.get(RECORDED_PARAMETERS_KEY, "{}")}')


def main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(prog='da_bag_eval',
                                     description=' '.join(__doc__.split('\n\n')[0].split()),
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog='\n'.join(__doc__.splitlines()[2:]))
    parser.add_argument('bag', type=Path,
                        help='bag with inputs and /ground_truth/correspondences')
    parser.add_argument('out', type=Path, nargs='?', help='a da_bag_replay recording to score')
    parser.add_argument('--algorithms', help='comma-separated (default: those the bag names)')
    parser.add_argument('--offline', action='store_true', help='run the pipeline without DDS')
    parser.add_argument('--json', action='store_true', help='print JSON instead of a table')
    parser.add_argument('--rate', type=float, default=1.0, help='live playback rate factor')
    parser.add_argument('-p', dest='parameters', action='append', default=[],
                        metavar='NAME:=VALUE', help='node parameter (repeatable)')
    args = parser.parse_args(argv)
    try:
        from .replay import bag_parameters
        overrides = {**bag_parameters(args.bag), **parse_assignments(args.parameters)}
        if args.out is not None:
            _, truth = read_truth(args.bag)
            label, heading = recording_info(args.out)
            rows = [{'algorithm': label, **score_recording(
                truth, BagReader(args.out), read_truth_xy(args.bag)).summary()}]
        else:
            algorithms = args.algorithms.split(',') if args.algorithms else \
                list(bag_algorithms(args.bag))
            rows = []
            for algorithm in algorithms:
                summary = evaluate_offline(args.bag, algorithm, overrides) if args.offline \
                    else evaluate_live(args.bag, algorithm, overrides, args.rate)
                rows.append({'algorithm': algorithm, **summary})
    except (BagError, ValueError) as error:
        print(f'da_bag_eval: {error}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(rows, indent=2, default=float))
    else:
        print(heading if args.out is not None else
              f'{args.bag} ({"offline" if args.offline else "live"}; parameters '
              f'{json.dumps(overrides, sort_keys=True)})')
        print(format_table(rows, args.offline))
        print(LEGEND)
        if overrides.get('confirm_hits', 1) == 1 and any(
                row.get('landmarks_false') for row in rows):
            print(CONFIRM_NOTE)
    return 0 if all(row.get('node_alive', True) for row in rows) else 1


if __name__ == '__main__':
    sys.exit(main())
