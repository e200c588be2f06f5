"""The emulator's CAN over python-can's ``udp_multicast`` bus (``emulate --can udp``): kernel
sockets as the car's SocketCAN, no tty in the path. The stack's :class:`CanReceiver` opens it
from the config the emulator writes; each end drops its own frames, which IP multicast hands
back to the sender."""

from __future__ import annotations

import time

from common.clock import RealClock
from common.messages import ActuatorCommand, AsState, WheelSpeeds
from sensors.can_codec import AS_COMMAND_ID, CanCodec
from sensors.can_receiver import CanReceiver
from simulator.transports import UdpCanBus


def _receiver(car: UdpCanBus) -> CanReceiver:
    cfg = car.drive_config()
    assert cfg["interface"] == "udp_multicast"
    return CanReceiver(RealClock(), CanCodec(), cfg["interface"], cfg["channel"], 0,
                       bus_kwargs={"port": cfg["udp_port"]}, read_timeout_s=0.02,
                       reconnect_min_s=0.02, reconnect_max_s=0.1)


def _until(condition, timeout_s: float = 5.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return False


def test_frames_cross_both_ways_and_neither_end_takes_its_own() -> None:
    codec = CanCodec()
    car = UdpCanBus()
    receiver = _receiver(car)
    taken = []
    try:
        with receiver:
            assert receiver.wait_connected(5.0)
            assert not car.is_open  # the stack has sent nothing yet
            car.send_frame(codec.encode_wheel_speeds(WheelSpeeds(0.0, 1.0, 2.0, 3.0, 4.0)))
            assert _until(lambda: receiver.codec.counts["wheel_speeds"] == 1)
            command = codec.encode_command(ActuatorCommand(0.0, 0.3, 0.0, 0.1, AsState.DRIVING))
            receiver.post(command)

            def got_command() -> bool:
                taken.extend(car.poll(0.0))
                return any(f.arbitration_id == AS_COMMAND_ID for f in taken)

            assert _until(got_command)
            assert car.is_open  # the stack's first frame opened the bus
            time.sleep(0.1)
            taken.extend(car.poll(0.0))
    finally:
        car.close()
    # the car took only the stack's command, not its own wheel speeds looped back
    assert [f.arbitration_id for f in taken] == [AS_COMMAND_ID]
    decoded = codec.decode_command(taken[0])
    assert decoded is not None and abs(decoded.throttle - 0.3) < 0.01
    # and the stack decoded the wheel speeds but not its own command looped back
    assert receiver.codec.counts["wheel_speeds"] == 1
    assert sum(receiver.codec.counts.values()) == 1
    assert car.bad_lines == 0


def test_two_emulators_never_share_a_bus() -> None:
    first, second = UdpCanBus(), UdpCanBus()
    try:
        assert first.port != second.port
        codec = CanCodec()
        first.send_frame(codec.encode_wheel_speeds(WheelSpeeds(0.0, 1.0, 1.0, 1.0, 1.0)))
        time.sleep(0.2)
        assert second.poll(0.0) == []
    finally:
        first.close()
        second.close()
