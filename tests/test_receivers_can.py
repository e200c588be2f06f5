"""The CAN receiver over slcan on a pseudo-terminal: what a USB-CAN adapter speaks.

The test plays the adapter on the master side of the pty (slcan ASCII: ``t<id:3><dlc><data>\\r``
frames in, the receiver's commands and frames out); python-can's ``slcan`` interface opens the
slave side like a real ``/dev/ttyACM0``. The kernel pty is the process boundary.
"""

from __future__ import annotations

import os
import select
import time
import tty
from collections.abc import Callable
from pathlib import Path

import can
import pytest

from common.clock import RealClock
from common.messages import ActuatorCommand, AsState, CanFrame, RemoteStop, WheelSpeeds
from sensors.can_codec import AS_COMMAND_ID, CanCodec
from sensors.can_receiver import CAN_ERR_BUSOFF, CanReceiver

FAST = dict(read_timeout_s=0.02, reconnect_min_s=0.02, reconnect_max_s=0.1)
SLCAN = dict(bus_kwargs={"sleep_after_open": 0.0})


def make_pty() -> tuple[int, int, str]:
    master, slave = os.openpty()
    tty.setraw(slave)
    return master, slave, os.ttyname(slave)


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0,
             action: Callable[[], object] | None = None) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if action is not None:
            action()
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def slcan_line(frame: CanFrame) -> bytes:
    """One frame in the slcan ASCII protocol (as an adapter sends it to the host)."""
    return f"t{frame.arbitration_id:03X}{len(frame.data)}{frame.data.hex().upper()}\r".encode()


def read_slcan_frames(master: int, timeout_s: float = 2.0) -> list[CanFrame]:
    """Frames the host sent to the 'adapter' (open/close/bitrate commands skipped)."""
    out: list[CanFrame] = []
    buffer = b""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        ready, _, _ = select.select([master], [], [], 0.05)
        if ready:
            buffer += os.read(master, 4096)
        *lines, buffer = buffer.split(b"\r")
        for line in lines:
            if line[:1] == b"t":
                text = line.decode()
                dlc = int(text[4])
                out.append(CanFrame(0.0, int(text[1:4], 16), bytes.fromhex(text[5:5 + 2 * dlc])))
        if out and not ready:
            break
    return out


def test_slcan_frames_decode_unknown_ids_are_counted_and_commands_go_out() -> None:
    master, slave, path = make_pty()
    clock = RealClock()
    codec = CanCodec()
    receiver = CanReceiver(clock, codec, "slcan", path, 500000, **SLCAN, **FAST)
    sender = CanCodec()
    try:
        with receiver:
            assert receiver.wait_connected(5.0)
            frames = [sender.encode_wheel_speeds(WheelSpeeds(0.0, 1.0, 2.0, 3.0, 4.25)),
                      sender.encode_res(RemoteStop(0.0, False, True)),
                      CanFrame(0.0, 0x7AB, b"\xde\xad"),  # not in our DBC
                      CanFrame(0.0, 0x100, b"\x01")]  # known id, wrong length
            os.write(master, b"".join(slcan_line(f) for f in frames))
            assert wait_for(lambda: receiver.intake.raw_count >= 4)
            raw, readings = receiver.intake.take()
            assert [r.arbitration_id for r in raw] == [0x100, 0x010, 0x7AB, 0x100]
            ws = [r for r in readings if isinstance(r, WheelSpeeds)]
            assert len(ws) == 1 and ws[0].rear_right_mps == pytest.approx(4.25)
            res = [r for r in readings if isinstance(r, RemoteStop)]
            assert res == [RemoteStop(res[0].timestamp_s, False, True)]
            stats = receiver.stats(clock.now_s())
            assert stats.rejects == {"bad_length": 1, "unknown_id": 1}
            # garbage on the line itself: slcan lines that are not frames
            os.write(master, b"zzz\r\a\rt1G08\rt10\r")
            os.write(master, slcan_line(frames[0]))
            assert wait_for(lambda: receiver.intake.raw_count >= 5)
            assert receiver.is_alive()
            assert receiver.reconnects == 0  # a garbled line is not a lost bus
            assert receiver.stats(clock.now_s()).errors == 2
            # the actuator command goes out as an slcan frame the 'VCU' decodes
            os.read(master, 4096)  # drop the adapter set-up commands (C, S6, O)
            cmd = ActuatorCommand(1.0, 0.0, 0.4, -0.25, AsState.DRIVING)
            assert receiver.send(codec.encode_command(cmd))
            sent = read_slcan_frames(master)
            assert [f.arbitration_id for f in sent] == [AS_COMMAND_ID]
            back = CanCodec().decode_command(sent[0])
            assert back is not None
            assert back.brake == pytest.approx(0.4, abs=1e-4)
            assert back.steering_rad == pytest.approx(-0.25, abs=1e-4)
            assert back.state is AsState.DRIVING
        assert not receiver.is_alive()
        assert not receiver.send(codec.encode_command(cmd))  # bus closed: counted, no raise
        assert receiver.send_errors == 1
    finally:
        os.close(master)
        os.close(slave)


def test_adapter_unplugged_and_replugged_reconnects(tmp_path: Path) -> None:
    link = tmp_path / "ttyCAN"
    master, slave, path = make_pty()
    os.symlink(path, link)
    clock = RealClock()
    codec = CanCodec()
    receiver = CanReceiver(clock, codec, "slcan", str(link), 500000, **SLCAN, **FAST)
    frame = slcan_line(CanCodec().encode_res(RemoteStop(0.0, True, False)))
    with receiver:
        assert receiver.wait_connected(5.0)
        assert wait_for(lambda: receiver.intake.count >= 1, action=lambda: os.write(master, frame))
        os.unlink(link)
        os.close(master)
        os.close(slave)
        assert wait_for(lambda: not receiver.connected.is_set())
        assert receiver.is_alive()
        master2, slave2, path2 = make_pty()
        os.symlink(path2, link)
        try:
            assert receiver.wait_connected(5.0)
            before = receiver.intake.count
            assert wait_for(lambda: receiver.intake.count > before,
                            action=lambda: os.write(master2, frame))
            assert receiver.reconnects >= 1
            assert receiver.stats(clock.now_s()).errors >= 1
        finally:
            receiver.stop()
            os.close(master2)
            os.close(slave2)


def test_bus_off_error_frame_reopens_the_bus() -> None:
    """A bus-off error frame (SocketCAN error class) closes and reopens the bus."""
    channel = f"busoff-{os.getpid()}"
    clock = RealClock()
    receiver = CanReceiver(clock, CanCodec(), "virtual", channel, 0, **FAST)
    with can.Bus(interface="virtual", channel=channel) as peer:  # the other node on the bus
        with receiver:
            assert receiver.wait_connected(5.0)
            peer.send(can.Message(arbitration_id=0x004, data=bytes(8), is_error_frame=True))
            assert wait_for(lambda: receiver.error_frames >= 1)
            peer.send(can.Message(arbitration_id=CAN_ERR_BUSOFF, data=bytes(8),
                                  is_error_frame=True))
            assert wait_for(lambda: receiver.reconnects >= 1)
            assert receiver.wait_connected(5.0)
            stats = receiver.stats(clock.now_s())
            assert stats.errors >= 3  # two error frames and the failed read
            frame = CanCodec().encode_res(RemoteStop(0.0, False, True))
            assert wait_for(lambda: receiver.intake.count >= 1,
                            action=lambda: peer.send(can.Message(
                                arbitration_id=frame.arbitration_id, data=frame.data,
                                is_extended_id=False)))
