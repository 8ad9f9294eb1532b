"""A short history of stamped items for time matching (no ROS types: stamps in nanoseconds)."""
from __future__ import annotations

import bisect
from typing import Any, Generic, Optional, TypeVar

Item = TypeVar('Item')


class StampedBuffer(Generic[Item]):
    """The last `capacity` items ordered by stamp (ns); out-of-order arrivals are inserted."""

    def __init__(self, capacity: int = 50) -> None:
        self.capacity = capacity
        self._stamps: list[int] = []
        self._items: list[Any] = []

    def __len__(self) -> int:
        return len(self._stamps)

    def add(self, stamp_ns: int, item: Item) -> None:
        """Insert `item` at its stamp (an equal stamp replaces the older item)."""
        index = bisect.bisect_left(self._stamps, stamp_ns)
        if index < len(self._stamps) and self._stamps[index] == stamp_ns:
            self._items[index] = item
            return
        self._stamps.insert(index, stamp_ns)
        self._items.insert(index, item)
        if len(self._stamps) > self.capacity:
            del self._stamps[0], self._items[0]

    def at(self, stamp_ns: int) -> Optional[Item]:
        """The item stamped exactly stamp_ns, None when there is none."""
        index = bisect.bisect_left(self._stamps, stamp_ns)
        if index < len(self._stamps) and self._stamps[index] == stamp_ns:
            return self._items[index]
        return None

    def newest_stamp(self) -> Optional[int]:
        """The newest stamp held [ns], None when empty."""
        return self._stamps[-1] if self._stamps else None

    def latest_not_after(self, stamp_ns: int, max_age_ns: int) -> tuple[Optional[Item], str]:
        """(newest item stamped <= stamp_ns and >= stamp_ns - max_age_ns, '') or (None, why)."""
        if not self._stamps:
            return None, 'none received'
        index = bisect.bisect_right(self._stamps, stamp_ns) - 1
        if index < 0:
            return None, 'all newer than the observation'
        if stamp_ns - self._stamps[index] > max_age_ns:
            return None, 'too old'
        return self._items[index], ''

    def nearest(self, stamp_ns: int, tolerance_ns: int) -> tuple[Optional[Item], str]:
        """(item with the stamp nearest stamp_ns within tolerance_ns, '') or (None, why)."""
        if not self._stamps:
            return None, 'none received'
        stamps = self._stamps
        best = bisect.bisect_left(stamps, stamp_ns)   # the first not older; the older one wins ties
        if best == len(stamps) or best and stamp_ns - stamps[best - 1] <= stamps[best] - stamp_ns:
            best -= 1
        if abs(stamps[best] - stamp_ns) > tolerance_ns:
            return None, 'none within the tolerance'
        return self._items[best], ''
