"""The racing line of a closed track, built where the planner's loop does not wait for it.

Building the racing line (the track model from the cone map, then the minimum-curvature line
inside it) takes about a second of CPU. In simulation the planner builds it in line, so a run
stays the same from one time to the next; on the car (``drive``) a plan a second late is a car a
second blind, so :class:`BackgroundRace` builds it in a process of its own while the planner goes
on driving the track's centre line, and the planner swaps the line in at the first plan after it
is done.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from planner.config import PlannerConfig
from planner.racing_line import racing_line
from planner.speed_profile import SpeedLimits, steering_lock_cap
from planner.track_model import TrackModel, track_from_cones

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class RaceLine:
    """A built racing line: its points (N, 2) (m, world frame, one lap, not closed) and the
    track model it lies in."""

    line_xy_m: FloatArray
    model: TrackModel


def build_race_line(cones_xy_m: FloatArray, colours: NDArray[np.int64], guide_xy_m: FloatArray,
                    config: PlannerConfig, car: CarConfig, limits: SpeedLimits) -> RaceLine:
    """The track the cones (N, 2) with their colours (N,) mark along the closed ``guide_xy_m``
    (M, 2), and the racing line inside it (its centre line when ``config.racing_line`` is
    off). Raises :class:`common.errors.TrackError` or ValueError when the cones make no track.
    """
    c = config
    model = track_from_cones(cones_xy_m, colours, guide_xy_m, True, step_m=c.track_step_m,
                             max_lateral_m=c.track_max_lateral_m,
                             nominal_width_m=c.nominal_track_width_m)
    if c.racing_line:
        line, _ = racing_line(model, half_width_m=car.width_m / 2.0,
                              front_m=car.length_m - car.rear_overhang_m,
                              clearance_m=c.cone_radius_m + c.racing_margin_m, limits=limits,
                              speed_cap=steering_lock_cap(car, c.steer_lock_fraction,
                                                          c.understeer_rad_per_mps2,
                                                          c.crawl_speed_mps))
    else:
        line = model.centre_xy_m
    return RaceLine(np.asarray(line, np.float64), model)


WORKER_NICENESS = 10
"""How much lower than the caller's the worker's CPU priority is (``os.nice``): on a busy
machine its second of work must not starve the caller's sensor and control threads."""


def _lower_priority() -> None:
    """Lower the worker's CPU priority (its first act, before it waits for a job)."""
    try:
        os.nice(WORKER_NICENESS)
    except OSError as exc:  # not allowed here: run at the caller's priority
        logger.debug("racing line worker: nice failed: %s", exc)


def _serve(conn: Any) -> None:
    """The worker process: build each job's line (:func:`build_race_line`) and send it back
    (or the error that ended it), until the pipe closes."""
    _lower_priority()
    while True:
        try:
            args = conn.recv()
        except (EOFError, OSError):
            return
        try:
            result: Any = build_race_line(*args)
        except Exception as exc:  # sent back: the planner logs it and drives on
            result = exc
        try:
            conn.send(result)
        except (BrokenPipeError, OSError):
            return


class BackgroundRace:
    """One worker process that builds racing lines (:func:`build_race_line`) while the caller
    goes on; the result of the latest job is the one kept (an earlier one still being built is
    dropped when it arrives).

    The process (``spawn``: the caller may run threads, which ``fork`` does not copy safely)
    starts at construction, at a lower CPU priority, so that its start-up (a Python with numpy
    and scipy: a second or more of CPU on a busy machine) falls in the car's wait before the go,
    not in its first metres; a loaded drive went to EMERGENCY with a stale IMU when it started
    with the first job. A plain process on a pipe, not a ``multiprocessing.Pool``: the pool's
    terminate could hang while its worker was still starting, and the executive process then
    outlived its 30 s to stop. :meth:`close` kills it at once (a shutdown never waits)."""

    def __init__(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        self._conn, child = ctx.Pipe()
        self._process: Any = ctx.Process(target=_serve, args=(child,), name="racing-line",
                                         daemon=True)
        self._process.start()
        child.close()
        self._sent = 0
        self._received = 0

    def submit(self, cones_xy_m: FloatArray, colours: NDArray[np.int64], guide_xy_m: FloatArray,
               config: PlannerConfig, car: CarConfig, limits: SpeedLimits) -> None:
        """Start building a racing line (the arrays are copied to the worker)."""
        if self._process is None:
            raise RuntimeError("the racing line worker is closed")
        self._conn.send((np.array(cones_xy_m), np.array(colours), np.array(guide_xy_m),
                         config, car, limits))
        self._sent += 1

    @property
    def pending(self) -> bool:
        """A line is being built."""
        return self._received < self._sent

    def poll(self) -> RaceLine | BaseException | None:
        """The latest job's line, or the error that ended its building; None while it is
        being built (or none was asked for)."""
        result: RaceLine | BaseException | None = None
        try:
            while self._received < self._sent and self._conn.poll():
                got = self._conn.recv()
                self._received += 1
                if self._received == self._sent:
                    result = got
        except (EOFError, OSError) as exc:
            self._received = self._sent
            return RuntimeError(f"the racing line worker ended: {exc!r}")
        return result

    def close(self) -> None:
        """Stop the worker at once (a line being built is dropped)."""
        if self._process is not None:
            self._conn.close()
            self._process.kill()
            self._process.join(2.0)
            self._process = None
        self._received = self._sent
