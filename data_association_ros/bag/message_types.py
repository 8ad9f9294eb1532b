"""ROS message types for bags: class lookup, the ros2msg schema text and the type hash.

The `.msg` and `.json` files come from the installed interface packages
(`<prefix>/share/<pkg>/msg/`), found through AMENT_PREFIX_PATH and the Python prefix.
"""
from __future__ import annotations

import importlib
import json
import os
import re
import sys
from functools import lru_cache
from pathlib import Path

PRIMITIVES = {'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
              'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'}
SEPARATOR = '=' * 80


class MessageTypeError(LookupError):
    """A message type that is not installed (or whose definition files are missing)."""


def type_name_of(msg_or_class) -> str:
    """'pkg/msg/Type' of a message instance or class."""
    cls = msg_or_class if isinstance(msg_or_class, type) else type(msg_or_class)
    package = cls.__module__.split('.')[0]
    return f'{package}/msg/{cls.__name__}'


@lru_cache(maxsize=None)
def message_class(type_name: str):
    """The Python class of 'pkg/msg/Type' (or 'pkg/Type'); MessageTypeError if not installed."""
    package, _, name = _split(type_name)
    try:
        return getattr(importlib.import_module(f'{package}.msg'), name)
    except (ImportError, AttributeError):
        raise MessageTypeError(f'message type {type_name} is not installed') from None


def _split(type_name: str) -> tuple[str, str, str]:
    parts = type_name.split('/')
    if len(parts) == 3:
        return parts[0], parts[1], parts[2]
    if len(parts) == 2:
        return parts[0], 'msg', parts[1]
    raise MessageTypeError(f'not a message type name: {type_name!r}')


def _prefixes() -> list[Path]:
    paths = [Path(p) for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    return paths + [Path(sys.prefix), Path(sys.base_prefix)]


def _interface_file(type_name: str, suffix: str) -> Path:
    package, kind, name = _split(type_name)
    for prefix in _prefixes():
        path = prefix / 'share' / package / kind / f'{name}{suffix}'
        if path.is_file():
            return path
    raise MessageTypeError(f'{package}/{kind}/{name}{suffix} not found under '
                           f'{", ".join(map(str, _prefixes()))}')


def _dependencies(package: str, text: str) -> list[str]:
    """'pkg/Type' of every non-primitive field type in a .msg text, in order of appearance."""
    found = []
    for line in text.splitlines():
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        base = re.split(r'[\[<]', line.split()[0], maxsplit=1)[0]
        if base in PRIMITIVES:
            continue
        if '/' in base:
            dep_package, dep_name = base.split('/')[0], base.split('/')[-1]
        else:
            dep_package, dep_name = package, base
        found.append(f'{dep_package}/{dep_name}')
    return found


@lru_cache(maxsize=None)
def schema_text(type_name: str) -> str:
    """The ros2msg schema of a type: its .msg text, then each dependency (depth first, once)
    as a line of 80 '=', 'MSG: pkg/Type' and its text (as rosbag2 writes it)."""
    package, _, name = _split(type_name)
    text = _interface_file(type_name, '.msg').read_text()
    parts, seen = [text.rstrip('\n')], set()

    def visit(pkg: str, source: str) -> None:
        for dep in _dependencies(pkg, source):
            if dep in seen:
                continue
            seen.add(dep)
            dep_package, dep_name = dep.split('/')
            dep_text = _interface_file(f'{dep_package}/msg/{dep_name}', '.msg').read_text()
            parts.append(f'{SEPARATOR}\nMSG: {dep}\n{dep_text.rstrip(chr(10))}')
            visit(dep_package, dep_text)

    visit(package, text)
    return '\n'.join(parts) + '\n'


@lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """The RIHS01_... type description hash of a type, from share/<pkg>/msg/<Type>.json."""
    package, kind, name = _split(type_name)
    full = f'{package}/{kind}/{name}'
    data = json.loads(_interface_file(type_name, '.json').read_text())
    for entry in data.get('type_hashes', []):
        if entry.get('type_name') == full:
            return entry['hash_string']
    raise MessageTypeError(f'no type hash for {full} in its .json description')
