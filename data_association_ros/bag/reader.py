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
    """A bag that cannot be read: missing, truncated, corrupt, not MCAP, or without a wanted
    topic of the wanted type."""


MCAP_MAGIC = b'\x89MCAP0\r\n'
SQLITE_MAGIC = b'SQLite format 3\x00'


def sqlite_error(path: Path) -> BagError:
    """The error for a rosbag2 sqlite3 bag: only MCAP is read; how to convert it."""
    return BagError(
        f'{path}: a sqlite3 (.db3) bag; only the MCAP storage is read. Convert it on a ROS 2 '
        f'install: ros2 bag convert -i {path} -o out.yaml, where out.yaml holds '
        f'"output_bags: [{{uri: {path.name}_mcap, storage_id: mcap}}]"')


def _file_kind(path: Path) -> str:
    """'mcap', 'sqlite3' or 'other', from the file's first bytes."""
    with open(path, 'rb') as stream:
        head = stream.read(len(SQLITE_MAGIC))
    if head.startswith(MCAP_MAGIC):
        return 'mcap'
    return 'sqlite3' if head.startswith(SQLITE_MAGIC) else 'other'


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
            if metadata.get('storage_identifier') == 'sqlite3':
                raise sqlite_error(self.path)
            self.files = [self.path / name for name in names]
        else:
            self.files = sorted(self.path.glob('*.mcap'))
            if not self.files and any(self.path.glob('*.db3')):
                raise sqlite_error(self.path)
        if not self.files:
            raise BagError(f'{self.path}: not a bag (no metadata.yaml and no .mcap file)')
        for file in self.files:
            if not file.is_file():
                raise BagError(f'{file}: listed in metadata.yaml but missing')
            kind = _file_kind(file)
            if kind == 'sqlite3':
                raise sqlite_error(file)
            if kind != 'mcap':
                raise BagError(f'{file}: not a bag (neither an MCAP file nor a rosbag2 bag '
                               'directory)')
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

    def check_type(self, topic: str) -> None:
        """BagError naming `topic`, its type and the expected one when the bag tools cannot
        read it: another type than topics.EXPECTED_TYPES lists, or a type not installed."""
        from .topics import EXPECTED_TYPES
        found = self.topics[topic]
        parts = found.split('/')
        normal = f'{parts[0]}/msg/{parts[1]}' if len(parts) == 2 else found
        expected = EXPECTED_TYPES.get(topic, ())
        try:
            message_class(found)
            installed = True
        except MessageTypeError:
            installed = False
        if (expected and normal not in expected) or not installed:
            raise BagError(f'{self.path}: topic {topic} has type {found or "(no schema)"}'
                           f'{"" if installed else " (not installed here)"}, expected '
                           f'{" or ".join(expected) or "an installed type"}')

    def messages(self, topics: Optional[Iterable[str]] = None,
                 deserialize: bool = True) -> Iterator[BagMessage]:
        """Messages of `topics` (all when None) in log-time order.  With deserialize, a wanted
        topic of an unexpected or uninstalled type raises BagError (check_type); messages of
        other topics whose type is not installed are skipped."""
        wanted = None if topics is None else set(topics)
        if wanted is not None:
            self.require(wanted)
            if deserialize:
                for topic in sorted(wanted):
                    self.check_type(topic)
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
