"""``emulate --serial-stall T:D``: the emulated car's GPS and IMU bytes held back over a window
of its clock, then written in one burst, as a stalled serial link delivers them (issue 19);
read through the pseudo-terminals' stack end with pyserial, as drive reads them."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import pytest
import serial

from common.cli_types import stall_window
from common.messages import CanFrame, RawBytes
from orchestrator.config import AppConfig
from simulator.emulator import EmulatorOptions, HardwareEmulator


def _read_all(port: serial.Serial, settle_s: float = 0.2) -> bytes:
    """Everything the port has, after the kernel has had ``settle_s`` to pass it on."""
    time.sleep(settle_s)
    return port.read(port.in_waiting or 0)


def test_bytes_in_a_stall_come_out_at_its_end_in_order(tmp_path: Path) -> None:
    emulator = HardwareEmulator(AppConfig(), EmulatorOptions(
        track="default", exploration_overrun_m=5.0, handover_standstill_s=1.0,
        workdir=tmp_path, wait_for_stack_s=0.0, serial_stalls=((1.0, 0.5),)))
    gps = serial.Serial(str(emulator.gps.link_path), timeout=0)
    imu = serial.Serial(str(emulator.imu.link_path), timeout=0)
    try:
        frame = CanFrame(0.0, 0x300, b"\x00" * 8)
        emulator._dispatch([RawBytes(0.9, "gps", b"$A\r\n"), RawBytes(0.9, "imu", b"i0")], 0.9)
        assert _read_all(gps) == b"$A\r\n" and _read_all(imu) == b"i0"  # before: at once
        for k, t in enumerate((1.0, 1.2, 1.49)):
            emulator._dispatch([RawBytes(t, "gps", b"$B%d\r\n" % k), RawBytes(t, "imu", b"i%d" % k),
                                frame], t)
        assert _read_all(gps) == b"" and _read_all(imu) == b""  # held
        assert emulator.serial_bytes_held == 3 * (len(b"$B0\r\n") + len(b"i0"))
        emulator._dispatch([RawBytes(1.5, "gps", b"$C\r\n")], 1.5)  # the stall is over
        assert _read_all(gps) == b"$B0\r\n$B1\r\n$B2\r\n$C\r\n"
        assert _read_all(imu) == b"i0i1i2"
        assert emulator.summary("test", 1.5)["serial_bytes_held"] == 21
    finally:
        gps.close()
        imu.close()
        emulator.close()


@pytest.mark.parametrize("text, expected", [("41.3:0.46", (41.3, 0.46)), ("0:1", (0.0, 1.0))])
def test_stall_window_parses(text: str, expected: tuple[float, float]) -> None:
    assert stall_window(text) == expected


@pytest.mark.parametrize("text", ["3", "3:0", "-1:2", "a:1", "3:nan", "3:-1"])
def test_stall_window_refuses_with_one_line(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError) as info:
        stall_window(text)
    assert "\n" not in str(info.value)
