"""Per-object LiDAR scores (`da_lidar_eval --scenes ... --objects OUT.csv`): issue 21's share per
set of seeds, or two runs compared object by object.

    python benchmarks/lidar_objects.py sets OUT.csv [--size 30]
    python benchmarks/lidar_objects.py compare BEFORE.csv AFTER.csv

sets: per kind (and LiDAR) the objects within all limits with no id switch (the CSV's `passes`)
over all seeds, then per set of `size` consecutive seeds (from the file's smallest seed s0:
seeds s0 + i size ... s0 + (i + 1) size - 1, the same sets for every kind), the sets under
issue 21's 95 % marked.

compare: every object that passes in one run and not in the other (FIXED / BROKEN, with both
runs' position [m], heading [deg], velocity [m/s] RMSE and id switches; an object scored in one
run only counts as not passing in the other), how many objects' scores moved at all, and per
kind (and LiDAR) the passes before -> after.  The way each change of the tracker was measured
(docs/lidar.md).
"""
from __future__ import annotations

import argparse
import csv
import sys
from collections import defaultdict
from pathlib import Path

GOAL = 0.95
"""Issue 21: at least this share of the objects within all limits with no id switch."""
SCORES = ('position_rmse_m', 'heading_rmse_deg', 'velocity_rmse_mps', 'id_switches')

Key = tuple[str, str, int, int]


COLUMNS = ('kind', 'lidar', 'seed', 'object', 'passes') + SCORES


class ObjectsFileError(ValueError):
    """A file that is not a readable --objects CSV (the message says why)."""


def read_objects(path: Path) -> dict[Key, dict]:
    """{(kind, lidar, seed, object): row} of one --objects CSV; ObjectsFileError when it cannot
    be read or lacks a column of COLUMNS."""
    try:
        with open(path, newline='') as file:
            reader = csv.DictReader(file)
            missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
            if missing:
                raise ObjectsFileError(f'{path}: no column {", ".join(missing)} (not a '
                                       f'da_lidar_eval --objects file)')
            objects = {}
            for row in reader:
                key = _key(row, path, reader.line_num)
                if key in objects:
                    raise ObjectsFileError(f'{path}, line {reader.line_num}: seed {key[2]} '
                                           f'object {key[3]} of {key[0]} listed twice')
                objects[key] = row
            return objects
    except (OSError, UnicodeDecodeError, csv.Error) as error:
        raise ObjectsFileError(f'{path}: {error}') from None


def _key(row: dict, path: Path, line: int) -> Key:
    """(kind, lidar, seed, object) of one row, its scores checked to be numbers."""
    try:
        for column in SCORES:
            float(row[column])
        return row['kind'], row['lidar'], int(row['seed']), int(row['object'])
    except (TypeError, ValueError):  # a short row (None) or a field that is no number
        raise ObjectsFileError(f'{path}, line {line}: not a complete row of numbers '
                               f'({", ".join(f"{c}={row.get(c)!r}" for c in COLUMNS)})'
                               ) from None


def passed(row: dict | None) -> bool:
    """Within all limits with no id switch (a missing row: not scored, so no)."""
    return row is not None and row['passes'] == '1'


def seed_sets(objects: dict[Key, dict], size: int) -> dict[tuple[str, str], list]:
    """{(kind, lidar): [(first seed, last seed, passing, objects), ...]} over sets of `size`
    consecutive seeds from the file's smallest seed (the same sets for every kind); sets
    without scored objects left out."""
    first = min((seed for _, _, seed, _ in objects), default=0)
    counts: dict[tuple[str, str], dict[int, list]] = defaultdict(lambda: defaultdict(
        lambda: [0, 0]))
    for (kind, lidar, seed, _), row in objects.items():
        count = counts[kind, lidar][(seed - first) // size]
        count[0] += passed(row)
        count[1] += 1
    return {group: [(first + i * size, first + (i + 1) * size - 1, good, total)
                    for i, (good, total) in sorted(sets.items())]
            for group, sets in sorted(counts.items())}


def group_name(kind: str, lidar: str) -> str:
    """A kind, with the LiDAR it was seen by unless the scene's own ('')."""
    return f'{kind} {lidar}' if lidar else kind


def describe(row: dict | None) -> str:
    """One run's scores of an object."""
    if row is None:
        return 'not scored'
    return (f"position {float(row['position_rmse_m']):.3f} m, heading "
            f"{float(row['heading_rmse_deg']):.1f} deg, velocity "
            f"{float(row['velocity_rmse_mps']):.2f} m/s, id switches {row['id_switches']}")


def compare(before: dict[Key, dict], after: dict[Key, dict]) -> tuple[list[str], int, dict]:
    """(a line per object that passes in one run only, objects whose scores moved,
    {(kind, lidar): [passing before, passing after, objects]})."""
    lines, moved = [], 0
    totals: dict[tuple[str, str], list] = defaultdict(lambda: [0, 0, 0])
    for key in sorted(set(before) | set(after)):
        old, new = before.get(key), after.get(key)
        total = totals[key[:2]]
        total[0] += passed(old)
        total[1] += passed(new)
        total[2] += 1
        if passed(old) != passed(new):
            kind, lidar, seed, number = key
            where = f'{group_name(kind, lidar)} seed {seed} object {number}'
            lines.append(f"{'FIXED' if passed(new) else 'BROKEN'} {where}: {describe(old)} -> "
                         f"{describe(new)}")
        if old is None or new is None or any(old[s] != new[s] for s in SCORES):
            moved += 1
    return lines, moved, dict(totals)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    commands = parser.add_subparsers(dest='command', required=True)
    sets = commands.add_parser('sets', help='the share within all limits per set of seeds')
    sets.add_argument('objects', type=Path)
    sets.add_argument('--size', type=int, default=30, help='seeds per set (default 30)')
    versus = commands.add_parser('compare', help='two runs object by object')
    versus.add_argument('before', type=Path)
    versus.add_argument('after', type=Path)
    args = parser.parse_args(argv)
    try:
        return _run(args, parser)
    except ObjectsFileError as error:
        parser.exit(2, f'{parser.prog}: error: {error}\n')


def _run(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    """The command of the parsed `args`."""
    if args.command == 'sets':
        if args.size < 1:
            parser.error('--size must be at least 1')
        groups = seed_sets(read_objects(args.objects), args.size)
        if not groups:
            print(f'{args.objects}: no scored objects')
        for (kind, lidar), rows in groups.items():
            good, total = sum(r[2] for r in rows), sum(r[3] for r in rows)
            under = [r for r in rows if r[2] < GOAL * r[3]]
            print(f'{group_name(kind, lidar)}: {good} / {total} '
                  f"({100 * good / total:.1f} %), {len(under)} of {len(rows)} sets of "
                  f"{args.size} seeds under {100 * GOAL:.0f} %")
            for first, last, good, total in rows:
                mark = '  <- under' if good < GOAL * total else ''
                print(f'  seeds {first}-{last}: {good} / {total} ({100 * good / total:.1f} %)'
                      f'{mark}')
        return 0
    lines, moved, totals = compare(read_objects(args.before), read_objects(args.after))
    print('\n'.join(lines) if lines else 'no object passes in one run only')
    for (kind, lidar), (old, new, total) in sorted(totals.items()):
        print(f'{group_name(kind, lidar)}: {old} -> {new} of {total}')
    print(f'objects whose scores moved: {moved} of {sum(t[2] for t in totals.values())}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
