"""The deliberative layer of ``drive`` (the Path Planner) in a process of its own.

The executive process (:mod:`orchestrator.live_worker`) starts it. In one process the planner
shared one interpreter lock with the mapper and the sensors' receiver threads: on a busy 2-core
computer its tens of milliseconds a plan kept the LiDAR's receiver from its socket, the sweeps
reached the map up to 0.8 s late and were dropped, and the exploration drove to the end of the
cones it had seen and stopped (issue 19, ``bench load``). Here it has its own.

:class:`PlannerServer` runs the :class:`~orchestrator.layers.DeliberativeLayer` at its rate
behind a :class:`~orchestrator.live_link.Link`. When a plan is due it asks the executive for
the newest map (:class:`~orchestrator.layer_messages.MapRequest`), which answers with
:class:`~orchestrator.layer_messages.PlannerInput` (the map state, the poses the planner has not
yet observed, the RES go and whether the car drives), and sends back
:class:`~orchestrator.layer_messages.PlanUpdate`. It ends on
:class:`~orchestrator.layer_messages.Stop` or when the link closes, and sends
:class:`~orchestrator.layer_messages.Final` with its stage times and lags; an error in the
layer is sent as :class:`~orchestrator.layer_messages.LayerError` (the run stops).
"""

from __future__ import annotations

import logging
import socket
import time

from common.clock import RealClock
from orchestrator.config import AppConfig
from orchestrator.layer_messages import (
    Final,
    LayerError,
    Loaded,
    MapRequest,
    PlannerInput,
    PlanUpdate,
    Start,
    Stop,
)
from orchestrator.layers import DeliberativeLayer
from orchestrator.live_link import Link
from orchestrator.main_loop import StageTimes
from orchestrator.priority import enter_child_process, lock_memory, nicer_by

log = logging.getLogger(__name__)

PLANNER_NICENESS_STEP = 5
"""The planner process runs this much nicer than the executive process: mapping comes before
planning (the issue's priorities: control > mapping > planning > recording)."""
INPUT_TIMEOUT_S = 1.0
"""How long the planner waits for the map it asked for before it asks again."""


class PlannerServer:
    """The deliberative layer behind ``link`` (see the module docstring). ``clock`` is replaced
    by the run's clock at :class:`Start`."""

    def __init__(self, config: AppConfig, link: Link, clock: RealClock) -> None:
        from orchestrator.managers import make_planner

        # on the car the racing line is built beside the planner's loop, not in it
        config.planner.racing_line_background = True
        self.layer = DeliberativeLayer(make_planner(config), config.run.plan_rate_hz)
        self.link = link
        self.clock = clock
        self.times = StageTimes()
        self.stopped = False

    def _wait_start(self) -> bool:
        while not self.link.closed:
            for message in self.link.recv(0.05):
                if isinstance(message, Start):
                    self.clock = message.clock
                    return True
                if isinstance(message, Stop):
                    return False
        return False

    def _input(self) -> PlannerInput | None:
        """Ask for the newest map and wait for it; None at a stop or after the timeout."""
        self.link.send(MapRequest())
        end = time.monotonic() + INPUT_TIMEOUT_S
        while not self.link.closed and time.monotonic() < end:
            for message in self.link.recv(0.05):
                if isinstance(message, Stop):
                    self.stopped = True
                    return None
                if isinstance(message, PlannerInput):
                    return message
        return None

    def _plan_once(self) -> None:
        layer = self.layer
        rate = layer.rate
        due_s = rate.next_s if rate.next_s is not None else self.clock.now_s() + rate.period_s
        # wait for the plan's time, listening for a stop meanwhile
        while not self.stopped and not self.link.closed:
            left = due_s - self.clock.now_s()
            if left <= 0.0:
                break
            if any(isinstance(m, Stop) for m in self.link.recv(min(left, 0.05))):
                self.stopped = True
        if self.stopped or self.link.closed:
            return
        given = self._input()
        if given is None:
            return
        for pose in given.poses:
            layer.observe_pose(pose)
        if given.map_state is None:  # before the first map: look again a period later
            return
        now_s = self.clock.now_s()
        started = layer.autonomous_started
        t0 = time.perf_counter()
        plan = layer.step(now_s, given.map_state, given.go, given.driving)
        if not started and layer.start_s is not None:
            self.times.add("start_autonomous", layer.start_s)
        if plan is None:
            return
        self.times.add("planner", time.perf_counter() - t0)
        self.link.send(PlanUpdate(plan))

    def run(self) -> None:
        """Serve until :class:`Stop` or the link closes, then send :class:`Final`."""
        try:
            self.link.send(Loaded())
            if self._wait_start():
                while not self.stopped and not self.link.closed:
                    self._plan_once()
        except Exception as exc:  # the run stops: the executive sends it on
            log.exception("planner layer failed")
            self.link.send(LayerError(f"planner: {exc!r}"))
        finally:
            try:
                self.layer.planner.close()
            except Exception:
                log.exception("closing the planner failed")
            self.link.send(Final({"stages_ms": self.times.summary_ms(),
                                  "lags_ms": {"planner": self.layer.rate.summary_ms()}}))


def planner_main(config: AppConfig, sock: socket.socket, log_level: int, niceness: int,
                 lock: bool) -> None:
    """Entry point of the planner process (``multiprocessing`` spawn target): at ``niceness``,
    memory locked when ``lock``."""
    enter_child_process("planner process", log_level, niceness)
    link = Link(sock)
    try:
        server = PlannerServer(config, link, RealClock())
    except Exception as exc:
        log.exception("the planner process could not start")
        link.send(LayerError(f"planner start: {exc!r}"))
        link.close()
        return
    if lock:
        lock_memory("planner process")
    try:
        server.run()
    finally:
        link.close()


def planner_niceness(executive_niceness: int) -> int:
    """The planner process's niceness beside the executive's (within -20..19)."""
    return nicer_by(executive_niceness, PLANNER_NICENESS_STEP)

