"""What ``drive``'s processes ask of the operating system to keep their timing on a busy
computer: the executive process's niceness, and memory locked in RAM (the reactive layer's
real-time priority is :func:`orchestrator.live.set_realtime_priority`)."""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import logging
import os
import resource
import signal

log = logging.getLogger(__name__)

DEFAULT_EXECUTIVE_NICENESS = -10
"""About nine times the CPU share of a process at the default niceness when the computer is
busy (a loaded car computer or test machine must not starve the map and the plan)."""


def set_niceness(niceness: int, what: str = "executive process") -> bool:
    """Give the calling process ``niceness`` (-20..19); False, with a warning, when the
    system refuses a negative one (it needs root or CAP_SYS_NICE). A process started by
    another inherits its niceness: a niceness of 0 is set too when it is not the current
    one. ``what`` names the process in the log."""
    try:
        if os.getpriority(os.PRIO_PROCESS, 0) == niceness:
            return True
        os.setpriority(os.PRIO_PROCESS, 0, niceness)
    except (OSError, ValueError) as exc:
        log.warning("niceness %d refused (%s): the %s shares the CPU equally with the "
                    "computer's other work", niceness, exc, what)
        return False
    log.info("%s at niceness %d", what, niceness)
    return True


MCL_CURRENT = 1
MCL_FUTURE = 2
"""``mlockall`` flags (``sys/mman.h``, the same on every Linux architecture)."""


@functools.cache
def _libc() -> ctypes.CDLL | None:
    """The C library, errno kept (None where there is none to find)."""
    name = ctypes.util.find_library("c")
    return None if name is None else ctypes.CDLL(name, use_errno=True)


def lock_memory(what: str) -> bool:
    """Lock the calling process's pages in RAM (``mlockall(MCL_CURRENT | MCL_FUTURE)``), as a
    real-time process does: a page the kernel has dropped (a shared library's code, even
    without swap) is read back from disk when next touched, a major fault that stalls the
    thread for tens to hundreds of milliseconds on a busy computer (issue 19 measured 150 ms
    wake-ups and a 430 ms stand-in sensor this way).

    Needs root, CAP_IPC_LOCK or an unlimited ``ulimit -l``; otherwise, or off Linux, it logs a
    warning and returns False (with a limited lock allowance the process's later allocations
    would fail once past it, so it is not attempted). ``what`` names the process in the log.
    """
    libc = _libc()
    if not hasattr(os, "geteuid") or libc is None:
        log.warning("cannot lock the %s's memory on this system: its timing depends on the "
                    "kernel keeping its pages in RAM", what)
        return False
    soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    if os.geteuid() != 0 and soft != resource.RLIM_INFINITY:
        log.warning("memory lock of the %s not attempted: the lock limit is %d KiB (raise it "
                    "with `ulimit -l unlimited`, or give CAP_IPC_LOCK); its timing depends on "
                    "the kernel keeping its pages in RAM", what, soft // 1024)
        return False
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        errno = ctypes.get_errno()
        log.warning("memory lock of the %s refused (%s): its timing depends on the kernel "
                    "keeping its pages in RAM", what, os.strerror(errno))
        return False
    log.info("%s memory locked in RAM", what)
    return True


def unlock_memory() -> None:
    """Undo :func:`lock_memory` (``munlockall``); harmless when nothing is locked."""
    libc = _libc()
    if libc is not None:
        libc.munlockall()


def enter_child_process(what: str, log_level: int, niceness: int) -> None:
    """The start of each of ``drive``'s processes but the control process: SIGINT and SIGTERM
    ignored (Ctrl-C reaches the whole process group; the process that started this one decides
    when it ends), logging at ``log_level`` to stderr, ``niceness`` set (``what`` names the
    process in the log)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    logging.basicConfig(level=log_level,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    set_niceness(niceness, what)


def nicer_by(niceness: int, step: int) -> int:
    """``niceness`` raised by ``step``, within Linux's -20..19 (a child process's niceness
    beside its parent's)."""
    return max(-20, min(19, niceness + step))
