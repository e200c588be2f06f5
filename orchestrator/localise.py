"""Replay without a track: the Mapper's localisation only, scored against the recording's truth.

A recording with no commands and no track (a road drive brought in by ``import``) has nothing
to plan or steer: the planner and the controller stay idle (they are not built), and the raw
sensor units go through the Sensor Manager to a Mapper in its localisation-only mode
(:class:`mapper.mapper.Mapper`, ``localisation_only``), ticked at the control rate on the
recording's own clock. The configuration is the recording's (the car the importer wrote), with
``--config`` on top.

Writes into the out folder:

- ``estimate.csv``: ``t_s,lat_deg,lon_deg,heading_deg`` per tick once the filter has started:
  the estimate at the reference point (the GNSS antenna, ``mapper.ukf.gnss_antenna_x_m`` ahead
  of the rear axle), ``t_s`` in the log's time base, ``heading_deg`` the direction of travel
  there, clockwise from north in [0, 360);
- ``summary.json``: position and course RMSE against the truth (horizontal, after the first
  ``EVAL_SKIP_S`` of the log), the raw fixes' RMSE at their own times, the position NEES, and
  inside a GNSS outage recorded by ``import --drop-gnss`` the worst error there; the GNSS
  latency used (``gnss_latency_s``) and where it came from (``gnss_latency_source``:
  ``configured`` when ``mapper.ukf.gnss_latency_s`` is set, else ``estimated`` from the log
  itself in a first pass over it, :mod:`mapper.gnss_latency`, with ``gnss_latency_sigma_s``
  and the estimate's details, or ``unavailable`` (0 used) when the drive cannot tell);
- ``localisation_map.png``, ``localisation_error.png``.
"""

from __future__ import annotations

import copy
import csv
import json
import logging
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from common.clock import SimClock
from common.conventions import LocalTangentFrame, enu_yaw_to_compass_deg
from common.errors import RecordingError
from common.messages import CanFrame, GpsFix, GroundTruth, ImuSample, RawBytes, WheelSpeeds
from mapper.gnss_latency import LatencyEstimate, estimate_gnss_latency
from mapper.gnss_timing import GnssTiming
from mapper.localisation_eval import Track, errors, position_nees, rms
from mapper.mapper import Mapper
from orchestrator.config import AppConfig
from orchestrator.managers import make_sensors
from recordings.player import Player
from recordings.topics import COMMAND, RAW_TOPICS, TRUTH_POSE, TRUTH_TRACK

log = logging.getLogger(__name__)

EVAL_SKIP_S = 5.0
"""The first seconds of the log are not scored (the filter starts from one fix)."""


def is_localisation_recording(path: Path) -> bool:
    """True for a recording with neither commands nor a track (nothing to drive)."""
    topics = set(Player(path).available_topics)
    return COMMAND not in topics and TRUTH_TRACK not in topics


class _Estimates:
    """The per-tick estimate at the reference point, in the world (ENU) frame."""

    def __init__(self, antenna_x_m: float) -> None:
        self.a = antenna_x_m
        self.t: list[float] = []
        self.en: list[tuple[float, float]] = []
        self.course: list[float] = []
        self.cov: list[np.ndarray] = []

    def add(self, mapper: Mapper) -> None:
        p = mapper.state().pose
        a = self.a
        c, s = math.cos(p.yaw_rad), math.sin(p.yaw_rad)
        vy = p.vy_mps + p.yaw_rate_radps * a
        slip = math.atan2(vy, p.vx_mps) if p.vx_mps > 0.5 else 0.0
        if self.t and p.timestamp_s <= self.t[-1]:
            return
        self.t.append(p.timestamp_s)
        self.en.append((p.x_m + a * c, p.y_m + a * s))
        self.course.append(p.yaw_rad + slip)
        j = np.array([[1.0, 0.0, -a * s], [0.0, 1.0, a * c]])
        self.cov.append(j @ p.covariance @ j.T)

    def track(self) -> Track:
        return Track(np.asarray(self.t), np.asarray(self.en).reshape(-1, 2),
                     np.asarray(self.course), np.asarray(self.cov).reshape(-1, 2, 2))


def _messages(path: Path, rate: float | None) -> Iterator[tuple[float, str, object]]:
    yield from Player(path, rate=rate, topics=[*RAW_TOPICS, TRUTH_POSE])


def _decoded_readings(config: AppConfig, path: Path) -> Iterator[object]:
    """Every reading the Sensor Manager decodes from the recording's raw units, in order."""
    clock = SimClock()
    sensors = make_sensors(config, clock, keep_raw=False)
    batch: list[RawBytes | CanFrame] = []
    for log_time_s, _topic, message in Player(path, topics=list(RAW_TOPICS)):
        if isinstance(message, (RawBytes, CanFrame)):
            batch.append(message)
        if len(batch) >= 256:
            clock.set(log_time_s)
            sensors.ingest(batch)
            batch.clear()
            yield from sensors.take().readings
    if batch:
        sensors.ingest(batch)
    yield from sensors.take().readings


def estimate_latency_from_log(config: AppConfig, path: Path) -> LatencyEstimate | None:
    """The GNSS latency from the recording's own fixes (timed as the Mapper times them, with
    no latency), rear wheel speeds and gyro (:func:`mapper.gnss_latency.estimate_gnss_latency`);
    None when the drive cannot tell."""
    ukf = config.mapper.ukf
    timing = GnssTiming(0.0, ukf.gnss_time_from_utc)
    fix_t: list[float] = []
    fix_ll: list[tuple[float, float]] = []
    odo: list[tuple[float, float]] = []
    gyro: list[tuple[float, float]] = []
    for r in _decoded_readings(config, path):
        if isinstance(r, GpsFix):
            fix = timing.retime(r)
            fix_t.append(fix.timestamp_s)
            fix_ll.append((fix.lat_deg, fix.lon_deg))
        elif isinstance(r, WheelSpeeds):
            odo.append((r.timestamp_s, r.mean_rear_mps))
        elif isinstance(r, ImuSample):
            gyro.append((r.timestamp_s, r.gyro_z_radps))
    if len(fix_t) < 2 or len(odo) < 2:
        return None
    ll = np.asarray(fix_ll)
    frame = LocalTangentFrame(float(ll[0, 0]), float(ll[0, 1]), 0.0)
    e, n, _ = frame.to_enu(ll[:, 0], ll[:, 1], 0.0)
    o = np.asarray(odo)
    order = np.argsort(o[:, 0], kind="stable")
    g = np.asarray(gyro).reshape(-1, 2)
    g = g[np.argsort(g[:, 0], kind="stable")]
    return estimate_gnss_latency(np.asarray(fix_t), np.stack([e, n], axis=1), o[order, 0],
                                 o[order, 1], g[:, 0] if len(g) > 1 else None,
                                 g[:, 1] if len(g) > 1 else None)


def _gnss_latency(config: AppConfig, path: Path) -> tuple[AppConfig, dict[str, Any]]:
    """The configuration to localise with and the summary's GNSS latency entries: the
    configured latency when set, else the one estimated from the log (0 when it cannot be)."""
    configured = config.mapper.ukf.gnss_latency_s
    if configured is not None:
        return config, {"gnss_latency_s": configured, "gnss_latency_source": "configured"}
    estimate = estimate_latency_from_log(config, path)
    config = copy.deepcopy(config)
    if estimate is None:
        log.warning("%s: the GNSS latency cannot be estimated from this drive (and none is "
                    "configured in mapper.ukf.gnss_latency_s): 0 s used", path)
        config.mapper.ukf.gnss_latency_s = 0.0
        return config, {"gnss_latency_s": 0.0, "gnss_latency_source": "unavailable"}
    config.mapper.ukf.gnss_latency_s = estimate.latency_s
    log.info("GNSS latency estimated from the log: %.3f +- %.3f s", estimate.latency_s,
             estimate.sigma_s)
    return config, {"gnss_latency_s": round(estimate.latency_s, 4),
                    "gnss_latency_source": "estimated",
                    "gnss_latency_sigma_s": round(estimate.sigma_s, 4),
                    "gnss_latency_estimate": estimate.as_dict()}


def run_localisation(config: AppConfig, path: Path, out_dir: Path | None,
                     rate: float | None = None) -> dict[str, Any]:
    """Localise through ``path`` (see the module docstring); returns the summary."""
    metadata = Player(path).metadata.get("fsd", {})
    config, latency = _gnss_latency(config, path)
    dt_s = 1.0 / config.run.control_rate_hz
    clock = SimClock()
    sensors = make_sensors(config, clock, keep_raw=False)
    mapper = Mapper(config.mapper, config.car, localisation_only=True)
    est = _Estimates(config.mapper.ukf.gnss_antenna_x_m)
    truth: list[GroundTruth] = []
    fixes: list[GpsFix] = []
    raw: list[RawBytes | CanFrame] = []
    tick_s: float | None = None
    ticks = 0
    first_s: float | None = None
    wall0 = time.perf_counter()

    def run_tick(t_s: float) -> None:
        nonlocal ticks
        clock.set(t_s)
        if raw:
            sensors.ingest(raw)
            raw.clear()
        readings = sensors.take().readings
        fixes.extend(r for r in readings if isinstance(r, GpsFix))
        mapper.update(readings, t_s)
        ticks += 1
        if mapper.initialised:
            est.add(mapper)

    for log_time_s, _topic, message in _messages(path, rate):
        if first_s is None:
            first_s = log_time_s
            tick_s = math.ceil(log_time_s / dt_s) * dt_s
        assert tick_s is not None
        while log_time_s > tick_s + 1e-9:
            run_tick(tick_s)
            tick_s += dt_s
        if isinstance(message, GroundTruth):
            truth.append(message)
        elif isinstance(message, (RawBytes, CanFrame)):
            raw.append(message)
    if tick_s is None:
        raise RecordingError(f"{path}: no sensor data to localise with")
    run_tick(tick_s)
    wall_s = time.perf_counter() - wall0
    if not est.t or mapper.world_frame is None:
        raise RecordingError(f"{path}: the localisation never started (no GNSS fix with a "
                             f"course above {config.mapper.ukf.gnss_min_speed_mps} m/s)")
    track = est.track()
    enu = mapper.world_frame.enu
    lat, lon, _ = enu.to_geodetic(track.en_m[:, 0], track.en_m[:, 1], 0.0)
    assert first_s is not None
    start_s = float(metadata.get("start_s", repr(first_s)))
    summary: dict[str, Any] = {
        "recording": str(path),
        "mode": "localisation",
        "log": metadata.get("log", ""),
        "start_s": start_s,
        "estimate_rows": len(track.t_s),
        "localisation_start_s": float(track.t_s[0]),
        "ticks": ticks,
        "timing": {"wall_time_s": round(wall_s, 3),
                   "realtime_factor": round(ticks * dt_s / max(wall_s, 1e-9), 2)},
        **latency,
        "mapper_stats": mapper.stats,
    }
    truth_origin = _truth_origin(metadata)
    plot_data: dict[str, Any] = {}
    if truth and truth_origin is not None:
        summary.update(_score(track, enu, truth, truth_origin, fixes, start_s, metadata,
                              plot_data))
    if out_dir is not None:
        out_dir.mkdir(parents=True, exist_ok=True)
        write_estimate_csv(out_dir / "estimate.csv", track.t_s, lat, lon, track.course_rad)
        (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        if plot_data:
            from visualiser.localisation_plots import write_localisation_plots

            write_localisation_plots(out_dir, **plot_data)
    return summary


def write_estimate_csv(path: Path, t_s: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray,
                       course_enu_rad: np.ndarray) -> None:
    """``t_s,lat_deg,lon_deg,heading_deg`` (heading: clockwise from north, [0, 360))."""
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t_s", "lat_deg", "lon_deg", "heading_deg"])
        for t, la, lo, c in zip(t_s, lat_deg, lon_deg, course_enu_rad, strict=True):
            w.writerow([f"{t:.6f}", f"{la:.9f}", f"{lo:.9f}",
                        f"{enu_yaw_to_compass_deg(float(c)):.4f}"])


def _truth_origin(metadata: dict[str, str]) -> LocalTangentFrame | None:
    try:
        return LocalTangentFrame(float(metadata["truth_lat0_deg"]),
                                 float(metadata["truth_lon0_deg"]),
                                 float(metadata.get("truth_alt0_m", "0")))
    except (KeyError, ValueError):
        log.warning("the recording's truth has no ENU origin in its metadata: not scored")
        return None


def _score(track: Track, enu: LocalTangentFrame, truth: list[GroundTruth],
           origin: LocalTangentFrame, fixes: list[GpsFix], start_s: float,
           metadata: dict[str, str], plot_data: dict[str, Any]) -> dict[str, Any]:
    """The summary's scores (see the module docstring); fills ``plot_data``."""
    lat, lon, _ = enu.to_geodetic(track.en_m[:, 0], track.en_m[:, 1], 0.0)
    e, n, _ = origin.to_enu(lat, lon, origin.alt0_m)
    est = Track(track.t_s, np.stack([e, n], axis=1), track.course_rad, track.cov_m2)
    ref = Track(np.array([g.timestamp_s for g in truth]),
                np.array([[g.x_m, g.y_m] for g in truth]), np.array([g.yaw_rad for g in truth]))
    t, d, dc = errors(est, ref)
    scored = t >= start_s + EVAL_SKIP_S
    nees = position_nees(est, ref)
    out: dict[str, Any] = {
        "evaluated_from_s": start_s + EVAL_SKIP_S,
        "evaluated_samples": int(np.count_nonzero(scored)),
        "position_rmse_m": round(rms(d[scored]), 4),
        "position_max_error_m": round(float(np.max(np.hypot(*d[scored].T))), 4),
        "heading_rmse_deg": round(rms(dc[scored]), 4),
        "nees_position_mean": round(float(np.mean(nees[scored])), 3),
        "nees_position_dof": 2,
    }
    fix_t = np.array([f.timestamp_s for f in fixes])
    fix_en = np.zeros((0, 2))
    fix_err_t, fix_err = np.zeros(0), np.zeros(0)
    s_ref = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(ref.en_m, axis=0).T))])
    fix_along, fix_cross = np.zeros(0), np.zeros(0)
    if len(fixes):
        fe, fn, _ = origin.to_enu(np.array([f.lat_deg for f in fixes]),
                                  np.array([f.lon_deg for f in fixes]), origin.alt0_m)
        fix_en = np.stack([fe, fn], axis=1)
        course = np.array([f.course_rad for f in fixes])
        raw = Track(fix_t, fix_en, np.where(np.isfinite(course), course, 0.0))
        ok = (fix_t >= start_s + EVAL_SKIP_S) & (fix_t >= ref.t_s[0]) & (fix_t <= ref.t_s[-1])
        at = ref.at(fix_t[ok])
        dc_raw = np.degrees(raw.course_rad[ok] - at.course_rad)
        dc_raw = np.mod(dc_raw + 180.0, 360.0) - 180.0
        _, de, _ = errors(est, Track(fix_t[ok], at.en_m, at.course_rad))
        fix_err_t, fix_err = fix_t[ok], np.hypot(*(fix_en[ok] - at.en_m).T)
        fix_along = np.interp(fix_err_t, ref.t_s, s_ref)
        fix_cross = _left_of(fix_en[ok] - at.en_m, at.course_rad)
        out.update({
            "gnss_fixes_scored": int(np.count_nonzero(ok)),
            "gnss_raw_rmse_m": round(rms(fix_en[ok] - at.en_m), 4),
            "gnss_raw_course_rmse_deg": round(rms(dc_raw[np.isfinite(course[ok])]), 4),
            "position_rmse_at_fix_times_m": round(rms(de), 4),
        })
    window = metadata.get("gnss_outage_s")
    outage = None
    if window:
        a, b = (float(v) for v in window.split(":"))
        inside = (t >= a) & (t < b)
        outage = (a, b)
        if np.any(inside):
            err = np.hypot(*d[inside].T)
            out["gnss_outage"] = {"start_s": a, "end_s": b,
                                  "max_error_m": round(float(np.max(err)), 4),
                                  "rmse_m": round(rms(d[inside]), 4),
                                  "travel_m": round(float(np.sum(np.hypot(
                                      *np.diff(ref.en_m[(ref.t_s >= a) & (ref.t_s < b)],
                                               axis=0).T))), 1)}
    plot_data.update(est_en_m=est.en_m, truth_en_m=ref.en_m, fixes_en_m=fix_en,
                     t_s=t - start_s, error_m=np.hypot(*d.T), course_error_deg=dc,
                     outage_s=None if outage is None else (outage[0] - start_s,
                                                           outage[1] - start_s),
                     fix_t_s=fix_err_t - start_s, fix_error_m=fix_err,
                     along_m=np.interp(t, ref.t_s, s_ref),
                     cross_m=_left_of(d, ref.at(t).course_rad),
                     fix_along_m=fix_along, fix_cross_m=fix_cross)
    return out


def _left_of(d_en_m: np.ndarray, course_rad: np.ndarray) -> np.ndarray:
    """The component (N,) of offsets (N, 2) to the left of the direction of travel (m)."""
    return np.asarray(-d_en_m[:, 0] * np.sin(course_rad) + d_en_m[:, 1] * np.cos(course_rad))
