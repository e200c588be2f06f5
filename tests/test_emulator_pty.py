"""The emulator's pseudo-terminal end: reads never wait, even on a busy machine.

Linux's tty ``read`` on an empty pty waits for the kernel worker that moves the other side's
bytes in, even on a non-blocking descriptor; that worker runs at normal priority, so the
emulator's real-time loop must not read an empty pty at all (issue 19 saw it held 0.4 s).
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from simulator import transports
from simulator.transports import PtyPort


def test_an_empty_pty_is_never_read_and_waiting_bytes_are(tmp_path: Path,
                                                          monkeypatch: pytest.MonkeyPatch) -> None:
    port = PtyPort(tmp_path / "ttyIMU")
    stack_side = os.open(str(port.link_path), os.O_RDWR | os.O_NOCTTY)
    try:
        reads: list[int] = []
        real_read = os.read

        def counted_read(fd: int, n: int) -> bytes:
            reads.append(fd)
            return real_read(fd, n)

        monkeypatch.setattr(transports.os, "read", counted_read)
        assert port.read() == b""
        assert reads == []  # nothing waiting: the tty's read was not entered
        os.write(stack_side, b"t0508" + b"00" * 8 + b"\r")
        got = b""
        deadline = time.monotonic() + 5.0
        while len(got) < 22 and time.monotonic() < deadline:  # the kernel worker moves them
            got += port.read()
            time.sleep(0.001)
        assert got == b"t0508" + b"00" * 8 + b"\r"
        assert reads  # and read once they were there
    finally:
        os.close(stack_side)
        port.close()
