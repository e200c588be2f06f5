"""The car's DBC and the CAN codec: layout, round trips, rejections."""

from __future__ import annotations

import os

import cantools
import pytest

from common.messages import (
    ActuatorCommand,
    AsState,
    CanFrame,
    RemoteStop,
    SteeringAngle,
    WheelSpeeds,
)
from sensors.can_codec import (
    AS_COMMAND_ID,
    AS_STATUS_ID,
    DEFAULT_DBC_PATH,
    MISSION_SELECT_ID,
    RES_STATE_ID,
    STEERING_ANGLE_ID,
    WHEEL_SPEEDS_ID,
    CanCodec,
    command_checksum,
)


def test_dbc_loads_and_documents_every_frame() -> None:
    db = cantools.database.load_file(str(DEFAULT_DBC_PATH))
    names = {m.frame_id: m.name for m in db.messages}
    assert names == {RES_STATE_ID: "RES_STATE", AS_COMMAND_ID: "AS_COMMAND",
                     WHEEL_SPEEDS_ID: "WHEEL_SPEEDS", STEERING_ANGLE_ID: "STEERING_ANGLE",
                     AS_STATUS_ID: "AS_STATUS", MISSION_SELECT_ID: "MISSION_SELECT"}
    for message in db.messages:
        assert message.comment, message.name
        assert message.cycle_time, message.name
        for signal in message.signals:
            assert signal.comment, signal.name
    assert db.get_message_by_frame_id(WHEEL_SPEEDS_ID).cycle_time == 10  # 100 Hz
    assert db.get_message_by_frame_id(STEERING_ANGLE_ID).cycle_time == 10


def test_wheel_speeds_round_trip_within_quantisation() -> None:
    codec = CanCodec()
    ws = WheelSpeeds(1.5, 12.3456, -0.0004, 24.9999, 3.14159)
    frame = codec.encode_wheel_speeds(ws)
    assert frame.arbitration_id == WHEEL_SPEEDS_ID and len(frame.data) == 8
    (out,) = codec.decode(frame)
    assert isinstance(out, WheelSpeeds) and out.timestamp_s == 1.5
    for a, b in ((out.front_left_mps, ws.front_left_mps), (out.front_right_mps, ws.front_right_mps),
                 (out.rear_left_mps, ws.rear_left_mps), (out.rear_right_mps, ws.rear_right_mps)):
        assert a == pytest.approx(b, abs=0.0005 + 1e-12)


def test_wheel_speeds_saturate_instead_of_wrapping() -> None:
    codec = CanCodec()
    (out,) = codec.decode(codec.encode_wheel_speeds(WheelSpeeds(0.0, 40.0, -40.0, 0.0, 0.0)))
    assert out.front_left_mps == pytest.approx(32.767)
    assert out.front_right_mps == pytest.approx(-32.768)


def test_steering_and_res_round_trip() -> None:
    codec = CanCodec()
    (sa,) = codec.decode(codec.encode_steering(SteeringAngle(2.0, -0.31234)))
    assert isinstance(sa, SteeringAngle) and sa.angle_rad == pytest.approx(-0.31234, abs=5e-5)
    for emergency in (False, True):
        for go in (False, True):
            (rs,) = codec.decode(codec.encode_res(RemoteStop(3.0, emergency, go)))
            assert rs == RemoteStop(3.0, emergency, go)


def test_command_round_trip_counter_and_checksum() -> None:
    codec = CanCodec()
    receiver = CanCodec()
    counters = []
    for k in range(20):
        cmd = ActuatorCommand(0.01 * k, 0.25 + 0.01 * k, 0.0, -0.2 + 0.01 * k, AsState.DRIVING)
        frame = codec.encode_command(cmd)
        assert frame.arbitration_id == AS_COMMAND_ID and len(frame.data) == 8
        assert frame.data[7] == command_checksum(AS_COMMAND_ID, frame.data)
        counters.append(frame.data[6] >> 4)
        out = receiver.decode_command(frame)
        assert out is not None
        assert out.throttle == pytest.approx(cmd.throttle, abs=5e-5)
        assert out.brake == 0.0
        assert out.steering_rad == pytest.approx(cmd.steering_rad, abs=5e-5)
        assert out.state is AsState.DRIVING
    assert counters == [k % 16 for k in range(20)]
    brake = receiver.decode_command(codec.encode_command(ActuatorCommand.full_brake(9.0)))
    assert brake is not None and brake.brake == 1.0 and brake.throttle == 0.0
    assert brake.state is AsState.EMERGENCY
    assert codec.decode(codec.encode_command(ActuatorCommand.full_brake(9.0))) == []


def test_command_with_bad_checksum_is_rejected() -> None:
    codec = CanCodec()
    frame = codec.encode_command(ActuatorCommand(0.0, 0.5, 0.0, 0.1))
    bad = bytearray(frame.data)
    bad[0] ^= 0x01
    assert codec.decode_command(CanFrame(0.0, AS_COMMAND_ID, bytes(bad))) is None
    assert codec.rejects["bad_checksum"] == 1


def test_unknown_ids_and_bad_lengths_are_counted_not_raised() -> None:
    codec = CanCodec()
    assert codec.decode(CanFrame(0.0, 0x7FF, b"\x00" * 8)) == []
    assert codec.decode(CanFrame(0.0, 0x1ABCDEF, b"", is_extended_id=True)) == []
    assert codec.decode(CanFrame(0.0, WHEEL_SPEEDS_ID, b"\x01\x02\x03")) == []
    assert codec.decode(CanFrame(0.0, RES_STATE_ID, b"")) == []
    assert codec.rejects["unknown_id"] == 2
    assert codec.rejects["bad_length"] == 2


def test_missing_dbc_is_a_clear_config_error(tmp_path) -> None:
    from common.errors import ConfigError

    with pytest.raises(ConfigError, match="nope.dbc"):
        CanCodec(tmp_path / "nope.dbc")


def test_codecs_share_one_parse_of_a_file_until_it_is_edited(tmp_path) -> None:
    dbc = tmp_path / "car.dbc"
    dbc.write_text(DEFAULT_DBC_PATH.read_text())
    first, second = CanCodec(dbc), CanCodec(dbc)
    assert first.db is second.db
    assert first.db is not CanCodec().db  # another file, another parse
    edited = dbc.read_text().replace("WHEEL_SPEEDS", "WHEEL_SPEED_X")
    dbc.write_text(edited)
    stat = dbc.stat()
    os.utime(dbc, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1_000_000_000))
    third = CanCodec(dbc)
    assert third.db is not first.db
    assert third.db.get_message_by_frame_id(WHEEL_SPEEDS_ID).name == "WHEEL_SPEED_X"
    # each codec keeps its own alive counters although the database is shared
    first.encode_command(ActuatorCommand(0.0, 0.1, 0.0, 0.0))
    assert second._counters != first._counters
