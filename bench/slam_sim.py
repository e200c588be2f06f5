"""The SLAM benchmark's own small simulation (``bench slam_loops``): its figures are measured on it.

Not the project's simulator (simulator/; the Mapper's tests drive that one): a kinematic truth
trajectory along a track's centreline and sensor readings made directly as message objects (no
wire formats), driven harder than the simulator's exploration lap. Sensors: IMU (200 Hz, white
noise, mounted at ``car.imu_x_m``), wheel speeds (100 Hz), GPS position (10 Hz, 2.5 m sigma),
LiDAR cones (10 Hz sweeps, each cone stamped at its azimuth's time, range/bearing noise about
the LiDAR, missed and false cones, size class) and camera cones (10 Hz, colour with errors).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray
from scipy.interpolate import CubicSpline, splev, splprep

from common.car import CarConfig
from common.messages import (
    CameraCones,
    ConeColour,
    ConeDetection,
    ConeSize,
    ImuSample,
    LidarCones,
    SteeringAngle,
    WheelSpeeds,
)
from mapper.config import MapperConfig
from mapper.evaluation import (
    evaluate_map,
    nees,
    nees_fraction_in_band,
    pose_error_vectors,
    pose_errors,
)
from mapper.slam.ekf_slam import EkfSlam
from simulator.track_generator import generate_track

FloatArray = NDArray[np.float64]
DATA_DIR = Path(__file__).resolve().parents[2] / "shared" / "data"
FSG_PATH = DATA_DIR / "tracks" / "amz_fssim" / "FSG.yaml"


@dataclass
class Scenario:
    """Cones (N, 2) with colours and sizes (N,), and a closed centreline (M, 2), world frame."""

    name: str
    cones_xy_m: FloatArray
    colours: NDArray[np.int64]
    sizes: NDArray[np.int64]
    centreline_xy_m: FloatArray


@dataclass
class SimSettings:
    """Truth motion and sensor noise of the test simulation."""

    speed_mps: float = 8.0
    accel_mps2: float = 3.0
    max_lateral_accel_mps2: float = 10.0
    extra_distance_m: float = 25.0
    """Driven past the end of the lap (to see the big orange cones again)."""
    physics_rate_hz: float = 1000.0
    imu_rate_hz: float = 200.0
    gyro_noise_density_radps_rthz: float = 2.5e-4
    accel_noise_density_mps2_rthz: float = 5.0e-3
    gyro_bias_radps: float = 0.002
    """Constant gyro z bias (the project simulator draws one with sigma 0.002 rad/s)."""
    accel_bias_mps2: tuple[float, float] = (0.1, -0.05)
    rear_slip_rad_per_mps2: float = 0.0073
    """The rear axle's slip angle per lateral acceleration (rad per m/s^2), as the project
    simulator's tyres (rear cornering stiffness 14 per unit load), saturating as a tanh tyre at
    ``grip_lateral_accel_mps2`` (the car's lateral limit): the heading leads the course by the
    slip angle in a corner."""
    grip_lateral_accel_mps2: float = 1.5 * 9.81
    wheel_rate_hz: float = 100.0
    wheel_sigma_mps: float = 0.03
    gps_rate_hz: float = 10.0
    gps_sigma_m: float = 2.5
    lidar_rate_hz: float = 10.0
    lidar_range_m: float = 12.0
    lidar_fov_deg: float = 100.0
    lidar_range_sigma_m: float = 0.02
    lidar_bearing_sigma_rad: float = 0.001
    miss_probability: float = 0.10
    false_rate: float = 0.05
    size_error_probability: float = 0.02
    camera_rate_hz: float = 10.0
    camera_range_m: float = 15.0
    camera_fov_deg: float = 50.0
    camera_range_sigma_fraction: float = 0.02
    camera_colour_error: float = 0.05


@dataclass
class Trajectory:
    """Truth: arc length ``s_m(t)`` sampled at the physics rate along a unit-speed spline."""

    t_s: FloatArray
    s_m: FloatArray
    v_mps: FloatArray
    a_mps2: FloatArray
    spline_x: CubicSpline
    spline_y: CubicSpline
    lap_length_m: float
    start_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Where the car started in the scenario's original frame (x_m, y_m, yaw_rad)."""
    slip_rad_per_mps2: float = 0.0
    """Rear-axle slip angle per lateral acceleration: yaw = course + atan(alpha), alpha =
    k a_max atanh(a_y / a_max) (the tanh tyre law of mapper.motion.rear_slip_velocity)."""
    grip_lateral_accel_mps2: float = 1.5 * 9.81

    def state(self, t_s: FloatArray) -> dict[str, FloatArray]:
        """Pose, path speed ``v``, body velocities ``vx``/``vy``, yaw rate (``omega``, its
        derivative ``omega_dot``) and body accelerations ``ax``/``ay`` of the rear axle at times
        (K,)."""
        t = np.asarray(t_s, np.float64)
        out = self._state(t)
        h = 1.0e-3
        out["omega_dot"] = (self._state(t + h)["omega"] - self._state(t - h)["omega"]) / (2 * h)
        return out

    def _state(self, t: FloatArray) -> dict[str, FloatArray]:
        s = np.interp(t, self.t_s, self.s_m) % self.lap_length_m
        v = np.interp(t, self.t_s, self.v_mps)
        a = np.interp(t, self.t_s, self.a_mps2)
        dx, dy = self.spline_x(s, 1), self.spline_y(s, 1)
        ddx, ddy = self.spline_x(s, 2), self.spline_y(s, 2)
        d3x, d3y = self.spline_x(s, 3), self.spline_y(s, 3)
        norm = np.hypot(dx, dy)
        kappa = (dx * ddy - dy * ddx) / norm ** 3
        dkappa = (dx * d3y - dy * d3x) / norm ** 4
        k, a_max = self.slip_rad_per_mps2, self.grip_lateral_accel_mps2
        lat = v * v * kappa                        # lateral acceleration (m/s^2)
        dlat = 2.0 * v * a * kappa + v ** 3 * dkappa
        u = np.clip(lat / a_max, -0.95, 0.95)
        alpha = k * a_max * np.arctanh(u)          # rear slip angle (tanh tyre law)
        dalpha = k * dlat / (1.0 - u * u)
        beta = -np.arctan(alpha)                   # velocity direction relative to the heading
        omega = v * kappa + dalpha / (1.0 + alpha ** 2)
        cb, sb = np.cos(beta), np.sin(beta)
        return {
            "x": self.spline_x(s), "y": self.spline_y(s), "yaw": np.arctan2(dy, dx) - beta,
            "v": v, "a": a, "kappa": kappa, "omega": omega,
            "vx": v * cb, "vy": v * sb,
            "ax": a * cb - lat * sb, "ay": a * sb + lat * cb,
        }


@dataclass
class SimData:
    """Readings in time order as (timestamp_s, kind, payload) and the truth."""

    events: list[tuple[float, str, Any]]
    trajectory: Trajectory
    scenario: Scenario


@dataclass
class SlamRun:
    """What :func:`run_slam` measured."""

    slam: EkfSlam
    times_s: FloatArray
    est_pose: FloatArray
    true_pose: FloatArray
    pose_cov: FloatArray
    map_metrics: dict[str, Any] = field(default_factory=dict)
    pose_metrics: dict[str, float] = field(default_factory=dict)
    nees_values: FloatArray = field(default_factory=lambda: np.zeros(0))
    nees_in_band: float = math.nan


def _rigid(points: FloatArray, x0: float, y0: float, yaw0: float) -> FloatArray:
    """Express world points (N, 2) in the frame of pose (x0, y0, yaw0)."""
    c, s = math.cos(yaw0), math.sin(yaw0)
    d = points - np.array([x0, y0])
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def load_fsg(path: Path = FSG_PATH) -> Scenario:
    """The FSG 2018 track (AMZ FSSIM YAML) with its start pose as the world origin."""
    with Path(path).open() as fh:
        data = yaml.safe_load(fh)
    x0, y0, yaw0 = (float(v) for v in data.get("starting_pose_front_wing", [0.0, 0.0, 0.0]))

    def arr(key: str) -> FloatArray:
        a = np.asarray(data.get(key) or np.zeros((0, 2)), np.float64).reshape(-1, 2)
        keep = np.ones(a.shape[0], bool)
        if a.shape[0] > 1:
            keep[1:] = np.hypot(*np.diff(a, axis=0).T) > 1e-6
            if np.hypot(*(a[0] - a[-1])) < 1e-6:
                keep[-1] = False
        return _rigid(a[keep], x0, y0, yaw0)

    left, right = arr("cones_left"), arr("cones_right")
    orange, big = arr("cones_orange"), arr("cones_orange_big")
    nearest = np.argmin(np.hypot(left[:, None, 0] - right[None, :, 0],
                                 left[:, None, 1] - right[None, :, 1]), axis=1)
    centre = 0.5 * (left + right[nearest])
    cones = np.vstack([left, right, orange, big])
    colours = np.concatenate([
        np.full(len(left), int(ConeColour.BLUE)), np.full(len(right), int(ConeColour.YELLOW)),
        np.full(len(orange), int(ConeColour.ORANGE)), np.full(len(big), int(ConeColour.BIG_ORANGE)),
    ])
    sizes = np.where(colours == int(ConeColour.BIG_ORANGE), int(ConeSize.LARGE),
                     int(ConeSize.SMALL))
    return Scenario("FSG", cones, colours.astype(np.int64), sizes.astype(np.int64), centre)


def generated_loop(seed: int) -> Scenario:
    """The generated trackdrive layout ``gen:SEED``
    (:func:`simulator.track_generator.generate_track`)."""
    track = generate_track(seed)
    return Scenario(f"gen:{seed}", np.asarray(track.cones_xy_m, np.float64),
                    np.asarray(track.colours, np.int64), np.asarray(track.sizes, np.int64),
                    np.asarray(track.centreline_xy_m, np.float64))


def _periodic_spline(points: FloatArray, smoothing: float = 0.0
                     ) -> tuple[CubicSpline, CubicSpline, float]:
    """A closed polyline (M, 2) to periodic cubic splines x(s), y(s) in arc length s (m)."""
    pts = np.vstack([points, points[:1]])
    tck, _ = splprep([pts[:, 0], pts[:, 1]], s=smoothing, per=1)
    u = np.linspace(0.0, 1.0, 20001)
    x, y = splev(u, tck)
    seg = np.hypot(np.diff(x), np.diff(y))
    s = np.concatenate([[0.0], np.cumsum(seg)])
    lap = float(s[-1])
    step = max(1, int(round(0.5 / (lap / 20000))))
    idx = np.arange(0, 20001, step)
    if idx[-1] != 20000:
        idx = np.append(idx, 20000)
    xs, ys = np.asarray(x)[idx], np.asarray(y)[idx]
    xs[-1], ys[-1] = xs[0], ys[0]
    return (CubicSpline(s[idx], xs, bc_type="periodic"),
            CubicSpline(s[idx], ys, bc_type="periodic"), lap)


def make_trajectory(scenario: Scenario, settings: SimSettings) -> Trajectory:
    """From standstill at the origin along the centreline for one lap plus the extra distance."""
    centre = scenario.centreline_xy_m
    smooth = 0.5 * centre.shape[0]
    sx, sy, lap = _periodic_spline(centre, smoothing=smooth)
    # Start where the centreline passes closest to the origin; the car starts there.
    grid = np.linspace(0.0, lap, 4000, endpoint=False)
    u0 = float(grid[np.argmin(np.hypot(sx(grid), sy(grid)))])
    if math.cos(math.atan2(float(sy(u0, 1)), float(sx(u0, 1)))) < 0.0:
        raise ValueError("centreline runs against the start heading")
    knots = np.linspace(0.0, lap, int(lap / 0.5) + 1)
    pts = np.stack([sx((knots + u0) % lap), sy((knots + u0) % lap)], axis=1)
    start = (float(pts[0, 0]), float(pts[0, 1]),
             math.atan2(float(sy(u0, 1)), float(sx(u0, 1))))
    pts = _rigid(pts, *start)    # the world frame is the car's start pose
    px, py = pts[:, 0], pts[:, 1]
    px[-1], py[-1] = px[0], py[0]
    spline_x = CubicSpline(knots, px, bc_type="periodic")
    spline_y = CubicSpline(knots, py, bc_type="periodic")
    total = lap + settings.extra_distance_m
    s_grid = np.linspace(0.0, total, int(total / 0.25) + 1)
    sg = s_grid % lap
    dx, dy = spline_x(sg, 1), spline_y(sg, 1)
    kappa = np.abs(dx * spline_y(sg, 2) - dy * spline_x(sg, 2)) / np.hypot(dx, dy) ** 3
    vmax = np.minimum(settings.speed_mps,
                      np.sqrt(settings.max_lateral_accel_mps2 / np.maximum(kappa, 1e-6)))
    for i in range(len(vmax) - 2, -1, -1):   # braking limit
        ds = s_grid[i + 1] - s_grid[i]
        vmax[i] = min(vmax[i], math.sqrt(vmax[i + 1] ** 2 + 2 * settings.accel_mps2 * ds))
    dt = 1.0 / settings.physics_rate_hz
    t_list, s_list, v_list = [0.0], [0.0], [0.0]
    s, v, t = 0.0, 0.0, 0.0
    while s < total:
        limit = float(np.interp(s, s_grid, vmax))
        v_new = min(v + settings.accel_mps2 * dt, limit)
        v_new = max(v_new, v - settings.accel_mps2 * 2 * dt)
        s += 0.5 * (v + v_new) * dt
        v = v_new
        t += dt
        t_list.append(t)
        s_list.append(s)
        v_list.append(v)
    t_arr, s_arr, v_arr = np.array(t_list), np.array(s_list), np.array(v_list)
    a_arr = np.gradient(v_arr, t_arr)
    a_arr = np.convolve(a_arr, np.ones(21) / 21, mode="same")
    return Trajectory(t_arr, s_arr, v_arr, a_arr, spline_x, spline_y, lap, start,
                      settings.rear_slip_rad_per_mps2, settings.grip_lateral_accel_mps2)


def simulate(scenario: Scenario, car: CarConfig, settings: SimSettings | None = None,
             seed: int = 0) -> SimData:
    """All sensor readings of one lap (plus ``extra_distance_m``), in time order."""
    st = settings or SimSettings()
    rng = np.random.default_rng(seed)
    traj = make_trajectory(scenario, st)
    scenario = Scenario(scenario.name, _rigid(scenario.cones_xy_m, *traj.start_pose),
                        scenario.colours, scenario.sizes,
                        _rigid(scenario.centreline_xy_m, *traj.start_pose))
    t_end = float(traj.t_s[-1])
    events: list[tuple[float, str, Any]] = []
    # IMU at car.imu_x_m: a_imu = a_o + w_dot x r + w x (w x r).
    t_imu = np.arange(0.0, t_end, 1.0 / st.imu_rate_hz)
    k = traj.state(t_imu)
    r = car.imu_x_m
    sg = st.gyro_noise_density_radps_rthz * math.sqrt(st.imu_rate_hz)
    sa = st.accel_noise_density_mps2_rthz * math.sqrt(st.imu_rate_hz)
    gz = k["omega"] + st.gyro_bias_radps + rng.normal(0, sg, t_imu.size)
    ax = (k["ax"] - k["omega"] ** 2 * r + st.accel_bias_mps2[0]
          + rng.normal(0, sa, t_imu.size))
    ay = (k["ay"] + k["omega_dot"] * r + st.accel_bias_mps2[1]
          + rng.normal(0, sa, t_imu.size))
    for i, t in enumerate(t_imu):
        events.append((float(t), "imu", ImuSample(float(t), float(ax[i]), float(ay[i]), 9.81,
                                                  0.0, 0.0, float(gz[i]))))
    # Wheel speeds and steering.
    t_w = np.arange(0.0025, t_end, 1.0 / st.wheel_rate_hz)
    k = traj.state(t_w)
    half = 0.5 * car.track_width_m
    noise = rng.normal(0, st.wheel_sigma_mps, (t_w.size, 4))
    steer = np.arctan(car.wheelbase_m * k["kappa"])
    for i, t in enumerate(t_w):
        v, w = float(k["vx"][i]), float(k["omega"][i])
        front = v / max(math.cos(float(steer[i])), 0.5)
        events.append((float(t), "wheels", WheelSpeeds(
            float(t), max(front - w * half + noise[i, 0], 0.0),
            max(front + w * half + noise[i, 1], 0.0),
            max(v - w * half + noise[i, 2], 0.0), max(v + w * half + noise[i, 3], 0.0))))
        events.append((float(t), "steering", SteeringAngle(float(t), float(steer[i]))))
    # GPS.
    t_g = np.arange(0.05, t_end, 1.0 / st.gps_rate_hz)
    k = traj.state(t_g)
    cov = np.eye(2) * st.gps_sigma_m ** 2
    for i, t in enumerate(t_g):
        xy = np.array([k["x"][i], k["y"][i]]) + rng.normal(0, st.gps_sigma_m, 2)
        events.append((float(t), "gps", (xy, cov)))
    # LiDAR sweeps and camera frames.
    period = 1.0 / st.lidar_rate_hz
    for t in np.arange(period, t_end, period):
        events.append((float(t), "lidar", _lidar_sweep(scenario, traj, car, st, float(t),
                                                        period, rng)))
    for t in np.arange(0.03, t_end, 1.0 / st.camera_rate_hz):
        events.append((float(t), "camera", _camera_frame(scenario, traj, car, st, float(t), rng)))
    order = {"imu": 0, "wheels": 1, "steering": 2, "gps": 3, "lidar": 4, "camera": 5}
    events.sort(key=lambda e: (e[0], order[e[1]]))
    return SimData(events, traj, scenario)


def _in_vehicle(scenario: Scenario, pose: dict[str, FloatArray], i: int | slice
                ) -> FloatArray:
    c, s = math.cos(float(pose["yaw"][i])), math.sin(float(pose["yaw"][i]))
    d = scenario.cones_xy_m - np.array([float(pose["x"][i]), float(pose["y"][i])])
    return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)


def _lidar_sweep(scenario: Scenario, traj: Trajectory, car: CarConfig, st: SimSettings,
                 t_end: float, period: float, rng: np.random.Generator) -> LidarCones:
    lx = car.lidar_x_m
    q = _in_vehicle(scenario, traj.state(np.array([t_end])), 0)
    az = np.arctan2(q[:, 1], q[:, 0] - lx)
    # The sensor turns once per period starting behind: azimuth pi at the sweep start.
    t_cone = t_end - period * (1.0 - ((math.pi - az) / (2 * math.pi)) % 1.0)
    pose = traj.state(t_cone)
    c, s = np.cos(pose["yaw"]), np.sin(pose["yaw"])
    d = scenario.cones_xy_m - np.stack([pose["x"], pose["y"]], axis=1)
    qx = c * d[:, 0] + s * d[:, 1] - lx
    qy = -s * d[:, 0] + c * d[:, 1]
    rho, phi = np.hypot(qx, qy), np.arctan2(qy, qx)
    seen = (rho <= st.lidar_range_m) & (np.abs(phi) <= math.radians(st.lidar_fov_deg))
    seen &= rng.random(seen.size) >= st.miss_probability
    idx = np.flatnonzero(seen)
    rho_n = rho[idx] + rng.normal(0, st.lidar_range_sigma_m, idx.size)
    phi_n = phi[idx] + rng.normal(0, st.lidar_bearing_sigma_rad, idx.size)
    cones = []
    for j, i in enumerate(idx):
        size = int(scenario.sizes[i])
        if rng.random() < st.size_error_probability:
            size = int(ConeSize.SMALL) if size == int(ConeSize.LARGE) else int(ConeSize.LARGE)
        cones.append(ConeDetection(float(t_cone[i]), lx + float(rho_n[j] * math.cos(phi_n[j])),
                                   float(rho_n[j] * math.sin(phi_n[j])), ConeColour.UNKNOWN,
                                   ConeSize(size)))
    n_false = rng.poisson(st.false_rate * max(idx.size, 1))
    for _ in range(n_false):
        rr = rng.uniform(2.0, st.lidar_range_m)
        pp = rng.uniform(-math.radians(st.lidar_fov_deg), math.radians(st.lidar_fov_deg))
        cones.append(ConeDetection(t_end, lx + rr * math.cos(pp), rr * math.sin(pp),
                                   ConeColour.UNKNOWN, ConeSize.SMALL))
    return LidarCones(t_end, tuple(cones), sweep_start_s=t_end - period)


def _camera_frame(scenario: Scenario, traj: Trajectory, car: CarConfig, st: SimSettings,
                  t: float, rng: np.random.Generator) -> CameraCones:
    cx = car.camera_x_m
    q = _in_vehicle(scenario, traj.state(np.array([t])), 0)
    qx, qy = q[:, 0] - cx, q[:, 1]
    rho, phi = np.hypot(qx, qy), np.arctan2(qy, qx)
    seen = (rho <= st.camera_range_m) & (np.abs(phi) <= math.radians(st.camera_fov_deg))
    idx = np.flatnonzero(seen)
    rho_n = rho[idx] * (1.0 + rng.normal(0, st.camera_range_sigma_fraction, idx.size))
    phi_n = phi[idx] + rng.normal(0, 0.005, idx.size)
    cones = []
    for j, i in enumerate(idx):
        colour = int(scenario.colours[i])
        if rng.random() < st.camera_colour_error:
            colour = int(rng.integers(1, len(ConeColour)))
        cones.append(ConeDetection(t, cx + float(rho_n[j] * math.cos(phi_n[j])),
                                   float(rho_n[j] * math.sin(phi_n[j])), ConeColour(colour),
                                   confidence=0.9))
    return CameraCones(t, tuple(cones))


def run_slam(sim: SimData, config: MapperConfig | None = None, car: CarConfig | None = None
             ) -> SlamRun:
    """Feed a simulation to :class:`EkfSlam`; poses are recorded after every sweep."""
    cfg = config or MapperConfig()
    car = car or CarConfig()
    slam = EkfSlam(cfg, car)
    times, est, covs = [], [], []
    for t, kind, payload in sim.events:
        if kind == "imu":
            slam.predict(payload)
        elif kind == "wheels":
            slam.update_odometry(payload, None)
        elif kind == "gps":
            slam.update_gps_xy(payload[0], payload[1], t)
        elif kind == "lidar":
            slam.update_cones(payload.cones, payload.timestamp_s)
            pose = slam.pose()
            times.append(t)
            est.append((pose.x_m, pose.y_m, pose.yaw_rad))
            covs.append(pose.covariance)
        elif kind == "camera":
            slam.add_colour_votes(payload.cones)
    t_arr = np.array(times)
    k = sim.trajectory.state(t_arr)
    truth = np.stack([k["x"], k["y"], k["yaw"]], axis=1)
    est_arr, cov_arr = np.array(est).reshape(-1, 3), np.array(covs).reshape(-1, 3, 3)
    run = SlamRun(slam, t_arr, est_arr, truth, cov_arr)
    run.map_metrics = evaluate_map(slam.cone_map(), sim.scenario.cones_xy_m,
                                   sim.scenario.colours)
    run.pose_metrics = pose_errors(est_arr, truth)
    run.nees_values = nees(pose_error_vectors(est_arr, truth), cov_arr)
    run.nees_in_band = nees_fraction_in_band(run.nees_values, 3)
    return run
