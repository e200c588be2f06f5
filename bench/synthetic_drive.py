"""The localisation benchmark's drive (``bench localisation``): seed 001's experiment replayed.

Not the project's simulator (simulator/ emits raw hardware bytes; the Mapper's tests drive that
one): this one makes the parsed readings the Mapper takes, directly, with the same noise figures
as the simulator's defaults (``simulator/config.py``) where it has them, so the estimator can be
checked against truth without the sensor pipeline. A kinematic car (rear-axle origin, the rear
axle's tyre slip) follows a path at a speed profile after standing still at the start:

- IMU 200 Hz: specific force at ``car.imu_x_m`` (centripetal and tangential terms), white noise
  and a constant per-run bias;
- wheel speeds and steering 100 Hz: per-wheel speed with slip noise, a tyre-radius scale error;
- GNSS 10 Hz: WGS84 fixes about a geodetic origin with the world x axis along
  ``start_heading_enu_rad``, white noise plus a Gauss-Markov bias, speed and course with noise;
- LiDAR cones 10 Hz (10 ms latency): range and bearing noise, missed cones, false cones;
- camera cones 10 Hz (100 ms latency): noisier positions, colours (some wrong).

Every reading is delivered at its arrival time (timestamp + latency): :meth:`Drive.batches`
groups them into the Mapper's update calls.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.conventions import LocalTangentFrame, WorldFrame, world_to_vehicle
from common.messages import (
    CameraCones,
    ConeColour,
    ConeDetection,
    ConeMap,
    ConeSize,
    GpsFix,
    ImuSample,
    LidarCones,
    Reading,
    SteeringAngle,
    WheelSpeeds,
)

FloatArray = NDArray[np.float64]


@dataclass(slots=True)
class DriveNoise:
    """Sensor noise of the synthetic drive (SI units)."""

    imu_rate_hz: float = 200.0
    accel_sigma_mps2: float = 0.05
    gyro_sigma_radps: float = 0.002
    accel_bias_sigma_mps2: float = 0.05
    gyro_bias_sigma_radps: float = 0.002
    wheel_rate_hz: float = 100.0
    wheel_speed_sigma_mps: float = 0.03
    wheel_slip_sigma: float = 0.01
    wheel_scale_error: float = 0.005
    """Relative tyre-radius error (all wheels read this much fast)."""
    steering_sigma_rad: float = 0.002
    gnss_rate_hz: float = 10.0
    gnss_sigma_m: float = 2.5
    gnss_bias_sigma_m: float = 1.0
    gnss_bias_tau_s: float = 60.0
    gnss_speed_sigma_mps: float = 0.1
    gnss_course_sigma_rad: float = 0.05
    lidar_rate_hz: float = 10.0
    lidar_latency_s: float = 0.01
    lidar_range_m: float = 20.0
    lidar_fov_rad: float = math.radians(200.0)
    lidar_range_sigma_m: float = 0.02
    lidar_bearing_sigma_rad: float = 0.002
    miss_prob: float = 0.10
    false_fraction: float = 0.05
    """False cones per frame as a fraction of the true detections (Poisson)."""
    camera_rate_hz: float = 10.0
    camera_latency_s: float = 0.1
    camera_range_m: float = 20.0
    camera_fov_rad: float = math.radians(90.0)
    camera_sigma_m: float = 0.05
    camera_sigma_per_m: float = 0.02
    colour_error_prob: float = 0.02
    rear_slip_rad_per_mps2: float = 0.0073
    """Rear-axle slip angle per lateral acceleration (rad per m/s^2): the axle slides outwards
    at ``vx * k * a_y``, as the project simulator's tyres (cornering stiffness 14 per load)."""


@dataclass(slots=True)
class Truth:
    """Ground truth sampled at the IMU rate: each array (T,)."""

    t_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    yaw_rad: FloatArray
    vx_mps: FloatArray
    vy_mps: FloatArray
    yaw_rate_radps: FloatArray

    def at(self, t_s: float) -> tuple[float, float, float]:
        """Interpolated (x_m, y_m, yaw_rad) at ``t_s``."""
        yaw = np.unwrap(self.yaw_rad)
        return (float(np.interp(t_s, self.t_s, self.x_m)),
                float(np.interp(t_s, self.t_s, self.y_m)),
                float(np.interp(t_s, self.t_s, yaw)))


@dataclass(slots=True)
class Drive:
    """A generated drive: readings in arrival order, the truth, the cones, the world frame."""

    arrivals: list[tuple[float, Reading]]
    truth: Truth
    cones_xy_m: FloatArray
    cone_colours: NDArray[np.int64]
    frame: WorldFrame
    duration_s: float
    lidar_frames: list[tuple[LidarCones, NDArray[np.int64]]] = field(default_factory=list)
    """Each LiDAR frame with the true cone index of each detection (-1 for false ones)."""

    def batches(self, rate_hz: float = 100.0) -> Iterator[tuple[float, list[Reading]]]:
        """(now_s, readings that arrived since the previous call), at ``rate_hz``."""
        i = 0
        n = len(self.arrivals)
        steps = int(math.ceil(self.duration_s * rate_hz))
        for k in range(1, steps + 1):
            now = k / rate_hz
            batch: list[Reading] = []
            while i < n and self.arrivals[i][0] <= now + 1e-9:
                batch.append(self.arrivals[i][1])
                i += 1
            yield now, batch

    def cone_map(self) -> ConeMap:
        """The true cones as a map (zero covariance)."""
        n = self.cones_xy_m.shape[0]
        sizes = np.where(self.cone_colours == int(ConeColour.BIG_ORANGE), int(ConeSize.LARGE),
                         int(ConeSize.SMALL))
        return ConeMap(self.cones_xy_m, np.zeros((n, 2, 2)), self.cone_colours, sizes,
                       np.ones(n), np.arange(n))


def loop_path(length_m: float = 100.0, step_m: float = 0.05) -> tuple[FloatArray, FloatArray]:
    """A closed stadium loop of ``length_m`` with smoothed curvature: (s (M,), curvature (M,))."""
    radius = 9.0
    straight = 0.5 * (length_m - 2.0 * math.pi * radius)
    s = np.arange(0.0, length_m, step_m)
    arc = math.pi * radius
    kappa = np.where((s % (straight + arc)) < straight, 0.0, 1.0 / radius)
    # Smooth the curvature steps (a steering rate limit) keeping the total turn at 2 pi.
    win = int(4.0 / step_m)
    kernel = np.ones(win) / win
    padded = np.concatenate([kappa[-win:], kappa, kappa[:win]])
    kappa = np.convolve(padded, kernel, mode="same")[win:-win]
    kappa *= 2.0 * math.pi / (kappa.sum() * step_m)
    # Start in the middle of a straight.
    return s, np.roll(kappa, int(0.5 * straight / step_m))


def straight_path(length_m: float = 100.0, step_m: float = 0.05) -> tuple[FloatArray, FloatArray]:
    """A straight: (s (M,), zero curvature (M,))."""
    s = np.arange(0.0, length_m + 20.0, step_m)
    return s, np.zeros_like(s)


def _integrate_path(s: FloatArray, kappa: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    ds = np.diff(s, prepend=s[0])
    yaw = np.cumsum(kappa * ds)
    yaw -= yaw[0]
    x = np.cumsum(np.cos(yaw) * ds)
    y = np.cumsum(np.sin(yaw) * ds)
    return x - x[0], y - y[0], yaw


def make_drive(
    kind: str = "loop",
    seed: int = 0,
    car: CarConfig | None = None,
    noise: DriveNoise | None = None,
    length_m: float = 100.0,
    speed_mps: float = 5.0,
    standstill_s: float = 3.0,
    start_heading_enu_rad: float = 0.7,
    origin: tuple[float, float, float] = (49.3269, 8.5654, 100.0),
    cone_spacing_m: float = 4.0,
    half_width_m: float = 1.5,
    tail_s: float = 0.5,
) -> Drive:
    """Generate a drive: ``kind`` "loop" (one lap of a ~``length_m`` closed loop) or "straight"
    (``length_m`` between two rows of cones ``2 half_width_m`` apart)."""
    car = car or CarConfig()
    nz = noise or DriveNoise()
    rng = np.random.default_rng(seed)
    s_path, k_path = loop_path(length_m) if kind == "loop" else straight_path(length_m)
    px, py, pyaw = _integrate_path(s_path, k_path)

    # Cones: both sides of the path every cone_spacing_m; big orange pairs at the start.
    n_c = int(length_m // cone_spacing_m)
    cs = np.arange(n_c) * cone_spacing_m + (0.0 if kind == "loop" else 2.0)
    if kind != "loop":
        cs = cs[cs <= length_m + 10.0]
    cx = np.interp(cs, s_path, px)
    cy = np.interp(cs, s_path, py)
    cyaw = np.interp(cs, s_path, pyaw)
    nx, ny = -np.sin(cyaw), np.cos(cyaw)
    left = np.stack([cx + half_width_m * nx, cy + half_width_m * ny], 1)
    right = np.stack([cx - half_width_m * nx, cy - half_width_m * ny], 1)
    cones = np.vstack([left, right])
    colours = np.concatenate([np.full(len(cs), int(ConeColour.BLUE)),
                              np.full(len(cs), int(ConeColour.YELLOW))])
    if kind == "loop":
        colours[0] = colours[len(cs)] = int(ConeColour.BIG_ORANGE)
        extra = np.array([[0.6, half_width_m], [0.6, -half_width_m]])
        cones = np.vstack([cones, extra])
        colours = np.concatenate([colours, [int(ConeColour.BIG_ORANGE)] * 2])

    # Speed profile: standstill, accelerate at 2 m/s^2, cruise, brake at the end of the lap.
    dt = 1.0 / nz.imu_rate_hz
    accel = 2.0
    t_acc = speed_mps / accel
    d_acc = 0.5 * accel * t_acc**2
    cruise = max(length_m - 2.0 * d_acc, 0.0) / speed_mps
    duration = standstill_s + 2.0 * t_acc + cruise + tail_s
    t = np.arange(0.0, duration, dt)
    tau = t - standstill_s
    v = np.clip(np.minimum(accel * tau, speed_mps), 0.0, None)
    t_brake = t_acc + cruise
    v = np.where(tau > t_brake, np.clip(speed_mps - accel * (tau - t_brake), 0.0, None), v)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * dt)])
    kappa = np.interp(s, s_path, k_path)
    yaw_rate = v * kappa
    yaw = np.concatenate([[0.0], np.cumsum(0.5 * (yaw_rate[1:] + yaw_rate[:-1]) * dt)])
    ay_lat = v * yaw_rate
    vy = -nz.rear_slip_rad_per_mps2 * v * ay_lat
    vx = v
    vxw = vx * np.cos(yaw) - vy * np.sin(yaw)
    vyw = vx * np.sin(yaw) + vy * np.cos(yaw)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (vxw[1:] + vxw[:-1]) * dt)])
    y = np.concatenate([[0.0], np.cumsum(0.5 * (vyw[1:] + vyw[:-1]) * dt)])
    truth = Truth(t, x, y, yaw, vx, vy, yaw_rate)

    arrivals: list[tuple[float, Reading]] = []

    # IMU: specific force at the IMU position, vehicle frame.
    dvx = np.gradient(vx, dt)
    dvy = np.gradient(vy, dt)
    dw = np.gradient(yaw_rate, dt)
    r = car.imu_x_m
    ax_true = dvx - yaw_rate * vy - yaw_rate**2 * r
    ay_true = dvy + yaw_rate * vx + dw * r
    ab = rng.normal(0.0, nz.accel_bias_sigma_mps2, 2)
    gb = rng.normal(0.0, nz.gyro_bias_sigma_radps)
    axm = ax_true + ab[0] + rng.normal(0.0, nz.accel_sigma_mps2, t.size)
    aym = ay_true + ab[1] + rng.normal(0.0, nz.accel_sigma_mps2, t.size)
    azm = 9.81 + rng.normal(0.0, nz.accel_sigma_mps2, t.size)
    gzm = yaw_rate + gb + rng.normal(0.0, nz.gyro_sigma_radps, t.size)
    for k in range(t.size):
        arrivals.append((float(t[k]) + 0.001, ImuSample(float(t[k]), float(axm[k]), float(aym[k]),
                                                        float(azm[k]), 0.0, 0.0, float(gzm[k]))))

    # Wheels and steering.
    step = max(1, int(round(nz.imu_rate_hz / nz.wheel_rate_hz)))
    half = 0.5 * car.track_width_m
    scale = 1.0 + nz.wheel_scale_error
    for k in range(0, t.size, step):
        tk = float(t[k])
        w = yaw_rate[k]
        rl, rr = vx[k] - w * half, vx[k] + w * half
        vfx = vx[k]
        vfy = vy[k] + w * car.wheelbase_m
        vf = math.hypot(vfx, vfy)
        fl, fr = vf - w * half, vf + w * half
        speeds = []
        for sp in (fl, fr, rl, rr):
            noisy = sp * scale * (1.0 + rng.normal(0.0, nz.wheel_slip_sigma))
            noisy += rng.normal(0.0, nz.wheel_speed_sigma_mps)
            speeds.append(max(noisy, 0.0) if abs(sp) > 1e-6 else 0.0)
        arrivals.append((tk + 0.002, WheelSpeeds(tk, *speeds)))
        steer = math.atan(car.wheelbase_m * kappa[k]) + rng.normal(0.0, nz.steering_sigma_rad)
        arrivals.append((tk + 0.002, SteeringAngle(tk, float(steer))))

    # GNSS.
    frame = WorldFrame(LocalTangentFrame(*origin), 0.0, 0.0, start_heading_enu_rad)
    step = int(round(nz.imu_rate_hz / nz.gnss_rate_hz))
    bias = rng.normal(0.0, nz.gnss_bias_sigma_m, 2)
    phi = math.exp(-1.0 / (nz.gnss_rate_hz * nz.gnss_bias_tau_s))
    for k in range(0, t.size, step):
        tk = float(t[k])
        bias = phi * bias + math.sqrt(1.0 - phi**2) * nz.gnss_bias_sigma_m * rng.normal(size=2)
        en = frame.world_to_enu([x[k], y[k]]) + bias + rng.normal(0.0, nz.gnss_sigma_m, 2)
        lat, lon, _ = frame.enu.to_geodetic(en[0], en[1], 0.0)
        speed = math.hypot(vxw[k], vyw[k])
        if speed > 0.1:
            course = math.atan2(vyw[k], vxw[k]) + start_heading_enu_rad
            course += rng.normal(0.0, nz.gnss_course_sigma_rad * max(1.0, 1.0 / speed))
            course = math.atan2(math.sin(course), math.cos(course))
        else:
            course = math.nan
        speed_m = abs(speed + rng.normal(0.0, nz.gnss_speed_sigma_mps))
        arrivals.append((tk + 0.02, GpsFix(tk, float(lat), float(lon), origin[2], 1, 12, 0.9,
                                           speed_m, course)))

    # LiDAR and camera.
    lidar_frames: list[tuple[LidarCones, NDArray[np.int64]]] = []
    step = int(round(nz.imu_rate_hz / nz.lidar_rate_hz))
    for k in range(step, t.size, step):
        tk = float(t[k])
        rel = world_to_vehicle(cones, x[k], y[k], yaw[k])
        det, idx = _lidar_frame(rel, car, nz, rng, tk)
        lc = LidarCones(tk, tuple(det), sweep_start_s=tk - 0.1, point_count=0)
        lidar_frames.append((lc, idx))
        arrivals.append((tk + nz.lidar_latency_s, lc))
    step = int(round(nz.imu_rate_hz / nz.camera_rate_hz))
    for k in range(step // 2, t.size, step):
        tk = float(t[k])
        rel = world_to_vehicle(cones, x[k], y[k], yaw[k])
        cam = _camera_frame(rel, colours, car, nz, rng, tk)
        arrivals.append((tk + nz.camera_latency_s, CameraCones(tk, tuple(cam), frame_id=k)))

    arrivals.sort(key=lambda a: a[0])
    return Drive(arrivals, truth, cones, colours.astype(np.int64), frame, duration,
                 lidar_frames)


def _lidar_frame(rel: FloatArray, car: CarConfig, nz: DriveNoise, rng: np.random.Generator,
                 tk: float) -> tuple[list[ConeDetection], NDArray[np.int64]]:
    lx = rel[:, 0] - car.lidar_x_m
    ly = rel[:, 1]
    rng_m = np.hypot(lx, ly)
    bearing = np.arctan2(ly, lx)
    seen = (rng_m <= nz.lidar_range_m) & (np.abs(bearing) <= 0.5 * nz.lidar_fov_rad)
    seen &= rng.random(rel.shape[0]) >= nz.miss_prob
    idx = np.flatnonzero(seen)
    r = rng_m[idx] + rng.normal(0.0, nz.lidar_range_sigma_m, idx.size)
    b = bearing[idx] + rng.normal(0.0, nz.lidar_bearing_sigma_rad, idx.size)
    dets = [ConeDetection(tk, float(car.lidar_x_m + ri * math.cos(bi)), float(ri * math.sin(bi)),
                          height_m=0.325 + float(rng.normal(0.0, 0.02)),
                          width_m=0.228 + float(rng.normal(0.0, 0.02)))
            for ri, bi in zip(r, b, strict=True)]
    n_false = int(rng.poisson(nz.false_fraction * max(idx.size, 1)))
    for _ in range(n_false):
        rf = math.sqrt(rng.uniform(1.0, nz.lidar_range_m**2))
        bf = rng.uniform(-0.5, 0.5) * nz.lidar_fov_rad
        dets.append(ConeDetection(tk, float(car.lidar_x_m + rf * math.cos(bf)),
                                  float(rf * math.sin(bf)),
                                  height_m=float(rng.uniform(0.2, 0.5)),
                                  width_m=float(rng.uniform(0.15, 0.35))))
    out_idx = np.concatenate([idx, np.full(n_false, -1)]).astype(np.int64)
    return dets, out_idx


def _camera_frame(rel: FloatArray, colours: NDArray[np.int64], car: CarConfig, nz: DriveNoise,
                  rng: np.random.Generator, tk: float) -> list[ConeDetection]:
    cx = rel[:, 0] - car.camera_x_m
    rng_m = np.hypot(cx, rel[:, 1])
    bearing = np.arctan2(rel[:, 1], cx)
    seen = (rng_m <= nz.camera_range_m) & (np.abs(bearing) <= 0.5 * nz.camera_fov_rad)
    seen &= rng.random(rel.shape[0]) >= nz.miss_prob
    out = []
    for i in np.flatnonzero(seen):
        sigma = nz.camera_sigma_m + nz.camera_sigma_per_m * rng_m[i]
        colour = int(colours[i])
        if rng.random() < nz.colour_error_prob:
            colour = int(rng.choice([c for c in (1, 2, 3, 4) if c != colour]))
        out.append(ConeDetection(tk, float(rel[i, 0] + rng.normal(0.0, sigma)),
                                 float(rel[i, 1] + rng.normal(0.0, sigma)),
                                 colour=ConeColour(colour), confidence=0.9))
    return out
