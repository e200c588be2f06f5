"""The hardware emulator: the simulated car served over the car's real transports.

``python main.py emulate --track T --write-config car.toml`` runs the simulator in real time and
serves its bytes as the hardware does: NMEA on one pseudo-terminal, IMU packets on another, CAN
through an slcan adapter on a third (or ``--can udp``: python-can's ``udp_multicast`` bus, kernel
sockets as the car's SocketCAN), VLP-16 packets and camera datagrams over UDP on loopback.
It takes the actuator frames the stack sends on CAN and drives the simulated car with them.
``python main.py drive --config car.toml`` in another process then drives it as it would drive
the car. The car selects its mission in ``MISSION_SELECT`` (``--mission``, 10 Hz) and decodes
the stack's ``AS_STATUS`` (logging each change of the AS state, as the ASSI shows it). As on the
car, a person (the scripted driver) drives the exploration lap (``--exploration manual``), and
once the ASSI has shown READY for the rules' 5 s the RES sends "go" over CAN; like the car, it
brakes to a stop when actuator frames stop coming for 200 ms.
"""

from __future__ import annotations

import gc
import json
import logging
import math
import resource
import signal
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from common.clock import RealClock
from common.messages import ActuatorCommand, CanFrame, Mission, RawBytes
from sensors.can_codec import AS_STATUS_ID, CanCodec
from simulator.config import WorldConfig
from simulator.driver import ScriptedDriver
from simulator.handover import Handover, Phase
from simulator.tracks import load_track
from simulator.transports import PtyPort, SlcanAdapter, UdpCanBus, UdpSender, free_udp_port
from simulator.world import SimWorld

log = logging.getLogger(__name__)

ACTUATOR_TIMEOUT_S = 0.2
"""No actuator frame for this long: the car brakes to a stop (its own watchdog)."""
IDLE_END_S = 2.0
"""After the handover, standing still with no actuator frames for this long ends the run."""
LATE_STEP_S = 0.1
"""A step later than this (s) counts in the summary's ``steps_late``: the IMU's timeout in
drive (``sensors.imu.timeout_s``), the shortest of the critical sensors'."""


STACK_DRIVES_MPS = 2.0
"""Above this speed after the handover the stack drives the car (logged once: a sign for the
person at the track side, and for tests, that the car is moving under the stack)."""


def catch_up_times_s(from_s: float, to_s: float, step_s: float) -> list[float]:
    """The times (s) to step a world at ``from_s`` to ``to_s`` by at most ``step_s`` each:
    ``[to_s]`` when on time, the missed steps' times and then ``to_s`` when late."""
    missed = max(int(math.floor((to_s - from_s) / step_s)) - 1, 0)
    return [from_s + (k + 1) * step_s for k in range(missed)] + [to_s]


@dataclass
class EmulatorOptions:
    """``emulate`` options."""

    track: str
    exploration_overrun_m: float
    """The person drives this far past the start line before stopping (Main's run setting)."""
    handover_standstill_s: float
    """Then the car stands this long before the RES "go" (Main's run setting)."""
    seconds: float | None = None
    write_config: Path | None = None
    summary: Path | None = None
    workdir: Path | None = None
    seed: int | None = None
    step_s: float = 0.005
    wait_for_stack_s: float = 60.0
    """The car stands, its clock stopped, until the stack opens the CAN adapter (slcan ``O``),
    at most this long (0: start at once): the person drives only once the stack is running."""
    mission: str = "trackdrive"
    """The mission the emulated car selects (written into the config for ``drive``)."""
    exploration: str = "autonomous"
    """``autonomous``: nobody drives the first lap; ``manual``: the scripted person does."""
    lead_in_s: float = 1.0
    """Then it stands this long with its sensors streaming before the exploration lap starts."""
    ready_wait_s: float | None = 5.0
    """The person presses go once the ASSI has shown READY this long (s; the rules' 5 s; None:
    without looking at ``AS_STATUS``)."""
    move_delay_s: float = 3.0
    """The car may move this long after the go (the rules' 3 s): the first lap is timed from
    then."""
    can: str = "slcan"
    """The CAN bus: ``slcan``, an slcan USB adapter on a pseudo-terminal; ``udp``, python-can's
    ``udp_multicast`` bus, kernel sockets as the car's SocketCAN (:class:`UdpCanBus`)."""
    serial_stalls: tuple[tuple[float, float], ...] = ()
    """(start_s, duration_s) windows of the emulator's clock in which the GPS and IMU bytes are
    held back, then written in one burst: a stalled serial link (issue 19 saw 0.46 s at
    15.6 m/s under load). drive's readers see the silence, so a stall longer than a sensor's
    timeout ends in a stop; a starved reader thread (the load's own case) they cannot mimic."""


class HardwareEmulator:
    """Runs a SimWorld in real time behind real transports."""

    def __init__(self, config: WorldConfig, options: EmulatorOptions) -> None:
        self.config = config
        self.options = options
        if options.seed is not None:
            config.sim.seed = options.seed
        self.track = load_track(options.track)
        self.track.check_drivable(config.car.width_m)
        self.world = SimWorld(config, self.track, config.sim.seed,
                              mission=Mission[options.mission.upper()],
                              lidar_sweep_units=False)  # one datagram per packet, as sent
        self.driver = ScriptedDriver(self.track, config.car, config.sim.seed,
                                     speed_mps=config.sim.driver_speed_mps,
                                     steer_noise_rad=config.sim.driver_steer_noise_rad)
        self.person = Handover(self.track, self.driver, self.world,
                               overrun_m=options.exploration_overrun_m,
                               standstill_s=options.handover_standstill_s,
                               autonomous_exploration=options.exploration == "autonomous",
                               ready_wait_s=options.ready_wait_s,
                               move_delay_s=options.move_delay_s)
        self.codec = CanCodec(config.sensors.can.dbc or None)
        workdir = options.workdir or Path(tempfile.mkdtemp(prefix="fsd-emulator-"))
        workdir.mkdir(parents=True, exist_ok=True)
        self.workdir = workdir
        self.gps = PtyPort(workdir / "gps")
        self.imu = PtyPort(workdir / "imu")
        self.can: SlcanAdapter | UdpCanBus = (UdpCanBus() if options.can == "udp"
                                              else SlcanAdapter(workdir / "can"))
        self.lidar_port = free_udp_port()
        self.camera_port = free_udp_port()
        self.lidar = UdpSender("127.0.0.1", self.lidar_port)
        self.camera = UdpSender("127.0.0.1", self.camera_port)
        self.frames_in = 0
        self.step_late_s: list[float] = []
        """How late (s) each step's units went out against the step's schedule."""
        self.unknown_frames_in = 0
        self.last_command: ActuatorCommand | None = None
        self.last_command_wall_s = -math.inf
        self.ever_commanded = False
        self._stop = False
        self.watchdog_stop: dict[str, float] | None = None
        """When the actuator frames stopped while the stack drove: time (s), speed (m/s), and
        once the car stood, the stop's time (s) and distance (m)."""
        self._watchdog_xy = (0.0, 0.0)
        self._stack_drove = False
        self.final_speed_mps = 0.0
        self._held_serial: list[RawBytes] = []
        self.serial_bytes_held = 0
        """GPS and IMU bytes the serial stalls held back (all written after each stall)."""

    # ------------------------------------------------------------------ config for `drive`
    def drive_config(self) -> dict[str, Any]:
        """Overrides that point `drive` at what this emulator serves."""
        sim = self.config.sim
        return {
            "sensors": {
                "gps": {"port": str(self.gps.link_path)},
                "imu": {"port": str(self.imu.link_path)},
                "can": self.can.drive_config(),
                "lidar": {"host": "127.0.0.1", "port": self.lidar_port},
                "camera": {"host": "127.0.0.1", "port": self.camera_port},
            },
            # the car's mission as the emulated car selects it (on the car: MISSION_SELECT)
            "mission": {"mission": self.options.mission,
                        "exploration": self.options.exploration},
            "sim": {"origin_lat_deg": sim.origin_lat_deg, "origin_lon_deg": sim.origin_lon_deg,
                    "origin_alt_m": sim.origin_alt_m,
                    "start_heading_enu_rad": sim.start_heading_enu_rad},
        }

    def write_drive_config(self, path: Path) -> None:
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text("# Written by `main.py emulate`: the emulated car's ports.\n"
                       + tomli_w.dumps(self.drive_config()))
        tmp.replace(path)  # atomic: `drive` never reads half a file

    # ------------------------------------------------------------------ the run
    def _serial_stalled(self, t_s: float) -> bool:
        return any(start <= t_s < start + duration
                   for start, duration in self.options.serial_stalls)

    def _dispatch(self, raw: list[RawBytes | CanFrame], t_s: float) -> None:
        stalled = self._serial_stalled(t_s)
        if not stalled and self._held_serial:
            held, self._held_serial = self._held_serial, []
            for serial_unit in held:
                port = self.gps if serial_unit.source == "gps" else self.imu
                port.write(serial_unit.payload)
        for unit in raw:
            if isinstance(unit, CanFrame):
                self.can.send_frame(unit)
            elif stalled and unit.source in ("gps", "imu"):
                self._held_serial.append(unit)
                self.serial_bytes_held += len(unit.payload)
            elif unit.source == "gps":
                self.gps.write(unit.payload)
            elif unit.source == "imu":
                self.imu.write(unit.payload)
            elif unit.source == "lidar":
                self.lidar.send(unit.payload)
            elif unit.source == "camera":
                self.camera.send(unit.payload)

    def _take_commands(self, t_s: float, wall_s: float) -> None:
        for frame in self.can.poll(t_s):
            if frame.arbitration_id == AS_STATUS_ID:
                self._as_status(frame)
                continue
            self.frames_in += 1
            command = self.codec.decode_command(frame)
            if command is None:
                self.unknown_frames_in += 1
                continue
            self.last_command = command
            self.last_command_wall_s = wall_s
            self.ever_commanded = True

    def _as_status(self, frame: CanFrame) -> None:
        """The stack's ``AS_STATUS``, decoded as the car does; a change of state is logged."""
        before = self.world.as_status
        for status in self.world.receive_can((frame,)):
            if before is None or before.state != status.state:
                log.info("AS_STATUS: %s (ASSI %s), mission %s, lap %d", status.state.name,
                         status.assi.name.lower().replace("_", " "),
                         status.mission.name.lower(), status.lap)
            before = status

    def _stack_command(self, t_s: float, wall_s: float) -> ActuatorCommand:
        fresh = wall_s - self.last_command_wall_s <= ACTUATOR_TIMEOUT_S
        if fresh and self.last_command is not None:
            c = self.last_command
            return ActuatorCommand(t_s, c.throttle, c.brake, c.steering_rad, c.state)
        return ActuatorCommand.full_brake(t_s)

    def advance(self, t_s: float) -> list[RawBytes | CanFrame]:
        """The stack's frames taken and the world advanced to ``t_s`` (s, this run's clock);
        the sensors' units it made, to dispatch. Late (this process was not run in time), the
        world does not wait: it is driven through the missed steps one by one, the person
        steering at each (one steer held over a 1.4 s stall put the scripted driver into the
        cones on a loaded test machine)."""
        raw: list[RawBytes | CanFrame] = []
        *missed, _ = catch_up_times_s(self.world.t_s, t_s, self.options.step_s)
        for step_t_s in missed:
            # the stack's last command until the car's own watchdog brakes
            raw.extend(self._step_world(step_t_s, self._stack_command(step_t_s, step_t_s)))
        self._take_commands(t_s, t_s)
        raw.extend(self._step_world(t_s, self._stack_command(t_s, t_s)))
        return raw

    def _step_world(self, t_s: float, stack: ActuatorCommand) -> list[RawBytes | CanFrame]:
        """The world stepped to ``t_s`` (s) under the person's command (the stack's after the
        handover), the person's view of it updated; the sensors' units it made."""
        if t_s < self.options.lead_in_s:
            applied: ActuatorCommand | None = ActuatorCommand.full_brake(t_s)
        else:
            applied = self.person.command(t_s, self.world.truth(), stack)
        raw = self.world.step_to(t_s, applied)
        if t_s >= self.options.lead_in_s:
            self.person.observe(t_s, self.world.truth())
        return raw

    def run(self) -> dict[str, Any]:
        """Serve until ``seconds``, a signal, or the car standing idle after the stack is done."""
        options = self.options
        previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}

        def on_signal(signum: int, _frame: Any) -> None:
            self._stop = True

        for s in previous:
            signal.signal(s, on_signal)
        if options.write_config is not None:  # after the handlers: a script may signal at once
            self.write_drive_config(options.write_config)
        self._wait_for_stack(options.wait_for_stack_s)
        # What is built lives to the end: out of the collector's sight, so that its full
        # collections (which stop this loop) stay short, as in drive's processes.
        gc.collect()
        gc.freeze()
        clock = RealClock()
        stop_reason = "signal"
        idle_since: float | None = None
        next_s = 0.0
        try:
            while not self._stop:
                next_s += options.step_s
                clock.sleep_until(next_s)
                t_s = clock.now_s()
                self._dispatch(self.advance(t_s), t_s)
                self.step_late_s.append(clock.now_s() - next_s)
                truth = self.world.truth()
                self._track_watchdog(t_s, truth)
                if options.seconds is not None and t_s >= options.seconds:
                    stop_reason = "time limit"
                    break
                speed = math.hypot(truth.vx_mps, truth.vy_mps)
                commands_stopped = t_s - self.last_command_wall_s > IDLE_END_S
                if self.person.phase == Phase.AUTONOMOUS and speed < 0.05 and commands_stopped:
                    idle_since = idle_since if idle_since is not None else t_s
                    if t_s - idle_since >= IDLE_END_S:
                        stop_reason = "actuator frames stopped; car at standstill"
                        break
                else:
                    idle_since = None
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
            gc.unfreeze()
            self.close()
        summary = self.summary(stop_reason, clock.now_s())
        if options.summary is not None:
            options.summary.write_text(json.dumps(summary, indent=2) + "\n")
        return summary

    def close(self) -> None:
        """Close the ports and sockets (the run does at its end)."""
        for port in (self.gps, self.imu, self.can):
            port.close()
        self.lidar.close()
        self.camera.close()

    def _track_watchdog(self, t_s: float, truth: Any) -> None:
        """Record the first time the watchdog brakes a car the stack was driving, and its stop."""
        speed = math.hypot(truth.vx_mps, truth.vy_mps)
        self.final_speed_mps = speed
        if (not self._stack_drove and self.person.phase == Phase.AUTONOMOUS
                and speed > STACK_DRIVES_MPS):
            self._stack_drove = True
            log.info("the stack drives the car: %.1f m/s at t=%.2f s", speed, t_s)
        stale = t_s - self.last_command_wall_s > ACTUATOR_TIMEOUT_S
        # a gap while the stack holds the car still (the 3 s after the go) brakes nothing
        if (self.watchdog_stop is None and stale and self.ever_commanded and self._stack_drove
                and self.person.phase == Phase.AUTONOMOUS):
            self.watchdog_stop = {"time_s": round(t_s, 3), "speed_mps": round(speed, 3),
                                  "last_frame_s": round(self.last_command_wall_s, 3)}
            self._watchdog_xy = (truth.x_m, truth.y_m)
            log.warning("no actuator frame for %.0f ms at %.1f m/s: braking to a stop",
                        ACTUATOR_TIMEOUT_S * 1e3, speed)
        stop = self.watchdog_stop
        if stop is not None and "stop_time_s" not in stop and speed < 0.05:
            stop["stop_time_s"] = round(t_s - stop["time_s"], 3)
            stop["stop_distance_m"] = round(math.hypot(truth.x_m - self._watchdog_xy[0],
                                                       truth.y_m - self._watchdog_xy[1]), 3)

    def _wait_for_stack(self, timeout_s: float) -> None:
        """Answer the adapter's commands until the stack opens the CAN bus (or ``timeout_s``):
        slcan's ``O``, or the stack's first frame on a UDP bus."""
        if timeout_s <= 0.0:
            return
        end = time.monotonic() + timeout_s
        while not self._stop and not self.can.is_open and time.monotonic() < end:
            self.can.poll(0.0)
            time.sleep(0.01)
        if self.can.is_open:
            log.info("the stack opened the CAN adapter: the car starts")
        elif not self._stop:
            log.warning("no stack opened the CAN adapter in %.0f s: the car starts anyway",
                        timeout_s)

    def summary(self, stop_reason: str, elapsed_s: float) -> dict[str, Any]:
        person = self.person
        return {
            "track": self.track.name,
            "stop_reason": stop_reason,
            "elapsed_s": round(elapsed_s, 3),
            "exploration_lap_time_s": (None if math.isnan(person.exploration_lap_time_s)
                                       else round(person.exploration_lap_time_s, 3)),
            "handover_time_s": (None if math.isnan(person.handover_time_s)
                                else round(person.handover_time_s, 3)),
            "laps_completed": len(person.autonomous_crossings_s),
            "lap_times_s": person.lap_times_s(),
            "cones_hit": len(self.world.cones_hit),
            "cone_hit_times_s": [round(t, 2) for t, _ in self.world.cone_hits],
            "off_track": self.world.off_track_events,
            "actuator_frames_in": self.frames_in,
            "non_command_frames_in": self.unknown_frames_in,
            "dropped_serial_bytes": self.gps.dropped_bytes + self.imu.dropped_bytes,
            "serial_bytes_held": self.serial_bytes_held,
            "can_bad_lines": self.can.bad_lines,
            "wall_time_s": round(elapsed_s, 3),
            "final_speed_mps": round(self.final_speed_mps, 3),
            "watchdog_stop": self.watchdog_stop,
            "mission_select": self.world.mission_value,
            "as_status_frames_in": self.world.as_status_frames,
            "as_state": (self.world.as_status.state.name if self.world.as_status is not None
                         else None),
            "as_transitions": [{"time_s": round(t, 3), "state": state.name}
                               for t, state in self.world.as_transitions],
            "major_page_faults": resource.getrusage(resource.RUSAGE_SELF).ru_majflt,
            **self._lateness(),
        }

    def _lateness(self) -> dict[str, Any]:
        """How late (ms) the steps' units went out against their schedule: p99, max, and the
        steps later than ``LATE_STEP_S`` (the stack's shortest sensor timeout: a stand-in
        sensor that late is the test machine's fault, not the stack's)."""
        late = np.asarray(self.step_late_s, np.float64)
        if late.size == 0:
            return {"step_late_p99_ms": None, "step_late_max_ms": None, "steps_late": 0}
        return {"step_late_p99_ms": round(float(np.percentile(late, 99)) * 1e3, 3),
                "step_late_max_ms": round(float(late.max()) * 1e3, 3),
                "steps_late": int(np.count_nonzero(late > LATE_STEP_S))}
