"""Rewrite config/association.yaml and the parameter tables of the README and docs/ pages from the declarations
(association_node, ekf_slam_node, box_tracker_node, lidar_tracker_node).

Run after changing a parameter: python scripts/update_parameter_docs.py (the tests check that
both files match the declarations).
"""
from __future__ import annotations

import pathlib
import re

from data_association_ros.pipelines.parameters import NODE_PARAMETERS
from data_association_ros.bag.parameter_arguments import float_text
from data_association_ros.nodes.box_tracker_node import TRACKER_PARAMETERS
from data_association_ros.nodes.lidar_tracker_node import LIDAR_NODE_PARAMETERS
from data_association_ros.pipelines.slam import SLAM_PARAMETERS

ROOT = pathlib.Path(__file__).resolve().parents[1]
TABLES = (('parameters', NODE_PARAMETERS, 'README.md'),
          ('slam-parameters', SLAM_PARAMETERS, 'docs/slam.md'),
          ('box-parameters', TRACKER_PARAMETERS, 'docs/mot.md'),
          ('lidar-parameters', LIDAR_NODE_PARAMETERS, 'docs/lidar.md'))
"""(marker name, the declarations of its table, the page that holds it)."""


def yaml_value(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        return float_text(value)
    if isinstance(value, list):
        return '[' + ', '.join(yaml_value(float(v)) for v in value) + ']'
    return str(value)


def config_text() -> str:
    lines = ['# Every parameter of association_node with its default (README: "Parameters").',
             '# ros2 run data_association_ros association_node --ros-args --params-file '
             'association.yaml', 'association_node:', '  ros__parameters:']
    for p in NODE_PARAMETERS:
        read_only = ' [read-only]' if p.read_only else ''
        lines.append(f'    # {p.description} (valid: {p.range_text()}){read_only}')
        lines.append(f'    {p.name}: {yaml_value(p.default)}')
    return '\n'.join(lines) + '\n'


def readme_table(parameters=NODE_PARAMETERS) -> str:
    rows = ['| parameter | default | valid | run-time | meaning |', '|---|---|---|---|---|']
    for p in parameters:
        rows.append(f'| `{p.name}` | `{yaml_value(p.default)}` | {p.range_text()} | '
                    f'{"no (read-only)" if p.read_only else "yes"} | {p.description} |')
    return '\n'.join(rows)


def main() -> None:
    (ROOT / 'config' / 'association.yaml').write_text(config_text())
    for name, parameters, page in TABLES:
        text = (ROOT / page).read_text()
        begin, end = f'<!-- {name}:begin -->', f'<!-- {name}:end -->'
        pattern = re.compile(re.escape(begin) + '.*?' + re.escape(end), re.S)
        text = pattern.sub(lambda _: f'{begin}\n{readme_table(parameters)}\n{end}', text)
        (ROOT / page).write_text(text)


if __name__ == '__main__':
    main()
