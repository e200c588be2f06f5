"""comma2k19 segments (commaai/comma2k19): a Toyota RAV4's IMU, u-blox GNSS and CAN, with comma's
fused pose as the reference.

A segment folder holds numpy arrays saved without the ``.npy`` suffix, each channel a folder
with ``t`` (s of the device's boot time, the log's time base kept here) and ``value``:

- ``processed_log/IMU/accelerometer``, ``gyro_uncalibrated`` (N, 3): the device frame (x
  forward, y right, z down; specific force, about (0, 0, -9.81) at rest), 100 Hz. The raw gyro
  is imported, as an IMU sends it (its z bias here is 0.07 rad/s): the UKF's bias states learn
  it (``gyro`` is the same less the phone's own bias estimate);
- ``processed_log/GNSS/live_gnss_ublox`` (N, 6): latitude deg, longitude deg, speed m/s, UTC
  time ms, altitude m, bearing deg (clockwise from north), 10 Hz, stamped on arrival;
- ``processed_log/CAN/wheel_speed`` (N, 4) m/s (front left, front right, rear left, rear right)
  and ``steering_angle`` (N,) steering-wheel degrees, positive to the left;
- ``global_pose/frame_times``, ``frame_positions``, ``frame_velocities`` (ECEF m, m/s) at 20 Hz:
  comma's fused INS/GNSS/vision pose of the device (camera and GNSS receiver in one housing),
  the reference point of the dataset.

The device sits on the windscreen, :data:`DEVICE_X_M` ahead of the rear axle; its IMU is turned
a little against the car (the mount): roll and pitch from the accelerometer's mean against
gravity (the wheels' mean acceleration removed), yaw from the longitudinal and lateral specific
forces against the wheels' acceleration and the centripetal ``v w``. The wheel speed scale is
the receiver's speed over the wheels'. These calibrations use the car's own sensors only, never
the reference. They go with the car's geometry into the configuration the recording carries.
The fixes are timed by their UTC time on the boot clock (``mapper.ukf.gnss_time_from_utc``); no
latency is written: the replay estimates it from the log's own fixes and wheels
(:mod:`mapper.gnss_latency`), as on a team's car, where there is no reference to calibrate
against.

The GNSS receiver gives no accuracy fields here (no HDOP, no satellite count in these arrays):
the fixes are written as NMEA GGA and RMC without them.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import numpy as np
import pymap3d
from numpy.typing import NDArray

from common.conventions import mount_rotation
from common.errors import RecordingError
from common.messages import GpsFix, GroundTruth, ImuSample, SteeringAngle, WheelSpeeds
from recordings.importers.base import GnssOutage, ImportedLog, ImportedReading

log = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

GRAVITY_MPS2 = 9.80665
DEVICE_X_M = 1.2
"""The comma device (IMU and GNSS antenna) ahead of the rear axle (m): the top of the
windscreen of a 2018 RAV4 (wheelbase 2.66 m); an estimate, not a survey."""
GNSS_POSITION_SIGMA_M = 2.0
"""The fixes' noise for the UKF (m): their error is about 0.4 m RMS but correlated over
seconds; 2 m keeps the position NEES near its 2 degrees of freedom on this segment."""
GYRO_BIAS_SIGMA_RADPS = 0.1
"""The raw gyro's bias before the filter learns it (rad/s): a phone-grade MEMS gyro's turn-on
bias reaches several degrees per second."""
STEER_RATIO = 16.88
"""Steering-wheel angle over road-wheel angle of the 2017-2018 RAV4 (openpilot's value)."""

#: The 2018 Toyota RAV4's geometry (manufacturer's data) and limits, as ``[car]`` overrides.
RAV4_CAR: dict[str, Any] = {
    "name": "toyota_rav4_2018",
    "wheelbase_m": 2.66,
    "track_width_m": 1.6,
    "length_m": 4.6,
    "width_m": 1.845,
    "rear_overhang_m": 0.98,
    "cg_to_front_axle_m": 1.1,
    "mass_kg": 1600.0,
    "yaw_inertia_kgm2": 2500.0,
    "wheel_radius_m": 0.35,
    "max_lateral_accel_mps2": 8.0,
    "max_steer_rad": 0.6,
    "top_speed_mps": 50.0,
    "imu_x_m": DEVICE_X_M,
    "camera_x_m": DEVICE_X_M,
    "camera_z_m": 1.3,
}

_CHANNELS = {
    "accel": "processed_log/IMU/accelerometer",
    "gyro": "processed_log/IMU/gyro_uncalibrated",
    "gnss": "processed_log/GNSS/live_gnss_ublox",
    "wheels": "processed_log/CAN/wheel_speed",
    "steering": "processed_log/CAN/steering_angle",
}


def _array(path: Path) -> FloatArray:
    try:
        with path.open("rb") as fh:
            return np.asarray(np.load(fh, allow_pickle=False), np.float64)
    except (OSError, ValueError) as exc:
        raise RecordingError(f"comma2k19: cannot read {path}: {exc}") from exc


def _channel(root: Path, name: str, columns: int | None) -> tuple[FloatArray, FloatArray]:
    """(t (N,), value (N,) or (N, columns)) of one channel, checked."""
    folder = root / name
    t, v = _array(folder / "t"), _array(folder / "value")
    if t.ndim != 1 or len(v) != len(t) or len(t) < 2:
        raise RecordingError(f"comma2k19: {folder}: t {t.shape} and value {v.shape} do not match")
    if columns is not None and (v.ndim != 2 or v.shape[1] != columns):
        raise RecordingError(f"comma2k19: {folder}: value has shape {v.shape}, "
                             f"expected (N, {columns})")
    if columns is None and v.ndim == 2 and v.shape[1] == 1:
        v = v[:, 0]
    order = np.argsort(t, kind="stable")
    return t[order], v[order]


def load(segment: Path, drop_gnss: GnssOutage | None = None) -> ImportedLog:
    """Read a comma2k19 segment folder (see the module docstring); ``drop_gnss``: leave out the
    fixes of that window (from the readings and from the calibrations)."""
    segment = Path(segment)
    if not (segment / "processed_log").is_dir() or not (segment / "global_pose").is_dir():
        raise RecordingError(f"comma2k19: {segment} is not a segment folder (no processed_log/ "
                             f"and global_pose/)")
    t_acc, acc = _channel(segment, _CHANNELS["accel"], 3)
    t_gyr, gyr = _channel(segment, _CHANNELS["gyro"], 3)
    t_gnss, gnss = _channel(segment, _CHANNELS["gnss"], 6)
    t_ws, ws = _channel(segment, _CHANNELS["wheels"], 4)
    t_st, steer = _channel(segment, _CHANNELS["steering"], None)
    if len(t_acc) != len(t_gyr) or np.max(np.abs(t_acc - t_gyr)) > 1e-6:
        raise RecordingError("comma2k19: accelerometer and gyro samples are not paired")
    window = None
    dropped = 0
    if drop_gnss is not None:
        window = drop_gnss.window(float(min(t_acc[0], t_gnss[0], t_ws[0], t_st[0])))
        keep = (t_gnss < window[0]) | (t_gnss >= window[1])
        dropped = int(np.count_nonzero(~keep))
        t_gnss, gnss = t_gnss[keep], gnss[keep]
        if len(t_gnss) == 0:
            raise RecordingError(f"comma2k19: --drop-gnss leaves no fix in {segment}")
    # Device frame (x forward, y right, z down) to ours (x forward, y left, z up).
    flip = np.array([1.0, -1.0, -1.0])
    acc_v, gyr_v = acc * flip, gyr * flip
    rpy = _imu_mount(t_acc, acc_v, gyr_v, t_ws, ws, _course_rate(t_gnss, gnss))
    scale = _wheel_scale(t_gnss, gnss, t_ws, ws)

    readings: list[ImportedReading] = []
    for t, a, g in zip(t_acc, acc_v, gyr_v, strict=True):
        if np.all(np.isfinite(a)) and np.all(np.isfinite(g)):
            readings.append(ImuSample(float(t), float(a[0]), float(a[1]), float(a[2]),
                                      float(g[0]), float(g[1]), float(g[2])))
    for t, w in zip(t_ws, ws, strict=True):
        readings.append(WheelSpeeds(float(t), float(w[0]), float(w[1]), float(w[2]),
                                    float(w[3])))
    for t, s in zip(t_st, steer, strict=True):
        readings.append(SteeringAngle(float(t), math.radians(float(s)) / STEER_RATIO))
    utc_s = gnss[:, 3] * 1e-3
    day_s = math.floor(float(utc_s[0]) / 86400.0) * 86400.0
    for t, row, u in zip(t_gnss, gnss, utc_s, strict=True):
        lat, lon, speed, _, alt, bearing = (float(v) for v in row)
        if not (math.isfinite(lat) and math.isfinite(lon)):
            continue
        readings.append(GpsFix(float(t), lat, lon, alt, fix_quality=1,
                               speed_mps=speed, course_rad=math.radians(90.0 - bearing),
                               utc_time_s=float(u - day_s)))
    readings.sort(key=lambda r: r.timestamp_s)
    truth, origin = _truth(segment)
    config: dict[str, Any] = {
        "car": {**RAV4_CAR, "imu_roll_rad": rpy[0], "imu_pitch_rad": rpy[1],
                "imu_yaw_rad": rpy[2]},
        "mapper": {"ukf": {
            "gnss_antenna_x_m": DEVICE_X_M,
            "initial_gyro_bias_sigma_radps": GYRO_BIAS_SIGMA_RADPS,
            "gnss_time_from_utc": True,
            "gnss_position_sigma_m": GNSS_POSITION_SIGMA_M,
            "odometry_speed_scale": scale,
            "odometry_yaw_rate_source": "steering",
        }},
    }
    log.info("comma2k19 %s: %d readings, %d reference poses; IMU mount roll %.4f pitch %.4f "
             "yaw %.4f rad, wheel speed scale %.5f", segment.name, len(readings), len(truth),
             *rpy, scale)
    return ImportedLog(
        name=f"comma2k19:{segment.name}",
        readings=readings,
        truth=truth,
        truth_origin=origin,
        gnss_utc_day_s=day_s,
        gnss_outage_s=window,
        gnss_dropped=dropped,
        config=config,
        metadata={"source": "comma2k19", "segment": segment.name,
                  "reference": "comma global_pose (fused INS/GNSS/vision) of the device",
                  "truth_frame": "enu", "truth_lat0_deg": repr(origin[0]),
                  "truth_lon0_deg": repr(origin[1]), "truth_alt0_m": repr(origin[2]),
                  "truth_yaw": "direction of travel, CCW from east",
                  "reference_point": "device"},
    )


def _truth(segment: Path) -> tuple[list[GroundTruth], tuple[float, float, float]]:
    """comma's pose of the device in the ENU frame of its first position."""
    pose = segment / "global_pose"
    t = _array(pose / "frame_times")
    p = _array(pose / "frame_positions")
    v = _array(pose / "frame_velocities")
    if p.shape != (len(t), 3) or v.shape != (len(t), 3):
        raise RecordingError(f"comma2k19: {pose}: positions {p.shape} and velocities {v.shape} "
                             f"for {len(t)} times")
    ok = np.all(np.isfinite(p), axis=1) & np.all(np.isfinite(v), axis=1) & np.isfinite(t)
    t, p, v = t[ok], p[ok], v[ok]
    lat0, lon0, alt0 = (float(x) for x in pymap3d.ecef2geodetic(*p[0]))
    e, n, _ = pymap3d.ecef2enu(p[:, 0], p[:, 1], p[:, 2], lat0, lon0, alt0)
    ve, vn, _ = pymap3d.ecef2enuv(v[:, 0], v[:, 1], v[:, 2], lat0, lon0)
    e, n, ve, vn = (np.asarray(a, np.float64) for a in (e, n, ve, vn))
    yaw = np.arctan2(vn, ve)
    rate = np.gradient(np.unwrap(yaw), t)
    truth = [GroundTruth(float(t[i]), float(e[i]), float(n[i]), float(yaw[i]),
                         float(math.hypot(ve[i], vn[i])), 0.0, float(rate[i]))
             for i in range(len(t))]
    return truth, (lat0, lon0, alt0)


def _course_rate(t_gnss: FloatArray, gnss: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(times, yaw rate rad/s CCW) from the receiver's bearings, smoothed over 1 s (10 fixes)."""
    course = np.unwrap(np.radians(-gnss[:, 5]))
    rate = np.gradient(course, t_gnss)
    k = min(10, len(rate))
    return t_gnss, np.convolve(rate, np.ones(k) / k, mode="same")


def _imu_mount(t_imu: FloatArray, acc: FloatArray, gyr: FloatArray, t_ws: FloatArray,
               ws: FloatArray, course_rate: tuple[FloatArray, FloatArray]
               ) -> tuple[float, float, float]:
    """The IMU's roll, pitch, yaw (rad) against the car (vehicle frame, z up), from the log.

    Roll and pitch turn the mean specific force, less the wheels' mean longitudinal
    acceleration, onto +z. Yaw: least squares of the levelled horizontal specific force against
    the wheels' acceleration a_x and the centripetal ``v w`` (the car's own a_y; ``w`` the gyro
    less its mean offset from the receiver's course rate ``course_rate``, times and rad/s): with
    the IMU turned by psi, it reads ``(a_x + psi a_y, a_y - psi a_x)``.
    """
    v = np.interp(t_imu, t_ws, ws.mean(axis=1))
    a_long = np.gradient(v, t_imu)
    # Smooth the wheels' derivative over 0.5 s (the CAN speeds come in 1/36 m/s steps).
    k = max(1, int(round(0.5 / max(float(np.median(np.diff(t_imu))), 1e-3))))
    kernel = np.ones(k) / k
    a_long = np.convolve(a_long, kernel, mode="same")
    mean = acc.mean(axis=0) - np.array([a_long.mean(), 0.0, 0.0])
    roll = math.atan2(float(mean[1]), float(mean[2]))
    pitch = math.atan2(-float(mean[0]), math.hypot(float(mean[1]), float(mean[2])))
    level = mount_rotation(roll, pitch, 0.0) @ acc.T  # vehicle axes, less the yaw
    # The gyro's z bias (the raw gyro: 0.07 rad/s here) against the receiver's course rate.
    gz = gyr[:, 2] - float(np.mean(gyr[:, 2] - np.interp(t_imu, *course_rate)))
    a_lat = v * gz
    ax = np.convolve(level[0], kernel, mode="same")
    ay = np.convolve(level[1], kernel, mode="same")
    a_lat_s = np.convolve(a_lat, kernel, mode="same")
    # ax - a_long = psi a_lat ; ay - a_lat = -psi a_long (bias terms removed by centring)
    lhs = np.concatenate([ax - a_long, ay - a_lat_s])
    rhs = np.concatenate([a_lat_s, -a_long])
    lhs = lhs - np.concatenate([np.full(len(ax), np.mean(ax - a_long)),
                                np.full(len(ay), np.mean(ay - a_lat_s))])
    rhs = rhs - np.concatenate([np.full(len(ax), np.mean(a_lat_s)),
                                np.full(len(ay), np.mean(-a_long))])
    den = float(rhs @ rhs)
    yaw = float(lhs @ rhs) / den if den > 0.0 else 0.0
    return roll, pitch, yaw


def _wheel_scale(t_gnss: FloatArray, gnss: FloatArray, t_ws: FloatArray, ws: FloatArray) -> float:
    """The receiver's speed over the rear wheels' mean (both above 3 m/s): the wheels' scale."""
    v_wheels = np.interp(t_gnss, t_ws, 0.5 * (ws[:, 2] + ws[:, 3]))
    v_gnss = gnss[:, 2]
    ok = np.isfinite(v_gnss) & (v_gnss > 3.0) & (v_wheels > 3.0)
    if np.count_nonzero(ok) < 10:
        return 1.0
    return float(np.sum(v_gnss[ok]) / np.sum(v_wheels[ok]))
