"""The slcan writer: python-can's own lines, written without waiting, never half a line.

The adapter is played on the master side of a real pseudo-terminal, as in
``tests/test_receivers_can.py``; python-can's ``slcan`` bus on a second pty gives the reference
lines. Only the short write in the last test is simulated (a tty takes part of a line only when
its buffer is nearly full, which cannot be arranged to the byte).
"""

from __future__ import annotations

import os
import select
import tty

import can
import pytest

from sensors import slcan_writer
from sensors.slcan_writer import SlcanWriter, slcan_line

MESSAGES = [
    can.Message(arbitration_id=0x050, data=bytes(range(8)), is_extended_id=False),
    can.Message(arbitration_id=0x7FF, data=b"", is_extended_id=False),
    can.Message(arbitration_id=0x18DAF110, data=b"\xde\xad\xbe", is_extended_id=True),
]


def _pty() -> tuple[int, int]:
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(slave, False)
    return master, slave


def _drain(fd: int) -> bytes:
    out = b""
    while select.select([fd], [], [], 0.2)[0]:
        chunk = os.read(fd, 65536)
        if not chunk:
            break
        out += chunk
    return out


def test_lines_are_python_cans_own() -> None:
    master, slave = _pty()
    try:
        bus = can.Bus(interface="slcan", channel=os.ttyname(slave), sleep_after_open=0.0)
        try:
            _drain(master)  # the bus's set-up commands
            for msg in MESSAGES:
                bus.send(msg)
                assert _drain(master) == slcan_line(msg)
        finally:
            bus.shutdown()
    finally:
        os.close(master)
        os.close(slave)


def test_a_full_tty_refuses_the_frame_at_once_and_the_adapter_never_sees_half_a_line() -> None:
    master, slave = _pty()
    writer = SlcanWriter(slave)
    try:
        refused = 0
        for _ in range(10_000):  # the adapter does not read: the tty fills up
            try:
                writer.send(MESSAGES[0])
            except can.CanOperationError:
                refused += 1
                if refused >= 3:
                    break
        assert refused == 3
        received = _drain(master)
        writer.send(MESSAGES[2])  # the adapter reads again: frames go out
        received += _drain(master)
        lines = received.split(b"\r")
        assert lines[-1] == b""
        assert set(lines[:-2]) == {slcan_line(MESSAGES[0])[:-1]}
        assert lines[-2] == slcan_line(MESSAGES[2])[:-1]
    finally:
        os.close(master)
        os.close(slave)


def test_a_short_write_is_finished_before_the_next_line(monkeypatch: pytest.MonkeyPatch) -> None:
    master, slave = _pty()
    writer = SlcanWriter(slave)
    real_write = os.write
    takes = [10, 0]  # the tty takes 10 bytes of the first line, then nothing

    def short_write(fd: int, data: bytes) -> int:
        if takes:
            n = takes.pop(0)
            if n == 0:
                raise BlockingIOError
            return real_write(fd, bytes(data[:n]))
        return real_write(fd, data)

    monkeypatch.setattr(slcan_writer.os, "write", short_write)
    try:
        writer.send(MESSAGES[0])  # 10 of its 22 bytes went out: accepted, tail kept
        with pytest.raises(can.CanOperationError):
            writer.send(MESSAGES[1])  # nothing fits: refused, the tail still kept
        writer.send(MESSAGES[2])
        assert _drain(master) == slcan_line(MESSAGES[0]) + slcan_line(MESSAGES[2])
    finally:
        os.close(master)
        os.close(slave)
