"""SimWorld: the simulated car on a track, with every sensor model, faults and scoring.

``step_to(t_s, command)`` integrates the vehicle at ``config.sim.physics_rate_hz`` up to
``t_s``; after every physics step each sensor model is polled with the true state, so each
emits whatever falls due at its own rate. The raw units (``RawBytes`` / ``CanFrame``) come back
in time order. Ground truth is kept aside (``truth()``), never fed to the stack. The world
counts knocked cones (``cones_hit``: cone indices whose base the car's outline touched),
off-track events (all four corners beyond a boundary) and start-line crossings (lap times).

Deterministic: each sensor model gets its own generator spawned from ``seed`` in a fixed order,
so the same seed and the same commands give the same bytes.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    AsStatus,
    CanFrame,
    GroundTruth,
    Mission,
    RawBytes,
)
from sensors.can_codec import CanCodec
from simulator.camera_model import CameraModel
from simulator.can_model import CanModel
from simulator.config import WorldConfig
from simulator.faults import Fault, parse_faults
from simulator.gps_model import GpsModel
from simulator.imu_model import ImuModel
from simulator.lidar_model import EMULATOR_LOOKAHEAD_S, LidarModel
from simulator.track import Track
from simulator.vehicle import Vehicle

log = logging.getLogger(__name__)

SENSOR_MODELS: tuple[tuple[str, type], ...] = (
    ("gps", GpsModel),
    ("imu", ImuModel),
    ("can", CanModel),
    ("lidar", LidarModel),
    ("camera", CameraModel),
)
"""(name, class) of every sensor model, in the order their generators are spawned."""

RawUnit = RawBytes | CanFrame

_FAULT_SOURCE = {"gps-dropout": "gps", "lidar-dead": "lidar", "camera-dead": "camera"}


def mission_select_value(setting: str, mission: Mission) -> int | None:
    """The ``MISSION_SELECT`` wire value of ``config.sim.mission_select`` (see
    :class:`simulator.config.SimConfig`): ``run`` is ``mission``; None for ``missing``."""
    text = setting.strip().lower()
    if text == "run":
        return int(mission)
    if text == "missing":
        return None
    if text.isdigit() and 0 <= int(text) <= 15:
        return int(text)
    try:
        return int(Mission[text.upper()])
    except KeyError:
        raise ValueError(f"sim.mission_select {setting!r}: expected run, missing, a mission "
                         f"({', '.join(m.name.lower() for m in Mission)}) or 0..15") from None


OFF_TRACK_MARGIN_M = 0.5
"""The footprint's middle nearer the boundary than this (m, inside) is never off track."""


def _timestamp(unit: RawUnit) -> float:
    return unit.timestamp_s


class SimWorld:
    """The simulated world (see the module docstring).

    ``sensors``: names of the sensor models to run (default all of :data:`SENSOR_MODELS` that
    are enabled in ``config.sim``); ``faults``: fault specs (default ``config.sim.faults``);
    ``res_go``: whether the remote stop (RES) reports "go" from the start (on the car the
    person presses go at the handover: :meth:`send_go`); ``mission``: the run's mission, which
    the car selects in ``MISSION_SELECT`` unless ``config.sim.mission_select`` says otherwise
    (None: trackdrive). ``lidar_sweep_units``: the LiDAR's packets come as one raw unit per
    sweep (:class:`~simulator.lidar_model.LidarModel`; the same bytes, parsed in one piece);
    False: one unit per packet, when they have to be sent one datagram each (the emulator),
    cast in batches reaching :data:`~simulator.lidar_model.EMULATOR_LOOKAHEAD_S` ahead.

    The car's side of ``AS_STATUS``: :meth:`receive_can` decodes the frames the stack sends;
    ``as_status`` is the last one, ``as_transitions`` every change of its AS state as
    ``(time_s, state)``.
    """

    def __init__(self, config: WorldConfig, track: Track, seed: int | None = None,
                 faults: str | Iterable[str | Fault] | None = None,
                 sensors: Sequence[str] | None = None, res_go: bool = False,
                 mission: Mission | None = None, lidar_sweep_units: bool = True) -> None:
        self.config = config
        self.track = track
        self.seed = config.sim.seed if seed is None else int(seed)
        self.dt_s = 1.0 / config.sim.physics_rate_hz
        self.vehicle = Vehicle(config.car)
        self.faults = parse_faults(config.sim.faults if faults is None else faults)
        children = np.random.SeedSequence(self.seed).spawn(len(SENSOR_MODELS) + 1)
        self.rng = np.random.default_rng(children[-1])
        wanted = {name for name, _ in SENSOR_MODELS} if sensors is None else set(sensors)
        self.models: dict[str, Any] = {}
        for (name, cls), child in zip(SENSOR_MODELS, children, strict=False):
            if name in wanted and getattr(config.sim, name).enabled:
                self.models[name] = cls(config, np.random.default_rng(child))
        if "lidar" in self.models:
            self.models["lidar"].sweep_units = lidar_sweep_units
            if not lidar_sweep_units:
                self.models["lidar"].lookahead_s = EMULATOR_LOOKAHEAD_S
        self._step_index = 0
        self._command: ActuatorCommand | None = None
        self.cones_hit: set[int] = set()
        """Indices (into ``track.cones_xy_m``) of every cone the car has touched."""
        self.cone_hits: list[tuple[float, int]] = []
        """(time_s, cone index) of each first touch."""
        self.off_track_events = 0
        """How many times the car went fully off the track."""
        self.off_track = False
        self.start_line_crossings_s: list[float] = []
        """Times (s) the car crossed the start/finish line forwards."""
        self.finish_crossings_s: list[float] = []
        self._hint: int | None = None
        self._line = self._line_geometry(track.start_line_xy_m)
        self._finish = (self._line_geometry(track.finish_line_xy_m)
                        if track.kind == "acceleration" else None)
        self._start_behind_line = self._line is not None and self._line_side(self._line, 0, 0) < 0
        self._res_state: tuple[bool, bool] | None = None
        self._go = bool(res_go)
        self._update_res(0.0)
        self.mission_value = mission_select_value(config.sim.mission_select,
                                                  Mission.TRACKDRIVE if mission is None
                                                  else mission)
        """The wire value the car sends in ``MISSION_SELECT`` (None: no frame)."""
        can = self.models.get("can")
        if can is not None and hasattr(can, "set_mission"):
            can.set_mission(self.mission_value)
        self._status_codec = CanCodec(config.sensors.can.dbc or None)
        self.as_status: AsStatus | None = None
        self.as_status_frames = 0
        self.as_transitions: list[tuple[float, AsState]] = []
        self.as_state_since_s = math.nan
        """When the AS state last changed (s), as the car saw it in ``AS_STATUS``."""

    # -- public ---------------------------------------------------------------------------

    @property
    def t_s(self) -> float:
        """The simulated time reached (s)."""
        return self._step_index * self.dt_s

    @property
    def estop_active(self) -> bool:
        """True while the RES emergency stop is pressed (an ``estop`` fault is active)."""
        return self._active("estop", self.t_s)

    def send_go(self) -> None:
        """Press "go" on the remote (RES): its CAN frames report go from now on (unless the
        emergency stop is pressed)."""
        self._go = True
        self._update_res(self.t_s)

    def receive_can(self, frames: Iterable[CanFrame]) -> list[AsStatus]:
        """Frames the stack sent on the bus: each ``AS_STATUS`` is decoded (as the car's VCU
        does; the ASSI lamps show its mode) and kept; returns the statuses decoded."""
        out = []
        for frame in frames:
            status = self._status_codec.decode_as_status(frame)
            if status is None:
                continue
            self.as_status_frames += 1
            previous = self.as_status
            if previous is None or previous.state != status.state:
                self.as_transitions.append((status.timestamp_s, status.state))
                self.as_state_since_s = status.timestamp_s
            self.as_status = status
            out.append(status)
        return out

    def as_state_for_s(self, now_s: float, state: AsState) -> float:
        """How long (s) the car has seen ``state`` in ``AS_STATUS`` at ``now_s`` (0 when it
        does not show it)."""
        if self.as_status is None or self.as_status.state != state:
            return 0.0
        return now_s - self.as_state_since_s

    def truth(self) -> GroundTruth:
        """The car's true state now."""
        return self.vehicle.truth(self.t_s)

    @property
    def laps_completed(self) -> int:
        """Completed laps: start-line crossings, minus the first when the car starts behind it."""
        n = len(self.start_line_crossings_s)
        return max(n - 1, 0) if self._start_behind_line else n

    @property
    def lap_times_s(self) -> list[float]:
        """Durations (s) of the completed laps (between consecutive start-line crossings)."""
        c = self.start_line_crossings_s
        if not self._start_behind_line:
            c = [0.0, *c]
        return [b - a for a, b in zip(c, c[1:], strict=False)]

    def step_to(self, t_s: float, command: ActuatorCommand | None = None) -> list[RawUnit]:
        """Advance to ``t_s`` (s) under ``command`` (None: keep the last one; before any, the
        car rolls with no throttle and no brake). Returns every raw unit produced, in time
        order (stable for equal times)."""
        if command is not None:
            self._command = command
        cmd = self._command
        dt = self.dt_s
        n_target = int(math.floor(t_s / dt + 1e-9))
        out: list[RawUnit] = []
        vehicle = self.vehicle
        st = vehicle.state
        models = list(self.models.values())
        faults = self.faults
        while self._step_index < n_target:
            self._step_index += 1
            t = self._step_index * dt
            if faults:
                self._apply_faults(t)
            x0, y0 = st.x_m, st.y_m
            vehicle.step(cmd, dt)
            self._score(t, x0, y0)
            truth = vehicle.truth(t)
            for model in models:
                out.extend(model.poll(t, truth, vehicle, self.track))
        if faults:
            out = self._filter(out)
        out.sort(key=_timestamp)
        return out

    def summary(self) -> dict[str, Any]:
        """Scores of the run so far (for the run summary)."""
        return {
            "t_s": self.t_s,
            "distance_m": self.vehicle.state.distance_m,
            "cones_hit": len(self.cones_hit),
            "off_track_events": self.off_track_events,
            "laps_completed": self.laps_completed,
            "lap_times_s": self.lap_times_s,
            "faults": [str(f) for f in self.faults],
        }

    # -- scoring ----------------------------------------------------------------------------

    def _score(self, t: float, x0: float, y0: float) -> None:
        vehicle = self.vehicle
        st = vehicle.state
        track = self.track
        corners = vehicle.footprint_corners()
        for i in track.cones_touched(corners):
            if i not in self.cones_hit:
                self.cones_hit.add(i)
                self.cone_hits.append((t, i))
                log.info("t=%.2f s: cone %d knocked", t, i)
        # off track: only worth the full test when the car is near a boundary: every corner
        # beyond it puts their middle beyond it too (up to the bend of the boundary along
        # the car, well inside OFF_TRACK_MARGIN_M)
        mx = 0.25 * (corners[0][0] + corners[1][0] + corners[2][0] + corners[3][0])
        my = 0.25 * (corners[0][1] + corners[1][1] + corners[2][1] + corners[3][1])
        _, lateral, seg = track.locate(mx, my, self._hint)
        self._hint = seg
        half = (track.left_half_width_m[seg] if lateral >= 0.0
                else track.right_half_width_m[seg])
        off = False
        if abs(lateral) > half - OFF_TRACK_MARGIN_M:
            off = track.is_off_track(corners, seg)
        if off and not self.off_track:
            self.off_track_events += 1
            log.info("t=%.2f s: car off track", t)
        self.off_track = off
        if self._line is not None and self._crossed(self._line, x0, y0, st.x_m, st.y_m):
            self.start_line_crossings_s.append(t)
        if self._finish is not None and self._crossed(self._finish, x0, y0, st.x_m, st.y_m):
            self.finish_crossings_s.append(t)

    def _line_geometry(self, line: np.ndarray) -> tuple[float, ...] | None:
        if not np.all(np.isfinite(line)):
            return None
        (ax, ay), (bx, by) = line.tolist()
        length = math.hypot(bx - ax, by - ay)
        if length <= 0.0:
            return None
        ux, uy = (bx - ax) / length, (by - ay) / length
        mx, my = 0.5 * (ax + bx), 0.5 * (ay + by)
        s, _, seg = self.track.locate(mx, my)
        _, _, heading = self.track.point_at(s)
        nx, ny = -uy, ux
        if nx * math.cos(heading) + ny * math.sin(heading) < 0.0:
            nx, ny = -nx, -ny
        return mx, my, ux, uy, nx, ny, 0.5 * length + 1.0

    @staticmethod
    def _line_side(line: tuple[float, ...], x: float, y: float) -> float:
        mx, my, _, _, nx, ny, _ = line
        return (x - mx) * nx + (y - my) * ny

    @staticmethod
    def _crossed(line: tuple[float, ...], x0: float, y0: float, x1: float, y1: float) -> bool:
        mx, my, ux, uy, nx, ny, half = line
        d0 = (x0 - mx) * nx + (y0 - my) * ny
        d1 = (x1 - mx) * nx + (y1 - my) * ny
        if not (d0 < 0.0 <= d1):
            return False
        f = d0 / (d0 - d1)
        cx, cy = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
        return abs((cx - mx) * ux + (cy - my) * uy) <= half

    # -- faults -----------------------------------------------------------------------------

    def _active(self, kind: str, t: float) -> bool:
        return any(f.kind == kind and f.active(t) for f in self.faults)

    def _update_res(self, t: float) -> None:
        """Tell the CAN model the RES state: emergency while an estop fault is active (which
        also cancels "go": after an emergency the car needs a new go)."""
        if self._active("estop", t):
            state = (True, False)
            self._go = False
        else:
            state = (False, self._go)
        if state == self._res_state:
            return
        can = self.models.get("can")
        if can is not None and hasattr(can, "set_res"):
            can.set_res(emergency=state[0], go=state[1])
        if state[0]:
            log.info("t=%.2f s: RES emergency stop pressed", t)
        self._res_state = state

    def _apply_faults(self, t: float) -> None:
        models = self.models
        can = models.get("can")
        self._update_res(t)
        gps = models.get("gps")
        if gps is not None:
            gps.dropout = self._active("gps-dropout", t)
        lidar = models.get("lidar")
        if lidar is not None:
            lidar.dead = self._active("lidar-dead", t)
        camera = models.get("camera")
        if camera is not None:
            camera.dead = self._active("camera-dead", t)
        imu = models.get("imu")
        if imu is not None:
            imu.inject_nan = self._active("imu-nan", t)
        if can is not None:
            can.garbage = self._active("can-garbage", t)

    def _filter(self, out: list[RawUnit]) -> list[RawUnit]:
        """Drop what dead or silent sensors would not send."""
        drop: set[str] = set()
        for f in self.faults:
            source = _FAULT_SOURCE.get(f.kind)
            if source is not None:
                drop.add(source)
        if not drop:
            return out
        faults = [f for f in self.faults if f.kind in _FAULT_SOURCE]
        kept: list[RawUnit] = []
        for unit in out:
            if isinstance(unit, RawBytes) and unit.source in drop and any(
                    _FAULT_SOURCE[f.kind] == unit.source and f.active(unit.timestamp_s)
                    for f in faults):
                continue
            kept.append(unit)
        return kept
