"""The delay buffer: readings of every sensor applied in the order they were made (seed 000, 6.2.1).

LiDAR (about 10 ms) and camera (about 100 ms) detections arrive late and out of order with the
IMU, odometry and GNSS. Every reading goes into a :class:`DelayBuffer`; the filter is kept
*lagged* at the latest time every live source has reported (the horizon), and the buffered
readings up to the horizon are applied in the order they were made (the first method of seed
000, 6.2.1). The first reading of a source never heard before may find the lagged filter
already past its time: it is counted as late and dropped.
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections import Counter

from common.messages import Reading


class DelayBuffer:
    """Readings from several streams, released in timestamp order up to the common horizon.

    ``push(stream, reading, now_s)``; ``pop_ready(now_s)`` returns the readings whose timestamp is
    at most :meth:`horizon`: the smallest latest-timestamp over the streams heard from within
    ``max_delay_s`` of ``now_s``, never older than ``now_s - max_delay_s`` (a dead source does
    not stall the filter). A reading older than what was already released is counted in
    ``late`` and dropped (it cannot be applied in order).
    """

    def __init__(self, max_delay_s: float) -> None:
        self.max_delay_s = max_delay_s
        self._heap: list[tuple[float, int, str, Reading]] = []
        self._seq = itertools.count()
        self.latest_s: dict[str, float] = {}
        self.heard_s: dict[str, float] = {}
        self.released_s = -math.inf
        self.late: Counter[str] = Counter()

    def __len__(self) -> int:
        return len(self._heap)

    def push(self, stream: str, reading: Reading, now_s: float) -> bool:
        """Buffer ``reading``; False (counted) when it is older than the released horizon."""
        t = reading.timestamp_s
        if t > self.latest_s.get(stream, -math.inf):
            self.latest_s[stream] = t
        self.heard_s[stream] = now_s
        if t < self.released_s:
            self.late[stream] += 1
            return False
        heapq.heappush(self._heap, (t, next(self._seq), stream, reading))
        return True

    def horizon(self, now_s: float) -> float:
        """The time up to which every live stream has reported (s)."""
        live = [self.latest_s[s] for s, heard in self.heard_s.items()
                if now_s - heard <= self.max_delay_s]
        h = min(live) if live else now_s
        return max(h, now_s - self.max_delay_s)

    def pop_ready(self, now_s: float) -> list[tuple[str, Reading]]:
        """The buffered readings up to the horizon, in timestamp order (ties: arrival order)."""
        h = self.horizon(now_s)
        out: list[tuple[str, Reading]] = []
        heap = self._heap
        while heap and heap[0][0] <= h:
            _t, _n, stream, reading = heapq.heappop(heap)
            out.append((stream, reading))
        if out:
            self.released_s = max(self.released_s, out[-1][1].timestamp_s)
        return out
