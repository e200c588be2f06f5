"""The comma2k19 importer on the shared RAV4 segment: every channel arrives as our receivers'
bytes, in time order, in SI units, and ``--drop-gnss`` empties exactly its window."""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest

from common.messages import (
    CanFrame,
    GpsFix,
    GroundTruth,
    ImuSample,
    RawBytes,
    SteeringAngle,
    WheelSpeeds,
)
from main import cli
from orchestrator.log_import import GnssOutage, import_log
from recordings.player import Player
from recordings.topics import CAN_FRAME, GPS_NMEA, IMU_PACKET, TRUTH_POSE
from sensors.can_codec import CanCodec
from sensors.imu_protocol import ImuParser
from sensors.nmea import NmeaParser
from support.shared_data import shared_data

SEGMENT = ("vehicle_logs", "comma2k19_rav4_seg40")


def _source(*parts: str) -> np.ndarray:
    return np.load(shared_data(*SEGMENT) / Path(*parts))


def _read(path: Path) -> dict[str, list[tuple[float, object]]]:
    by_topic: dict[str, list[tuple[float, object]]] = defaultdict(list)
    for t, topic, message in Player(path):
        by_topic[topic].append((t, message))
    return by_topic


@pytest.fixture(scope="module")
def imported(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[float, object]]]:
    out = tmp_path_factory.mktemp("import") / "seg40.mcap"
    import_log("comma2k19", shared_data(*SEGMENT), out)
    return _read(out)


def test_channel_counts(imported: dict[str, list[tuple[float, object]]]) -> None:
    n_imu = len(_source("processed_log/IMU/accelerometer/t"))
    n_gnss = len(_source("processed_log/GNSS/live_gnss_ublox/t"))
    n_can = len(_source("processed_log/CAN/wheel_speed/t"))
    n_truth = len(_source("global_pose/frame_times"))
    assert len(imported[IMU_PACKET]) == n_imu
    assert len(imported[GPS_NMEA]) == 2 * n_gnss  # GGA and RMC per fix
    assert len(imported[CAN_FRAME]) == 2 * n_can  # wheel speeds and steering
    assert len(imported[TRUTH_POSE]) == n_truth


def test_times_monotonic_and_in_the_logs_time_base(
        imported: dict[str, list[tuple[float, object]]]) -> None:
    t_imu = _source("processed_log/IMU/accelerometer/t")
    for topic, items in imported.items():
        times = np.array([t for t, _ in items])
        assert np.all(np.diff(times) >= 0.0), topic
        # the device's boot time, not shifted
        assert abs(times[0] - t_imu[0]) < 1.0, topic
    stamps = np.array([m.timestamp_s for _, m in imported[IMU_PACKET]])  # type: ignore[attr-defined]
    np.testing.assert_allclose(stamps, t_imu, atol=1e-6)


def test_gnss_parses_back_to_the_fixes(imported: dict[str, list[tuple[float, object]]]) -> None:
    value = _source("processed_log/GNSS/live_gnss_ublox/value")
    parser = NmeaParser(require_checksum=True)
    fixes: list[GpsFix] = []
    for t, raw in imported[GPS_NMEA]:
        assert isinstance(raw, RawBytes)
        fixes += parser.feed(t, raw.payload)
    fixes += parser.flush()
    assert len(fixes) == len(value)
    assert not parser.rejects
    lat = np.array([f.lat_deg for f in fixes])
    lon = np.array([f.lon_deg for f in fixes])
    speed = np.array([f.speed_mps for f in fixes])
    # 7 decimals of a minute: 2e-9 deg
    np.testing.assert_allclose(lat, value[:, 0], atol=1e-8)
    np.testing.assert_allclose(lon, value[:, 1], atol=1e-8)
    np.testing.assert_allclose(speed, value[:, 2], atol=1e-3)  # m/s, from knots with 4 decimals
    compass = np.array([(90.0 - math.degrees(f.course_rad)) % 360.0 for f in fixes])
    diff = (compass - value[:, 5] + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(diff)) < 1e-3


def test_imu_in_the_vehicle_frame_si_units(imported: dict[str, list[tuple[float, object]]]) -> None:
    parser = ImuParser()
    samples: list[ImuSample] = []
    for t, raw in imported[IMU_PACKET]:
        assert isinstance(raw, RawBytes)
        samples += parser.feed(t, raw.payload)
    assert len(samples) == len(imported[IMU_PACKET])
    acc = np.array([[s.accel_x_mps2, s.accel_y_mps2, s.accel_z_mps2] for s in samples])
    gyro = np.array([[s.gyro_x_radps, s.gyro_y_radps, s.gyro_z_radps] for s in samples])
    # gravity up (+z) in m/s^2; the device frame had z down
    assert 9.3 < float(np.mean(acc[:, 2])) < 10.1
    src_gyro = _source("processed_log/IMU/gyro_uncalibrated/value")
    np.testing.assert_allclose(gyro[:, 2], -src_gyro[:, 2], atol=1e-6)  # z down -> z up, rad/s
    np.testing.assert_allclose(gyro[:, 0], src_gyro[:, 0], atol=1e-6)


def test_can_wheels_and_steering(imported: dict[str, list[tuple[float, object]]]) -> None:
    codec = CanCodec()
    wheels: list[WheelSpeeds] = []
    steering: list[SteeringAngle] = []
    for _, frame in imported[CAN_FRAME]:
        assert isinstance(frame, CanFrame)
        for r in codec.decode(frame):
            if isinstance(r, WheelSpeeds):
                wheels.append(r)
            elif isinstance(r, SteeringAngle):
                steering.append(r)
    src = _source("processed_log/CAN/wheel_speed/value")
    ws = np.array([[w.front_left_mps, w.front_right_mps, w.rear_left_mps, w.rear_right_mps]
                   for w in wheels])
    np.testing.assert_allclose(ws, src, atol=0.0006)  # m/s, the DBC's 1 mm/s steps
    wheel_deg = _source("processed_log/CAN/steering_angle/value")
    road = np.array([s.angle_rad for s in steering])
    assert len(road) == len(wheel_deg)
    # road-wheel radians: the steering wheel's degrees over the steering ratio (~16.9)
    ratio = np.radians(wheel_deg[np.abs(wheel_deg) > 2.0]) / road[np.abs(wheel_deg) > 2.0]
    assert np.all((ratio > 15.0) & (ratio < 19.0))


def test_truth_is_the_reference_in_enu(imported: dict[str, list[tuple[float, object]]]) -> None:
    truth = [m for _, m in imported[TRUTH_POSE]]
    assert all(isinstance(m, GroundTruth) for m in truth)
    xy = np.array([[m.x_m, m.y_m] for m in truth])  # type: ignore[attr-defined]
    t = np.array([m.timestamp_s for m in truth])  # type: ignore[attr-defined]
    speed = np.array([m.vx_mps for m in truth])  # type: ignore[attr-defined]
    assert np.allclose(xy[0], 0.0, atol=1e-6)  # the ENU origin is the first pose
    travelled = np.sum(np.hypot(*np.diff(xy, axis=0).T))
    # ~17 m/s for 60 s; the distance agrees with the integrated speed to 1 %
    assert 900.0 < travelled < 1100.0
    assert abs(travelled - np.trapezoid(speed, t)) < 0.01 * travelled


def test_drop_gnss_removes_the_window_only(tmp_path: Path) -> None:
    out = tmp_path / "outage.mcap"
    result = import_log("comma2k19", shared_data(*SEGMENT), out, GnssOutage(25.0, 10.0))
    t_gnss = _source("processed_log/GNSS/live_gnss_ublox/t")
    start, end = result["gnss_outage_s"]
    assert end - start == pytest.approx(10.0)
    inside = (t_gnss >= start) & (t_gnss < end)
    assert 90 <= np.count_nonzero(inside) <= 100  # 10 s at ~9.7 Hz
    read = _read(out)
    times = np.array([t for t, _ in read[GPS_NMEA]])
    assert not np.any((times >= start) & (times < end))
    assert len(times) == 2 * np.count_nonzero(~inside)
    assert times.min() < start and times.max() >= end  # GNSS before and after the outage
    assert len(read[IMU_PACKET]) == len(_source("processed_log/IMU/gyro/t"))
    assert result["counts"]["gnss_dropped"] == np.count_nonzero(inside)


def test_cli_bad_outage_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = cli(["import", "comma2k19", str(shared_data(*SEGMENT)), "--out",
                str(tmp_path / "x.mcap"), "--drop-gnss", "25"])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "START_S:DURATION_S" in err[0]
    code = cli(["import", "comma2k19", str(tmp_path), "--out", str(tmp_path / "x.mcap")])
    assert code == 2
    assert "not a segment folder" in capsys.readouterr().err


def test_unknown_format_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = cli(["import", "rosbag9", str(tmp_path), "--out", str(tmp_path / "x.mcap")])
    assert code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown log format 'rosbag9'" in err[0] and "comma2k19" in err[0]
