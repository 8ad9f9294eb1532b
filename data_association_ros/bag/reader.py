"""Read a rosbag2 bag directory (metadata.yaml + .mcap files), a directory holding .mcap files,
or a bare .mcap file; messages in log-time order, deserialised with rclpy where installed."""
from __future__ import annotations

import struct
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Iterator, Optional

from mcap.exceptions import McapError
from mcap.reader import make_reader
from rclpy.serialization import deserialize_message

from .message_types import MessageTypeError, message_class
from .rosbag2_metadata import read_metadata


class BagError(RuntimeError):
    """A bag that cannot be read: missing, truncated, corrupt, or without a wanted topic."""


@dataclass
class BagMessage:
    """One message: topic, type, log time [ns], CDR bytes and (when deserialised) the message."""

    topic: str
    type_name: str
    log_time_ns: int
    data: bytes
    msg: Any = None


class BagReader:
    """Opens a bag and lists its topics; `messages()` iterates them in log-time order."""

    def __init__(self, path) -> None:
        self.path = Path(path)
        if not self.path.exists():
            raise BagError(f'{self.path}: no such bag')
        if self.path.is_file():
            self.files = [self.path]
        elif (self.path / 'metadata.yaml').is_file():
            try:
                metadata = read_metadata(self.path)
                names = metadata.get('relative_file_paths') or [
                    f['path'] for f in metadata.get('files', [])]
            except Exception as error:
                raise BagError(f'{self.path / "metadata.yaml"}: unreadable ({error})') from None
            self.files = [self.path / name for name in names]
        else:
            self.files = sorted(self.path.glob('*.mcap'))
        if not self.files:
            raise BagError(f'{self.path}: no .mcap file')
        for file in self.files:
            if not file.is_file():
                raise BagError(f'{file}: listed in metadata.yaml but missing')
        self.topics: dict[str, str] = {}
        self.skipped_types: Counter = Counter()
        """Messages skipped because their type is not installed, by type name."""
        for file in self.files:
            summary = self._summary(file)
            for channel in summary.channels.values():
                schema = summary.schemas.get(channel.schema_id)
                self.topics[channel.topic] = schema.name if schema else ''

    def _summary(self, file: Path):
        try:
            with open(file, 'rb') as stream:
                summary = make_reader(stream).get_summary()
        except (McapError, struct.error, ValueError, EOFError, OSError) as error:
            raise BagError(f'{file}: truncated or corrupt MCAP file ({error})') from None
        if summary is None:
            raise BagError(f'{file}: truncated or corrupt MCAP file (no summary section)')
        return summary

    def require(self, topics: Iterable[str]) -> None:
        """Raise BagError naming the first of `topics` the bag does not have."""
        for topic in topics:
            if topic not in self.topics:
                raise BagError(f'{self.path}: this bag has no {topic} topic (it has '
                               f'{", ".join(sorted(self.topics)) or "no topics"})')

    def messages(self, topics: Optional[Iterable[str]] = None,
                 deserialize: bool = True) -> Iterator[BagMessage]:
        """Messages of `topics` (all when None) in log-time order.  With deserialize, a wanted
        topic whose type is not installed raises; unwanted ones are skipped."""
        wanted = None if topics is None else set(topics)
        if wanted is not None:
            self.require(wanted)
            if deserialize:
                for topic in wanted:
                    message_class(self.topics[topic])
        for file in self.files:
            try:
                with open(file, 'rb') as stream:
                    reader = make_reader(stream)
                    for schema, channel, message in reader.iter_messages(
                            topics=None if wanted is None else sorted(wanted),
                            log_time_order=True):
                        type_name = schema.name if schema else ''
                        msg = None
                        if deserialize:
                            try:
                                msg = deserialize_message(message.data, message_class(type_name))
                            except MessageTypeError:
                                self.skipped_types[type_name] += 1
                                continue
                        yield BagMessage(channel.topic, type_name, message.log_time,
                                         bytes(message.data), msg)
            except (McapError, struct.error, EOFError) as error:
                raise BagError(f'{file}: truncated or corrupt MCAP file ({error})') from None
