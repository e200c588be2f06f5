"""Output sinks of Main besides the recorder: the hash over every output, in order."""

from __future__ import annotations

from typing import Any

from recordings.hashing import OutputHasher


class HashSink:
    """Feeds every map state, plan and command Main emits into an :class:`OutputHasher`.

    Two runs with the same outputs in the same order give the same ``hexdigest()``: that is
    how a replay proves it reproduced the run that made the recording.
    """

    def __init__(self) -> None:
        self._hasher = OutputHasher()
        self.count = 0

    def write(self, topic: str, message: Any, log_time_s: float) -> None:
        self._hasher.update(topic, message)
        self.count += 1

    def hexdigest(self) -> str:
        return self._hasher.hexdigest()
