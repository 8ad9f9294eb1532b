"""Rewrite config/association.yaml and the README's parameter table from NODE_PARAMETERS.

Run after changing a parameter: python scripts/update_parameter_docs.py (the tests check that
both files match the declarations).
"""
from __future__ import annotations

import pathlib
import re

from data_association_ros.node_parameters import NODE_PARAMETERS

ROOT = pathlib.Path(__file__).resolve().parents[1]
BEGIN, END = '<!-- parameters:begin -->', '<!-- parameters:end -->'


def yaml_value(value) -> str:
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, float):
        text = repr(value)
        return text.replace('e-', '.0e-') if 'e' in text and '.' not in text else text
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


def readme_table() -> str:
    rows = ['| parameter | default | valid | run-time | meaning |', '|---|---|---|---|---|']
    for p in NODE_PARAMETERS:
        rows.append(f'| `{p.name}` | `{yaml_value(p.default)}` | {p.range_text()} | '
                    f'{"no (read-only)" if p.read_only else "yes"} | {p.description} |')
    return '\n'.join(rows)


def main() -> None:
    (ROOT / 'config' / 'association.yaml').write_text(config_text())
    readme = (ROOT / 'README.md').read_text()
    pattern = re.compile(re.escape(BEGIN) + '.*?' + re.escape(END), re.S)
    readme = pattern.sub(lambda _: f'{BEGIN}\n{readme_table()}\n{END}', readme)
    (ROOT / 'README.md').write_text(readme)


if __name__ == '__main__':
    main()
