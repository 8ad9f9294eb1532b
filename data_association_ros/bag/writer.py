"""Write a rosbag2 (Jazzy) bag: <dir>/<name>_0.mcap (profile ros2, ros2msg schemas, CDR
messages from rclpy.serialization) and <dir>/metadata.yaml (version 9)."""
from __future__ import annotations

from pathlib import Path
from typing import Optional

import yaml
from mcap.writer import Writer
from rclpy.serialization import serialize_message

from .message_types import schema_text, type_hash, type_name_of
from .rosbag2_metadata import (TopicRecord, metadata_document, reliable_qos_profile,
                               write_metadata)


class BagWriter:
    """Context manager: `with BagWriter(path) as bag: bag.write('/topic', msg, log_time_ns)`.

    Message bytes are written as given (or as serialize_message makes them); the MCAP keeps the
    mcap writer's default chunking (zstd), message indexes and statistics, which rosbag2 needs.
    """

    def __init__(self, directory, name: Optional[str] = None,
                 custom_data: Optional[dict[str, str]] = None,
                 transient_local_topics: tuple[str, ...] = ()) -> None:
        self.directory = Path(directory)
        self.custom_data = custom_data
        self.transient_local_topics = transient_local_topics
        self.directory.mkdir(parents=True, exist_ok=True)
        stem = name or self.directory.name
        self.file_name = f'{stem}_0.mcap'
        self._stream = open(self.directory / self.file_name, 'wb')
        self._writer = Writer(self._stream)
        self._writer.start(profile='ros2', library='data_association_ros bag writer')
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, tuple[int, TopicRecord]] = {}
        self._sequence = 0
        self._first: Optional[int] = None
        self._last: Optional[int] = None

    def _channel(self, topic: str, type_name: str) -> int:
        if topic in self._channels:
            channel_id, record = self._channels[topic]
            if record.type != type_name:
                raise ValueError(f'{topic}: type {type_name} after {record.type}')
            return channel_id
        if type_name not in self._schemas:
            self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding='ros2msg', data=schema_text(type_name).encode())
        record = TopicRecord(name=topic, type=type_name,
                             type_description_hash=type_hash(type_name),
                             offered_qos_profiles=(reliable_qos_profile(
                                 1 if topic in self.transient_local_topics else 10,
                                 'transient_local' if topic in self.transient_local_topics
                                 else 'volatile'),))
        qos_text = yaml.safe_dump(list(record.offered_qos_profiles), sort_keys=False)
        channel_id = self._writer.register_channel(
            topic=topic, message_encoding='cdr', schema_id=self._schemas[type_name],
            metadata={'offered_qos_profiles': qos_text,
                      'topic_type_hash': record.type_description_hash})
        self._channels[topic] = (channel_id, record)
        return channel_id

    def write(self, topic: str, msg, log_time_ns: int) -> None:
        """Serialise `msg` with rclpy and write it at `log_time_ns`."""
        self.write_serialized(topic, type_name_of(msg), serialize_message(msg), log_time_ns)

    def write_serialized(self, topic: str, type_name: str, data: bytes, log_time_ns: int,
                         publish_time_ns: Optional[int] = None) -> None:
        """Write CDR bytes of a `type_name` message at `log_time_ns`."""
        channel_id = self._channel(topic, type_name)
        self._writer.add_message(channel_id=channel_id, log_time=int(log_time_ns), data=data,
                                 publish_time=int(log_time_ns if publish_time_ns is None
                                                  else publish_time_ns),
                                 sequence=self._sequence)
        self._sequence += 1
        self._channels[topic][1].message_count += 1
        self._first = log_time_ns if self._first is None else min(self._first, log_time_ns)
        self._last = log_time_ns if self._last is None else max(self._last, log_time_ns)

    def close(self) -> None:
        """Finish the MCAP (summary, indexes, statistics) and write metadata.yaml."""
        if self._stream.closed:
            return
        self._writer.finish()
        self._stream.close()
        first = self._first or 0
        duration = (self._last or 0) - first
        write_metadata(self.directory, metadata_document(
            self.file_name, [record for _, record in self._channels.values()], first, duration,
            self.custom_data))

    def __enter__(self) -> 'BagWriter':
        return self

    def __exit__(self, *exc) -> None:
        self.close()
