"""MISSION_SELECT and AS_STATUS through the car's DBC: round trips as python-can messages over a
virtual bus, the value tables against the enums, unknown values counted and never raised."""

from __future__ import annotations

import itertools
import logging
import os

import can
import cantools
import pytest

from common.messages import AssiMode, AsState, AsStatus, CanFrame, Mission, MissionSelect
from sensors.can_codec import (
    AS_STATUS_ID,
    DEFAULT_DBC_PATH,
    MISSION_SELECT_ID,
    CanCodec,
    mission_from_wire,
)


def _over_the_bus(frames: list[CanFrame]) -> list[CanFrame]:
    """Send ``frames`` as python-can Messages on a virtual bus; what the other node reads."""
    channel = f"mission-status-{os.getpid()}"
    out: list[CanFrame] = []
    with can.Bus(interface="virtual", channel=channel) as tx, \
            can.Bus(interface="virtual", channel=channel) as rx:
        for frame in frames:
            tx.send(can.Message(timestamp=frame.timestamp_s, arbitration_id=frame.arbitration_id,
                                data=frame.data, is_extended_id=False))
            msg = rx.recv(timeout=5.0)
            assert msg is not None
            out.append(CanFrame(frame.timestamp_s, msg.arbitration_id, bytes(msg.data),
                                msg.is_extended_id))
    return out


def test_value_tables_match_the_enums() -> None:
    db = cantools.database.load_file(str(DEFAULT_DBC_PATH))
    select = db.get_message_by_frame_id(MISSION_SELECT_ID)
    status = db.get_message_by_frame_id(AS_STATUS_ID)
    assert select.name == "MISSION_SELECT" and select.senders == ["VCU"]
    assert status.name == "AS_STATUS" and status.senders == ["AS"]
    assert select.cycle_time == 100 and status.cycle_time == 100  # 10 Hz
    for signal, enum in ((select.get_signal_by_name("MISSION"), Mission),
                         (status.get_signal_by_name("AS_STATUS_MISSION"), Mission),
                         (status.get_signal_by_name("AS_STATUS_STATE"), AsState),
                         (status.get_signal_by_name("ASSI_MODE"), AssiMode)):
        assert signal.choices is not None
        assert {int(k): str(v) for k, v in signal.choices.items()} == \
            {m.value: m.name for m in enum}, signal.name


def test_mission_select_round_trip_over_a_virtual_bus() -> None:
    sender, receiver = CanCodec(), CanCodec()
    sent = [MissionSelect(0.1 * k, m, int(m)) for k, m in enumerate(Mission)]
    frames = [sender.encode_mission(ms) for ms in sent]
    assert all(f.arbitration_id == MISSION_SELECT_ID and len(f.data) == 1 for f in frames)
    assert [f.data[0] >> 4 for f in frames] == list(range(len(frames)))  # alive counter
    got = [r for f in _over_the_bus(frames) for r in receiver.decode(f)]
    assert got == sent
    assert receiver.counts["mission"] == len(sent)
    assert receiver.rejects["unknown_mission"] == 1  # UNKNOWN itself is not a mission to drive


def test_as_status_round_trip_over_a_virtual_bus() -> None:
    sender, receiver = CanCodec(), CanCodec()
    sent = [AsStatus(0.01 * k, state, mission, lap, assi) for k, (state, mission, lap, assi)
            in enumerate(itertools.product(AsState, Mission, (0, 1, 10, 255), AssiMode))]
    frames = [sender.encode_as_status(st) for st in sent]
    assert all(f.arbitration_id == AS_STATUS_ID and len(f.data) == 3 for f in frames)
    got = [receiver.decode_as_status(f) for f in _over_the_bus(frames)]
    assert got == sent
    assert receiver.decode(frames[0]) == []  # not a reading for the stack
    assert not receiver.rejects


def test_lap_counter_saturates_instead_of_wrapping() -> None:
    codec = CanCodec()
    frame = codec.encode_as_status(AsStatus(0.0, AsState.DRIVING, Mission.TRACKDRIVE, 300,
                                            AssiMode.YELLOW_FLASHING))
    out = codec.decode_as_status(frame)
    assert out is not None and out.lap == 255


@pytest.mark.parametrize("raw", [5, 6, 9, 14])
def test_unknown_mission_value_is_counted_and_read_as_unknown(
        raw: int, caplog: pytest.LogCaptureFixture) -> None:
    assert mission_from_wire(raw) is None
    codec = CanCodec()
    caplog.set_level(logging.WARNING, logger="sensors.can_codec")
    for k in range(3):
        data = bytes([(k << 4) | raw])  # counter in the high nibble
        (out,) = codec.decode(CanFrame(1.0 + k, MISSION_SELECT_ID, data))
        assert out == MissionSelect(1.0 + k, Mission.UNKNOWN, raw)
        assert not out.mission.selectable
    assert codec.rejects["unknown_mission"] == 3
    lines = [r.getMessage() for r in caplog.records if "MISSION_SELECT" in r.getMessage()]
    assert len(lines) == 1 and f"value {raw}" in lines[0]  # one line per distinct value


def test_mission_frames_that_do_not_fit_are_rejected_not_raised() -> None:
    codec = CanCodec()
    assert codec.decode(CanFrame(0.0, MISSION_SELECT_ID, b"")) == []
    assert codec.decode(CanFrame(0.0, MISSION_SELECT_ID, b"\x01\x02")) == []
    assert codec.decode(CanFrame(0.0, MISSION_SELECT_ID, b"\x01", is_extended_id=True)) == []
    assert codec.rejects["bad_length"] == 2 and codec.rejects["unknown_id"] == 1


@pytest.mark.parametrize("data", [bytes([0x07, 0x01, 0x00]),   # state 7
                                  bytes([0x70, 0x01, 0x00]),   # ASSI mode 7
                                  bytes([0x00, 0x09, 0x00])])  # mission 9
def test_as_status_with_values_outside_the_enums_is_rejected(data: bytes) -> None:
    codec = CanCodec()
    assert codec.decode_as_status(CanFrame(0.0, AS_STATUS_ID, data)) is None
    assert codec.rejects["bad_status"] == 1
    assert codec.decode_as_status(CanFrame(0.0, MISSION_SELECT_ID, b"\x01")) is None
    assert codec.decode_as_status(CanFrame(0.0, AS_STATUS_ID, b"\x00")) is None
    assert codec.rejects["bad_length"] == 1
