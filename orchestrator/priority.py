"""Process priority of ``drive``'s executive process (the reactive layer's real-time priority
is :func:`orchestrator.live.set_realtime_priority`)."""

from __future__ import annotations

import logging
import os

log = logging.getLogger(__name__)

DEFAULT_EXECUTIVE_NICENESS = -10
"""About nine times the CPU share of a process at the default niceness when the computer is
busy (a loaded car computer or test machine must not starve the map and the plan)."""


def set_niceness(niceness: int) -> bool:
    """Give the calling process ``niceness`` (-20..19); False, with a warning, when the
    system refuses a negative one (it needs root or CAP_SYS_NICE)."""
    if niceness == 0:
        return True
    try:
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
    except (OSError, ValueError) as exc:
        log.warning("niceness %d refused (%s): the executive process shares the CPU equally "
                    "with the computer's other work", niceness, exc)
        return False
    log.info("executive process at niceness %d", niceness)
    return True
