"""The delay buffer: readings of every sensor applied in the order they were made (seed 000, 6.2.1).

LiDAR (about 10 ms) and camera (about 100 ms) detections arrive late and out of order with the
IMU, odometry and GNSS. Every reading goes into a :class:`DelayBuffer`; the filter is kept
*lagged* at the latest time every live source has reported (the horizon), and the buffered
readings up to the horizon are applied in the order they were made (the first method of seed
000, 6.2.1). The first reading of a source never heard before may find the lagged filter
already past its time: it is counted as late and dropped.

When nothing at all arrives for ``freeze_gap_s`` the stack itself was not run (every reader
and the caller stalled together: a loaded machine stopped drive's processes for 1.4 s in
issue 19), and the sensors' data of that time is read in a burst afterwards: their silence
is not held against them (their ``heard`` times move on by the gap), and the floor of the
horizon, ``now - max_delay_s``, trails by the gap and takes it back at the clock's pace, so
the burst is applied in the order it was made instead of being dropped as late.
"""

from __future__ import annotations

import heapq
import itertools
import logging
import math
from collections import Counter

from common.messages import Reading

log = logging.getLogger(__name__)


class DelayBuffer:
    """Readings from several streams, released in timestamp order up to the common horizon.

    ``push(stream, reading, now_s)``; ``pop_ready(now_s)`` returns the readings whose timestamp is
    at most :meth:`horizon`: the smallest latest-timestamp over the streams heard from within
    ``max_delay_s`` of ``now_s``, never older than ``now_s - max_delay_s`` (a dead source does
    not stall the filter). A reading older than what was already released is counted in
    ``late`` and dropped (it cannot be applied in order).
    """

    def __init__(self, max_delay_s: float, freeze_gap_s: float = math.inf) -> None:
        self.max_delay_s = max_delay_s
        self.freeze_gap_s = freeze_gap_s
        self.freezes = 0
        """Gaps of ``freeze_gap_s`` or more with nothing pushed or popped (counted)."""
        self._active_s = -math.inf
        """The caller's last push or pop (s)."""
        self._trail_s = 0.0
        """How far (s) the horizon's floor trails ``now - max_delay_s`` after a freeze."""
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
        self._note_activity(now_s)
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
        return max(h, now_s - self.max_delay_s - self._trail_s)

    def _note_activity(self, now_s: float) -> None:
        """Detect a freeze of the caller (a gap of ``freeze_gap_s`` since its last push or
        pop) and pay the horizon's trail back at the clock's pace."""
        gap = now_s - self._active_s
        if not gap > 0.0:  # also NaN
            return
        if gap >= self.freeze_gap_s and math.isfinite(self._active_s):
            self.freezes += 1
            log.warning("mapper: no reading for %.2f s (the stack was not run): the sensors' "
                        "backlog is applied in the order it was made", gap)
            for stream in self.heard_s:
                self.heard_s[stream] += gap
            self._trail_s += gap
        else:
            self._trail_s = max(self._trail_s - gap, 0.0)
        self._active_s = now_s

    def pop_ready(self, now_s: float) -> list[tuple[str, Reading]]:
        """The buffered readings up to the horizon, in timestamp order (ties: arrival order)."""
        self._note_activity(now_s)
        h = self.horizon(now_s)
        out: list[tuple[str, Reading]] = []
        heap = self._heap
        while heap and heap[0][0] <= h:
            _t, _n, stream, reading = heapq.heappop(heap)
            out.append((stream, reading))
        if out:
            self.released_s = max(self.released_s, out[-1][1].timestamp_s)
        return out
