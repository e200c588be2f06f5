"""A thread-safe count of the messages a recorder dropped, logged at 1, 2, 4, 8, ... so that a
flood of drops is seen in the log without flooding it."""

from __future__ import annotations

import logging
import threading

log = logging.getLogger("recordings.recorder")


class DropCount:
    """Messages dropped so far (:attr:`count`); :meth:`add` logs when the total reaches the
    next power of two."""

    def __init__(self) -> None:
        self.count = 0
        self._next_report = 1
        self._lock = threading.Lock()

    def add(self, n: int, reason: str) -> None:
        """``n`` more messages dropped because of ``reason`` (in the log line)."""
        with self._lock:
            self.count += n
            total = self.count
            report = total >= self._next_report
            if report:
                self._next_report *= 2
        if report:
            log.warning("recorder dropped %d message(s) so far (%s)", total, reason)
