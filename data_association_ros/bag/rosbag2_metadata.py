"""metadata.yaml of a rosbag2 bag (Jazzy writes version 9), built and parsed as plain dicts."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

import yaml

INFINITE = {'sec': 9223372036, 'nsec': 854775807}
"""rmw's 'infinite' duration as rosbag2 writes it."""


def reliable_qos_profile(depth: int = 10, durability: str = 'volatile') -> dict[str, Any]:
    """The offered QoS of a reliable keep-last publisher (rosbag2 v9 form); durability
    'volatile' (default) or 'transient_local' (a map published once)."""
    return {'history': 'keep_last', 'depth': depth, 'reliability': 'reliable',
            'durability': durability, 'deadline': dict(INFINITE), 'lifespan': dict(INFINITE),
            'liveliness': 'automatic', 'liveliness_lease_duration': dict(INFINITE),
            'avoid_ros_namespace_conventions': False}


@dataclass
class TopicRecord:
    """One topic of a bag: name, type, serialization, offered QoS, type hash, message count."""

    name: str
    type: str
    type_description_hash: str = ''
    message_count: int = 0
    serialization_format: str = 'cdr'
    offered_qos_profiles: tuple = ()


def metadata_document(file_name: str, topics: list[TopicRecord], starting_time_ns: int,
                      duration_ns: int, custom_data: Optional[dict[str, str]] = None
                      ) -> dict[str, Any]:
    """The metadata.yaml content (version 9) for one MCAP file holding every message;
    custom_data: string -> string, as rosbag2 keeps it."""
    message_count = sum(t.message_count for t in topics)
    return {'rosbag2_bagfile_information': {
        'version': 9,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration_ns},
        'starting_time': {'nanoseconds_since_epoch': starting_time_ns},
        'message_count': message_count,
        'topics_with_message_count': [{
            'topic_metadata': {
                'name': t.name, 'type': t.type,
                'serialization_format': t.serialization_format,
                'offered_qos_profiles': [dict(p) for p in t.offered_qos_profiles],
                'type_description_hash': t.type_description_hash},
            'message_count': t.message_count} for t in topics],
        'compression_format': '',
        'compression_mode': '',
        'relative_file_paths': [file_name],
        'files': [{'path': file_name,
                   'starting_time': {'nanoseconds_since_epoch': starting_time_ns},
                   'duration': {'nanoseconds': duration_ns},
                   'message_count': message_count}],
        'custom_data': dict(custom_data) if custom_data else None,
        'ros_distro': 'jazzy',
    }}


def write_metadata(directory: Path, document: dict[str, Any]) -> None:
    """Write metadata.yaml (block style, keys in rosbag2's order)."""
    text = yaml.safe_dump(document, sort_keys=False, default_flow_style=False)
    (directory / 'metadata.yaml').write_text(text)


def read_custom_data(bag: Path) -> dict[str, str]:
    """custom_data of a bag directory's metadata.yaml ({} when it has none or no metadata)."""
    if not (Path(bag) / 'metadata.yaml').is_file():
        return {}
    return read_metadata(Path(bag)).get('custom_data') or {}


def read_metadata(directory: Path) -> dict[str, Any]:
    """The rosbag2_bagfile_information mapping of a bag directory's metadata.yaml."""
    document = yaml.safe_load((directory / 'metadata.yaml').read_text())
    if not isinstance(document, dict) or 'rosbag2_bagfile_information' not in document:
        raise ValueError(f'{directory / "metadata.yaml"}: no rosbag2_bagfile_information')
    return document['rosbag2_bagfile_information']
