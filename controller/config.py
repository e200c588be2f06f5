"""Configuration of the Controller and the safety supervisor."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


@dataclass(slots=True)
class PidConfig:
    """Gains and limits of one PID (output 0..1 of the actuator)."""

    kp: float = 0.3
    ki: float = 0.1
    kd: float = 0.0
    integral_limit: float = 0.3
    """The integrator's contribution (ki * integral) is clipped to +- this."""


@dataclass(slots=True)
class SafetyConfig:
    """When the safety supervisor stops the car."""

    plan_timeout_s: float = 0.2
    """A plan older than this (s) is late: the car follows it only at a speed at which the
    rest of its manoeuvre covers a controlled stop (it slows as the plan ages), and stops when
    it no longer does or the plan is older than ``plan_max_age_s``."""
    plan_max_age_s: float = 1.0
    pose_max_age_s: float = 0.5
    """A pose (the map's) older than this (s) while driving ends the run in a controlled stop:
    the controller carries a pose forward by its own motion for at most
    ``pose_prediction_max_s``, and beyond that the car is metres from where the pose says
    (issue 19: a map 1 s late under load hit cones). The simulator's and replay's poses are
    the tick's own."""
    late_plan_reaction_s: float = 0.2
    """A late plan must cover the controlled stop's distance plus the distance driven in this
    time (the control and actuator delay) ..."""
    late_plan_margin_m: float = 0.2
    """... plus this (m)."""
    late_plan_slow_decel_mps2: float = 6.5
    """On a late plan the controller drives no faster than a stop at this deceleration (with
    the reaction and margin) fits in the manoeuvre left ahead: gentler than
    ``stop_decel_mps2``, where the supervisor stops the car, so that the speed loop's lag
    behind a falling cap stays short of that line (issue 19: at the same deceleration a plan
    0.5 s late ended runs under load). About 0.8 of it, as 5 was of 6 before issue 45."""
    no_path_timeout_s: float = 1.5
    """A plan with no manoeuvre or no feasible one (the controller brakes fully) for this long
    ends the run; one that comes back before goes on (issue 19: under load the next cones of
    an exploration were mapped 1.1 s after the car had stopped at the end of those seen)."""
    critical_sources: tuple[str, ...] = ("imu", "lidar")
    """Sources whose staleness is an emergency (full braking at once)."""
    max_position_sigma_m: float = 1.0
    max_yaw_sigma_rad: float = 0.3
    track_half_width_m: float = 2.0
    corridor_margin_m: float = 1.0
    """Leaving the corridor: distance from the baseframe > half track width + this margin."""
    stop_decel_mps2: float = 8.0
    """Deceleration (m/s^2) of a controlled stop: within the braking the planner's profile
    plans with (``planner.friction_safety_factor`` 0.7 of the car's 12 m/s^2: 8.4), so the
    supervisor never asks the tyres for more than a planned stop does. It also sets the pace
    of an unseen track, which must leave room for this stop before the end of the cones
    seen (issue 45, :mod:`planner.exploration_speed`): 6 m/s^2 held the explored laps to
    about 11 m/s (autocross, shared tracks + gen:1..20, seeds 1-3: median ratio 1.856;
    1.768 at 8)."""
    standstill_speed_mps: float = 0.2
    min_ready_time_s: float = 0.0
    """Time in READY before a go is accepted (the rules ask 5 s on the car)."""
    auto_go: bool = False
    """Go from READY to DRIVING without a RES go (simulation)."""
    auto_arm: bool = True
    """Go from OFF to READY when the first plan with a baseframe arrives and sensors are fresh."""


@dataclass(slots=True)
class AsStateMachineConfig:
    """Timings of the FSD autonomous-system state machine (controller/as_state_machine.py)."""

    min_ready_s: float = 5.0
    """Time in READY before the RES go may start the mission (FS rules T14.8.4: 5 s)."""
    min_driving_before_move_s: float = 3.0
    """Time in DRIVING before the car may move (FS rules T14.8.5: 3 s)."""
    standstill_speed_mps: float = 0.1
    """At or below this speed the car stands (DRIVING -> FINISHED needs standstill)."""
    ignore_early_go: bool = True
    """A go already held when the READY wait ends is ignored until it is released and given
    again (the rules: only a go after the wait starts the mission). False: a held go counts."""
    assi_flash_hz: float = 3.0
    """Flashing frequency of the ASSI lamps (the rules: 2..5 Hz)."""
    mission_wait_s: float = 0.5
    """``MISSION_SELECT`` comes at 10 Hz: for this long (s) after the first step, no frame yet
    keeps the machine OFF without a log line; after it, "no mission selected" is logged."""


@dataclass(slots=True)
class ControllerConfig:
    """Throttle and brake PIDs, steering law, rates."""

    rate_hz: float = 100.0
    throttle_pid: PidConfig = field(default_factory=lambda: PidConfig(0.35, 0.15, 0.0, 0.3))
    brake_pid: PidConfig = field(default_factory=lambda: PidConfig(0.25, 0.1, 0.0, 0.2))
    use_feedforward: bool = True
    resistance_accel_mps2: float = 0.3
    """Drag and rolling resistance the throttle feedforward compensates at speed."""
    mode_switch_accel_mps2: float = 0.4
    """Hysteresis between throttle and brake modes on the wanted acceleration."""
    speed_preview_s: float = 0.25
    speed_dip_margin_mps: float = 0.0
    """When a target between the car and the preview point is slower than both the target read
    there and the car's speed less this margin (m/s), the speed loop reads that slower target
    instead and takes no positive feed-forward: a manoeuvre that bends back to its plan in its
    first metres dips its speed there and rises after, and read 0.25 s ahead the dip is
    skipped while the car, too fast for it, runs wide. 0: off (the preview point alone)."""
    steering_law: Literal["preview", "pure_pursuit", "stanley", "heading_p"] = "preview"
    lookahead_min_m: float = 3.0
    lookahead_max_m: float = 12.0
    lookahead_time_s: float = 0.6
    lookahead_base_m: float = 2.0
    preview_time_s: float = 0.2
    """Preview law: the path's curvature is read this far ahead (the steering's lag)."""
    preview_damping: float = 0.9
    heading_kp: float = 0.6
    stanley_k: float = 1.5
    stanley_soft_mps: float = 1.0
    understeer_accel_mps2: tuple[float, ...] = (0.0, 2.0, 4.0, 6.0, 8.0, 10.0, 11.0, 12.0)
    understeer_steer_rad: tuple[float, ...] = (0.0, 0.0075, 0.015, 0.022, 0.034, 0.05, 0.065,
                                               0.09)
    """The car's steady-state understeer: the steering (rad) beyond the kinematic atan(L kappa)
    that a lateral acceleration (m/s^2) needs, from a constant-radius cornering test (the
    defaults: the simulator's car, simulator/vehicle.py, measured so). The command is
    atan(L kappa) + table(v^2 |kappa|), interpolated, held beyond the last point."""
    lock_hold_fraction: float = 1.0
    """While the steering law asks for more than this fraction of the steering lock, the car
    gains no speed (the speed reference is held at the speed it had when the law first asked
    for it, at least ``lock_hold_min_speed_mps``): at the lock it cannot follow its path, and
    more speed widens its circle through the understeer (EPFL's autocross layout at the
    rules' 9 m hairpin: the car sped up from 2.2 to 4.6 m/s at the lock, and its front corner
    swept into the outer cone). 0: off."""
    lock_hold_min_speed_mps: float = 2.0
    """The speed held at the lock is at least this (m/s): at walking pace the understeer is
    nil and the car turns as the kinematic bicycle (the planner's ``crawl_speed_mps``); a car
    that reached the lock at a standstill (a start in a hairpin) must still move."""
    steer_along_course: bool = True
    """Steer relative to the direction of travel (yaw + sideslip atan(vy/vx)) rather than yaw."""
    max_steer_rate_radps: float = 3.0
    """Steering rate limit (the car's own limit applies too, whichever is lower)."""
    hold_brake: float = 1.0
    """Brake held at standstill in READY and FINISHED."""
    max_dt_s: float = 0.1
    pose_prediction_max_s: float = 0.5
    """The pose is carried forward to the control tick by its own motion over its age, at
    most this long (s; 0: as the map sent it): on the car the map is 20-120 ms old when it
    reaches the control loop, up to 0.4 s on a busy computer (controller/pose_prediction.py);
    an older pose stops the car (``safety.pose_max_age_s``)."""
    safety: SafetyConfig = field(default_factory=SafetyConfig)
    as_state: AsStateMachineConfig = field(default_factory=AsStateMachineConfig)
