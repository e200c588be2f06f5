"""The CAN receiver's sender thread: the control loop posts a frame and never waits on the bus.

A python-can ``virtual`` bus plays the car's other node. A bus write that blocks (a full slcan
pty, a busy adapter) is played by holding the receiver's send lock, the lock every bus write
takes: while it is held, :meth:`CanReceiver.post` still returns, and of two commands posted
meanwhile only the latest reaches the bus.
"""

from __future__ import annotations

import os
import threading
import time

import can

from common.clock import RealClock
from common.messages import ActuatorCommand, AsState, CanFrame
from sensors.can_codec import AS_COMMAND_ID, CanCodec
from sensors.can_receiver import CanReceiver


def _receiver(channel: str) -> CanReceiver:
    return CanReceiver(RealClock(), CanCodec(), "virtual", channel, 0, read_timeout_s=0.02,
                       reconnect_min_s=0.02, reconnect_max_s=0.1)


def _command(brake: float) -> CanFrame:
    return CanCodec().encode_command(ActuatorCommand(0.0, 0.0, brake, 0.0, AsState.DRIVING))


def _received(peer: can.BusABC, count: int, timeout_s: float = 5.0) -> list[can.Message]:
    out: list[can.Message] = []
    while len(out) < count:
        msg = peer.recv(timeout_s)
        if msg is None:
            break
        out.append(msg)
    return out


def test_post_returns_while_the_bus_is_blocked_and_the_latest_command_wins() -> None:
    channel = f"sender-{os.getpid()}"
    receiver = _receiver(channel)
    with can.Bus(interface="virtual", channel=channel) as peer, receiver:
        assert receiver.wait_connected(5.0)
        receiver._send_lock.acquire()  # the bus write blocks
        try:
            blocker = CanFrame(0.0, 0x051, b"\x01")
            receiver.post(blocker)
            deadline = time.monotonic() + 5.0
            while receiver._outbox and time.monotonic() < deadline:
                time.sleep(0.005)  # until the sender holds it, waiting for the bus
            assert not receiver._outbox
            posted = threading.Event()

            def control_tick() -> None:
                receiver.post(_command(0.1))
                receiver.post(_command(0.9))
                posted.set()

            tick = threading.Thread(target=control_tick)
            tick.start()
            assert posted.wait(5.0)  # returned although nothing can be written
        finally:
            receiver._send_lock.release()
        tick.join()
        got = _received(peer, 2)
        assert [m.arbitration_id for m in got] == [0x051, AS_COMMAND_ID]
        back = CanCodec().decode_command(CanFrame(0.0, got[1].arbitration_id,
                                                  bytes(got[1].data)))
        assert back is not None and abs(back.brake - 0.9) < 1e-3
        assert peer.recv(0.2) is None  # the superseded command is never sent late
        assert receiver.superseded == 1
    stats = receiver.send_stats()
    assert stats["sent"] == 2 and stats["errors"] == 0 and stats["superseded"] == 1
    assert stats["lag_max_ms"] >= stats["lag_p99_ms"] >= 0.0


def test_frames_of_different_ids_all_go_out_in_order_and_stop_sends_what_is_posted() -> None:
    channel = f"sender-order-{os.getpid()}"
    receiver = _receiver(channel)
    frames = [CanFrame(0.0, 0x050 + k, bytes([k])) for k in range(5)]
    with can.Bus(interface="virtual", channel=channel) as peer:
        receiver.start()
        assert receiver.wait_connected(5.0)
        receiver._send_lock.acquire()
        for frame in frames:
            receiver.post(frame)
        receiver._send_lock.release()
        assert receiver.stop()  # the sender sends all five before the bus closes
        got = _received(peer, 5)
    assert [(m.arbitration_id, bytes(m.data)) for m in got] == [
        (f.arbitration_id, f.data) for f in frames]
    assert receiver.superseded == 0 and receiver.sent == 5
    assert not receiver.is_alive()


def test_post_before_start_or_after_stop_is_a_counted_failure_not_an_exception() -> None:
    receiver = _receiver(f"sender-none-{os.getpid()}")
    receiver.post(_command(0.5))  # no bus open: counted, the caller carries on
    assert receiver.send_errors == 1 and receiver.sent == 0


def test_a_frame_the_bus_cannot_carry_is_counted_and_the_sender_carries_on() -> None:
    channel = f"sender-bad-{os.getpid()}"
    receiver = _receiver(channel)
    with can.Bus(interface="virtual", channel=channel) as peer, receiver:
        assert receiver.wait_connected(5.0)
        receiver.post(CanFrame(0.0, 0x051, bytes(9)))  # nine bytes: not a classic CAN frame
        receiver.post(CanFrame(0.0, 0x7FF + 1, b"\x01"))  # an 11-bit id out of range
        receiver.post(_command(0.3))
        got = _received(peer, 1)
        assert [m.arbitration_id for m in got] == [AS_COMMAND_ID]
    assert receiver.send_errors == 2 and receiver.sent == 1
