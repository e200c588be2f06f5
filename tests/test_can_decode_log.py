"""decode_log on a real CAN capture (candump -L) and on logs python-can writes (ASC, BLF)."""

from __future__ import annotations

import json
from pathlib import Path

import can
import pytest

from common.errors import DecodeError
from common.messages import RemoteStop, SteeringAngle, WheelSpeeds
from sensors.can_codec import CanCodec
from sensors.decode_can import decode_log
from support.shared_data import shared_path

DATA = shared_path("can")
LOG = DATA / "comma2k19_rav4_bus0_candump.log"
RAV4_DBC = DATA / "toyota_rav4_2017_pt_generated.dbc"

needs_data = pytest.mark.shared_data("can/comma2k19_rav4_bus0_candump.log")


@needs_data
def test_rav4_wheel_speeds_decode_with_the_rav4_dbc() -> None:
    out = list(decode_log(LOG, RAV4_DBC))
    counts = out[-1]["counts"]
    assert counts["frames"] == 53800
    assert counts["errors"] == 0
    assert counts["decoded"] + counts["unknown_id"] + counts["bad_length"] == 53800
    wheels = [o for o in out[:-1] if o["id"] == 0xAA]
    assert wheels and all(o["name"] == "WHEEL_SPEEDS" for o in wheels)
    # ~100 Hz of 0xAA over 60 s (4974 frames, a few truncated in the capture)
    assert len(wheels) >= 4900
    speeds = [o["signals"]["WHEEL_SPEED_FL"] for o in wheels]
    assert all(0.0 <= v <= 250.0 for v in speeds)  # km/h in the RAV4 DBC
    assert max(speeds) > 10.0  # the car is moving in this segment
    times = [o["time_s"] for o in wheels]
    assert times == sorted(times) and times[-1] - times[0] == pytest.approx(50.0, abs=11.0)
    steer = [o for o in out[:-1] if o["id"] == 0x25]
    assert steer and "STEER_ANGLE" in steer[0]["signals"]
    json.dumps(out)  # JSON-ready


@needs_data
def test_rav4_log_with_our_dbc_is_all_unknown_ids() -> None:
    out = list(decode_log(LOG, None))
    assert len(out) == 1
    assert out[0]["counts"]["unknown_id"] == 53800
    assert out[0]["counts"]["decoded"] == 0


def test_asc_and_blf_logs_decode_with_our_dbc(tmp_path: Path) -> None:
    codec = CanCodec()
    frames = [codec.encode_wheel_speeds(WheelSpeeds(0.01 * k, 1.0, 2.0, 3.0, 4.0))
              for k in range(5)]
    frames += [codec.encode_steering(SteeringAngle(0.1, 0.2)),
               codec.encode_res(RemoteStop(0.2, True, False))]
    for suffix in (".asc", ".blf", ".log"):
        path = tmp_path / f"bus{suffix}"
        with can.Logger(str(path)) as writer:
            for f in frames:
                writer.on_message_received(can.Message(
                    timestamp=1000.0 + f.timestamp_s, arbitration_id=f.arbitration_id,
                    data=f.data, is_extended_id=False))
            writer.on_message_received(can.Message(timestamp=1000.5, arbitration_id=0x7AB,
                                                   data=b"\x01", is_extended_id=False))
        out = list(decode_log(path))
        counts = out[-1]["counts"]
        assert counts["decoded"] == 7, suffix
        assert counts["unknown_id"] == 1, suffix
        names = [o["name"] for o in out[:-1]]
        assert names.count("WHEEL_SPEEDS") == 5
        assert out[0]["signals"]["WHEEL_SPEED_RR"] == pytest.approx(4.0)
        res = [o for o in out[:-1] if o["name"] == "RES_STATE"][0]
        assert res["signals"]["RES_EMERGENCY"] == 1


def test_missing_or_garbage_log_is_a_decode_error_or_counted(tmp_path: Path) -> None:
    with pytest.raises(DecodeError):
        list(decode_log(tmp_path / "nothing.log"))
    junk = tmp_path / "junk.log"
    junk.write_bytes(b"\x00\xffnot a candump line\n(12.5) can0 100#GG\n")
    out = list(decode_log(junk))
    assert "counts" in out[-1]
