"""Output sinks of Main besides the recorder: the hash over every output, in order, and the
Foxglove live view (``--live``)."""

from __future__ import annotations

from typing import Any

from orchestrator.config import AppConfig
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


def start_live(address: tuple[str, int] | None, config: AppConfig) -> Any:
    """The Foxglove live view (:class:`recordings.live_server.LiveServer`) on ``address``
    (``--live``: host, port), or None when not asked for."""
    if address is None:
        return None
    from recordings.live_server import LiveServer

    host, port = address
    return LiveServer(host, port, config.car)
