"""MOTChallenge data as a bag, and box tracking scored with TrackEval.

    da_make_mot_bag [SEQUENCE_DIR] [--out mot_<sequence>] [--fps 25] [--force]
    da_mot_eval [BAG] [--algorithms iou,mahalanobis_nn,gnn,jcbb] [--min-hits 3] [--max-age 1]
                [--iou-threshold 0.3]

A sequence folder in the MOTChallenge layout (det/det.txt, gt/gt.txt, seqinfo.ini with the
frame rate and image size) or flat (det.txt, gt.txt).  Text rows: frame, id, bb_left, bb_top,
bb_width, bb_height, conf, then x, y, z (MOT15) or class, visibility (MOT16+); detections have
id -1.  Ground-truth rows the MOT evaluation ignores (conf 0, classes other than pedestrian)
are dropped.  In the bag, frame k is stamped (k - 1) / fps s; /observations holds the
detections (x, y = box centre, width, height, score; frame 'camera') and /ground_truth/tracks the
true boxes (id, x, y, width, height); its metadata names the sequence.

Scores (TrackEval's CLEAR, Identity and HOTA on IoU
similarity, MOTA matching at IoU 0.5 as motmetrics does): TrackEval is maintained and runs on
NumPy 2, where motmetrics 1.4.0 calls the removed np.asfarray.
"""
from __future__ import annotations

import argparse
import configparser
import sys
import time
from pathlib import Path
from typing import Iterable, Optional

import numpy as np

from ..core.associators.iou import iou_matrix
from ..core.tracking import BoxTracker
from .reader import BagError, BagReader

DATA = Path(__file__).resolve().parents[2].parent / 'shared' / 'data' / 'mot' / 'TUD-Campus'
BAG = Path(__file__).resolve().parents[2] / 'bags' / 'mot_tud_campus'
DETECTIONS, TRUTH = '/observations', '/ground_truth/tracks'
DETECTION_DTYPE = np.dtype([('x', '<f4'), ('y', '<f4'), ('width', '<f4'), ('height', '<f4'),
                            ('score', '<f4')])
TRUTH_DTYPE = np.dtype([('id', '<i4'), ('x', '<f4'), ('y', '<f4'), ('width', '<f4'),
                        ('height', '<f4')])
SORT_PUBLISHED = {'MOTA': 62.7, 'IDF1': 60.6, 'IDSW': 6, 'FP': 15, 'FN': 113}
"""SORT (abewley/sort, default parameters) on these detections, motmetrics at IoU 0.5."""
SORT_SEQUENCE = 'TUD-Campus'
"""The only sequence SORT_PUBLISHED belongs to."""
SEQUENCE_KEY = 'data_association_ros.mot.sequence'
FPS_KEY = 'data_association_ros.mot.fps'
IMAGE_SIZE_KEY = 'data_association_ros.mot.image_size'
"""custom_data keys of a MOT bag: sequence name, frame rate, image size (WIDTHxHEIGHT)."""
PEDESTRIAN = 1


def sequence_files(data: Path) -> tuple[Path, Path, dict[str, str]]:
    """(det.txt, gt.txt, seqinfo.ini's [Sequence] or {}) of a sequence folder, in the
    MOTChallenge layout (det/det.txt, gt/gt.txt) or flat (det.txt, gt.txt)."""
    standard = (data / 'det' / 'det.txt', data / 'gt' / 'gt.txt')
    det, gt = standard if all(p.is_file() for p in standard) else (data / 'det.txt',
                                                                      data / 'gt.txt')
    info: dict[str, str] = {}
    if (data / 'seqinfo.ini').is_file():
        parser = configparser.ConfigParser()
        parser.read(data / 'seqinfo.ini')
        if parser.has_section('Sequence'):
            info = dict(parser['Sequence'])
    return det, gt, info


def evaluated_truth(rows: np.ndarray) -> np.ndarray:
    """The ground-truth rows the MOT evaluation counts: conf (column 7) not 0 and, where
    column 8 is a class (MOT16+; -1 in MOT15), pedestrians only."""
    keep = rows[:, 6] != 0
    if rows.shape[1] > 7:
        keep &= (rows[:, 7] == PEDESTRIAN) | (rows[:, 7] == -1)
    return rows[keep]


def read_mot(path: Path) -> dict[int, np.ndarray]:
    """{frame: rows (n, columns)} of a MOTChallenge text file (frames in the file only)."""
    return read_mot_rows(np.loadtxt(path, delimiter=',', ndmin=2))


def read_mot_rows(rows: np.ndarray) -> dict[int, np.ndarray]:
    """{frame: rows} of MOTChallenge rows (frames present only)."""
    return {int(f): rows[rows[:, 0] == f] for f in np.unique(rows[:, 0])}


def centre_boxes(rows: np.ndarray) -> np.ndarray:
    """(left, top, w, h) columns 2-5 -> (centre x, centre y, w, h) (n, 4)."""
    return np.column_stack([rows[:, 2] + rows[:, 4] / 2, rows[:, 3] + rows[:, 5] / 2,
                            rows[:, 4], rows[:, 5]])


def make_mot_bag(data: Path, out: Path, fps: Optional[float] = None) -> Path:
    """Write (replace) the bag `out` of the sequence folder `data` (see the module docstring);
    fps: seqinfo.ini's frameRate when None (25 without one)."""
    import shutil

    from msg_adapters import array_to_cloud
    from std_msgs.msg import Header

    from .writer import BagWriter
    det, gt, info = sequence_files(data)
    fps = fps if fps is not None else float(info.get('framerate', 25.0))
    detections = read_mot(det)
    rows = np.loadtxt(gt, delimiter=',', ndmin=2)
    truth = read_mot_rows(evaluated_truth(rows))
    frames = range(1, max(max(detections), max(truth, default=0)) + 1)
    custom = {SEQUENCE_KEY: info.get('name', data.resolve().name), FPS_KEY: f'{fps:g}'}
    if 'imwidth' in info and 'imheight' in info:
        custom[IMAGE_SIZE_KEY] = f'{info["imwidth"]}x{info["imheight"]}'
    if out.exists():
        shutil.rmtree(out)
    with BagWriter(out, out.name, custom_data=custom) as bag:
        for frame in frames:
            stamp_ns = int(round((frame - 1) / fps * 1e9))
            header = Header(frame_id='camera')
            header.stamp.sec, header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
            rows = detections.get(frame, np.zeros((0, 10)))
            points = np.zeros(len(rows), dtype=DETECTION_DTYPE)
            boxes = centre_boxes(rows)
            for k, name in enumerate(('x', 'y', 'width', 'height')):
                points[name] = boxes[:, k]
            points['score'] = rows[:, 6]
            bag.write(DETECTIONS, array_to_cloud(points, header), stamp_ns)
            rows = truth.get(frame, np.zeros((0, 10)))
            points = np.zeros(len(rows), dtype=TRUTH_DTYPE)
            boxes = centre_boxes(rows)
            points['id'] = rows[:, 1]
            for k, name in enumerate(('x', 'y', 'width', 'height')):
                points[name] = boxes[:, k]
            bag.write(TRUTH, array_to_cloud(points, header), stamp_ns)
    return out


def read_mot_bag(bag: Path) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """(detections per frame [(K, 4) boxes], truth per frame [structured id, x, y, w, h])."""
    from msg_adapters import cloud_to_array
    reader = BagReader(bag)
    reader.require([DETECTIONS, TRUTH])
    detections: dict[int, np.ndarray] = {}
    truth: dict[int, np.ndarray] = {}
    for message in reader.messages([DETECTIONS, TRUTH]):
        stamp = message.msg.header.stamp.sec * 1_000_000_000 + message.msg.header.stamp.nanosec
        points = cloud_to_array(message.msg)
        if message.topic == DETECTIONS:
            detections[stamp] = np.column_stack(
                [points[n].astype(float) for n in ('x', 'y', 'width', 'height')])
        else:
            truth[stamp] = points
    stamps = sorted(detections)
    return [detections[s] for s in stamps], [truth.get(s, np.zeros(0, TRUTH_DTYPE))
                                             for s in stamps]


def track(frames: Iterable[np.ndarray], tracker: BoxTracker) -> tuple[list, float]:
    """(reported tracks per frame, frames per second of the tracker loop)."""
    frames = list(frames)
    started = time.perf_counter()
    outputs = [tracker.step(boxes) for boxes in frames]
    elapsed = time.perf_counter() - started
    return outputs, len(frames) / elapsed if elapsed else float('inf')


def score(truth: list[np.ndarray], outputs: list[list[tuple[int, np.ndarray]]]) -> dict:
    """TrackEval CLEAR (MOTA, IDSW, FP, FN at IoU 0.5), Identity (IDF1) and HOTA."""
    try:
        from trackeval.metrics import CLEAR, HOTA, Identity
    except ImportError:
        raise ValueError('scoring needs TrackEval: pip install trackeval') from None
    gt_index = {int(i): k for k, i in enumerate(sorted({int(i) for t in truth for i in t['id']}))}
    tr_index = {i: k for k, i in enumerate(sorted({i for out in outputs for i, _ in out}))}
    data = {'num_timesteps': len(truth), 'num_gt_ids': len(gt_index),
            'num_tracker_ids': len(tr_index),
            'num_gt_dets': int(sum(len(t) for t in truth)),
            'num_tracker_dets': int(sum(len(o) for o in outputs)),
            'gt_ids': [], 'tracker_ids': [], 'similarity_scores': []}
    for true, out in zip(truth, outputs):
        gt_boxes = np.column_stack([true[n].astype(float) for n in
                                    ('x', 'y', 'width', 'height')]).reshape(-1, 4)
        tr_boxes = np.array([b for _, b in out]).reshape(-1, 4)
        data['gt_ids'].append(np.array([gt_index[int(i)] for i in true['id']], dtype=int))
        data['tracker_ids'].append(np.array([tr_index[i] for i, _ in out], dtype=int))
        data['similarity_scores'].append(iou_matrix(gt_boxes, tr_boxes))
    clear = CLEAR({'THRESHOLD': 0.5, 'PRINT_CONFIG': False}).eval_sequence(data)
    identity = Identity({'THRESHOLD': 0.5, 'PRINT_CONFIG': False}).eval_sequence(data)
    hota = HOTA().eval_sequence(data)
    return {'MOTA': 100 * clear['MOTA'], 'IDF1': 100 * identity['IDF1'],
            'HOTA': 100 * float(np.mean(hota['HOTA'])), 'IDSW': int(clear['IDSW']),
            'FP': int(clear['CLR_FP']), 'FN': int(clear['CLR_FN'])}


def evaluate(bag: Path, algorithm: str, min_hits: int = 3, max_age: int = 1,
             parameters: Optional[dict] = None, noise_scale: float = 1.0) -> dict:
    """Scores and tracker frames per second of one associator on a MOT bag."""
    frames, truth = read_mot_bag(bag)
    tracker = BoxTracker(algorithm, min_hits, max_age, parameters if parameters is not None
                         else default_parameters(algorithm), noise_scale=noise_scale)
    outputs, fps = track(frames, tracker)
    return {**score(truth, outputs), 'fps': fps}


def default_parameters(algorithm: str, iou_threshold: float = 0.3) -> dict:
    """SORT's IoU threshold for `iou`; the associator's defaults otherwise."""
    return {'iou_threshold': iou_threshold} if algorithm == 'iou' else {}


def make_main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog='da_make_mot_bag', description='Convert a MOTChallenge sequence (detections and '
        'ground truth) into a rosbag2 bag for da_mot_eval and box_tracker_node.')
    parser.add_argument('data', type=Path, nargs='?', default=DATA,
                        help='sequence folder: det/det.txt, gt/gt.txt [, seqinfo.ini] or det.txt, '
                             f'gt.txt (default: {DATA})')
    parser.add_argument('--out', type=Path,
                        help='output bag directory (default: mot_<sequence> in the current '
                             'directory); never replaced without --force')
    parser.add_argument('--fps', type=float,
                        help="frame rate (default: seqinfo.ini's frameRate, else 25)")
    parser.add_argument('--force', action='store_true', help='replace --out when it exists')
    args = parser.parse_args(argv)
    det, gt, info = sequence_files(args.data)
    for path in (det, gt):
        if not path.is_file():
            print(f'da_make_mot_bag: {path} not found (expected det/det.txt and gt/gt.txt, or '
                  f'det.txt and gt.txt, in {args.data})', file=sys.stderr)
            return 2
    name = info.get('name', args.data.resolve().name)
    out = args.out or Path('mot_' + name.lower().replace('-', '_'))
    if out.exists() and not args.force:
        print(f'da_make_mot_bag: {out} exists; choose another --out or add --force to replace '
              'it', file=sys.stderr)
        return 2
    print(make_mot_bag(args.data, out, args.fps))
    return 0


def eval_main(argv: Optional[list[str]] = None) -> int:
    parser = argparse.ArgumentParser(
        prog='da_mot_eval', description='Track the boxes of a MOT bag (da_make_mot_bag) with '
        'each associator in SORT\'s tracker and score them with TrackEval.')
    parser.add_argument('bag', type=Path, nargs='?', default=BAG,
                        help=f'MOT bag (default: {BAG})')
    parser.add_argument('--algorithms', default='iou,mahalanobis_nn,gnn,jcbb',
                        help='comma-separated box associators (default: %(default)s)')
    parser.add_argument('--min-hits', type=int, default=3,
                        help='a track is reported once updated on this many frames in a row '
                             '(default: %(default)s)')
    parser.add_argument('--max-age', type=int, default=1,
                        help='a track not updated for more than this many frames is deleted '
                             '(default: %(default)s)')
    parser.add_argument('--iou-threshold', type=float, default=0.3,
                        help='iou: pairs below this IoU are rejected (default: %(default)s)')
    parser.add_argument('--noise-scale', type=float, default=1.0,
                        help="multiplies SORT's R and Q (covariance-gated associators)")
    args = parser.parse_args(argv)
    try:
        sequence = mot_sequence(args.bag)
        read_mot_bag(args.bag)   # a clear error before the table when the bag is unusable
        print(f'{args.bag} ({sequence or "sequence unknown"}; min_hits {args.min_hits}, max_age '
              f'{args.max_age}, noise_scale {args.noise_scale:g})')
        print(f'{"tracker":<22}{"MOTA%":>8}{"IDF1%":>8}{"HOTA%":>8}{"IDSW":>6}{"FP":>6}{"FN":>6}'
              f'{"frames/s":>10}')
        if sequence == SORT_SEQUENCE:
            s = SORT_PUBLISHED
            print(f'{"SORT (published)":<22}{s["MOTA"]:>8.1f}{s["IDF1"]:>8.1f}{"-":>8}'
                  f'{s["IDSW"]:>6}{s["FP"]:>6}{s["FN"]:>6}{"-":>10}')
        for algorithm in args.algorithms.split(','):
            r = evaluate(args.bag, algorithm, args.min_hits, args.max_age,
                         default_parameters(algorithm, args.iou_threshold), args.noise_scale)
            print(f'{algorithm:<22}{r["MOTA"]:>8.1f}{r["IDF1"]:>8.1f}{r["HOTA"]:>8.1f}'
                  f'{r["IDSW"]:>6}{r["FP"]:>6}{r["FN"]:>6}{r["fps"]:>10.0f}')
    except (BagError, ValueError) as error:
        print(f'da_mot_eval: {error}', file=sys.stderr)
        return 2
    print('MOTA%, IDF1%, HOTA%: CLEAR MOTA, identity F1 and HOTA (IoU 0.5); IDSW: identity\n'
          'switches; FP, FN: false and missed boxes; frames/s: tracker loop speed; -: not '
          'measured')
    return 0


def mot_sequence(bag: Path) -> Optional[str]:
    """The sequence name in a MOT bag's metadata (None when not recorded)."""
    from .rosbag2_metadata import read_custom_data
    return read_custom_data(bag).get(SEQUENCE_KEY) if Path(bag).is_dir() else None
