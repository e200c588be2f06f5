"""Lap times as the frames know them: from the plan's lap counter (laps completed) and the AS
state, observed at the map-state rate (10 Hz: times to 0.1 s).

The first lap starts when the car first moves in AS DRIVING (the standing start after the RES
go); each lap ends when the plan's lap counter goes up, and the next starts there.
"""

from __future__ import annotations


class LapTimer:
    """Feed it :meth:`observe` in time order; read :attr:`lap` and :attr:`lap_times_s`."""

    def __init__(self) -> None:
        self.lap = 0
        """Laps completed (the plan's counter)."""
        self.lap_times_s: list[float] = []
        """Each completed lap's time (s), in order."""
        self._lap_start_s: float | None = None

    def observe(self, t_s: float, lap: int, driving: bool, speed_mps: float) -> None:
        """At ``t_s`` (s) the plan says ``lap`` laps are done; ``driving``: AS state DRIVING;
        ``speed_mps``: the car's speed."""
        if self._lap_start_s is None:
            if driving and speed_mps > 0.05:
                self._lap_start_s = t_s
            self.lap = max(self.lap, lap)
            return
        while lap > self.lap:
            self.lap += 1
            self.lap_times_s.append(t_s - self._lap_start_s)
            self._lap_start_s = t_s

    @property
    def last_s(self) -> float | None:
        return self.lap_times_s[-1] if self.lap_times_s else None

    @property
    def best_s(self) -> float | None:
        return min(self.lap_times_s) if self.lap_times_s else None
