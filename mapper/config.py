"""Configuration of the Mapper: backend choice and each estimator's parameters.

Why the values are what they are (the measurements): docs/tuning.md.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


@dataclass(slots=True)
class SmootherConfig:
    """Seed 002, table 2: the time smoother's optimal parameters."""

    size_ratio_x: float = 0.7
    size_ratio_y: float = 0.7
    match_distance_m: float = 1.5
    conf_limit: float = 20.0
    confidence_decay: float = 1.0
    match_conf: float = 2.0
    initial_conf: float = 2.0
    min_height_m: float = 0.1
    """Detections whose top is lower than this (m) are not used by the smoother backend: its
    reach before issue 45 (the simulated VLP-16's cones beyond 11.5 m show only low on one
    ring). Without cross-covariances its map drifts as a block, and with the cones taken
    further the default track's lap mapped cones again: 23-105 false landmarks of 140 (the
    SLAM merges them at the loop closure)."""
    detection_range_m: float = 20.0
    """Seed 002, 7.2 note: objects farther than this from the sensor do not decay."""
    detection_fov_rad: float = 3.4
    """Full horizontal field of view around the sensor's x axis; objects outside do not decay."""
    protect_min_matches: int = 1
    """Only objects matched at least this often are spared the decay outside the range (a
    one-off false detection at the edge of the field of view must still die)."""
    publish_min_matches: int = 1
    """Objects matched fewer times are kept internally but not published in the map."""
    position_weight_new: float = 0.0
    """Weight of a new detection in the weighted average; 0 = 1 / (match_count + 2)."""
    position_max_matches: int = 0
    """Matches averaged into an object's position; later ones leave it (0: no limit, the
    seed). Tried at 5 for the smoother backend's localisation on its own objects: the pose
    drift fell 15 % but objects left behind by the drift were duplicated (130 false cones)."""


@dataclass(slots=True)
class ObjectFilterConfig:
    """Seed 002, 7.2: reject detections that are too small, too near or too far."""

    min_range_m: float = 1.0
    max_range_m: float = 20.0
    min_height_m: float = 0.05
    """A detection's height is the top of its returns (m): a sparse LiDAR low on the car
    reaches a small cone's top only near (the simulated VLP-16 0.3 m up: beyond 5.7 m only its
    -1 deg ring, at 0.3 - d tan(1 deg) above the ground). 0.1 dropped every cone beyond 11.5 m
    from the sensor, so cones entered the map 11-12 m ahead of the car; the cone detector's
    ground clearance (0.05) is what a real cone's top is at least (issue 45: 14-15 m)."""
    max_height_m: float = 0.8
    min_width_m: float = 0.05
    max_width_m: float = 0.6


@dataclass(slots=True)
class UkfConfig:
    """Seed 001: UKF localisation (state x, y, yaw, vx, vy, yaw rate); see mapper/ukf_localiser.py.

    Mahalanobis gates are distances (sigma units), as robot_localization's rejection thresholds.
    """

    use_odometry: bool = True
    use_gnss_position: bool = True
    use_gnss_velocity: bool = True
    use_cones: bool = True
    alpha: float = 1.0
    beta: float = 0.0
    kappa: float = 3.0
    """Sigma-point spread: n + lambda = alpha^2 (n + kappa) (Julier's n + kappa = 3 + ...)."""
    yaw_rate_blend_nu: float = 0.0
    """Seed 001, alg. 2 line 8: omega = nu * omega + (1 - nu) * gyro (0: trust the gyro)."""
    imu_lever_arm: bool = True
    accel_sigma_mps2: float = 0.08
    """Accelerometer white noise per sample (m/s^2), after the standstill bias calibration."""
    gyro_sigma_radps: float = 0.005
    """Gyro white noise per sample (rad/s)."""
    gyro_bias_sigma_radps: float = 5.0e-4
    """Residual gyro bias (rad/s): spread into the yaw-rate state's process noise."""
    accel_bias_sigma_mps2: float = 0.2
    static_calibration: bool = True
    """Average the IMU while the car stands still at the start: gyro and accelerometer biases."""
    static_min_samples: int = 50
    static_gyro_threshold_radps: float = 0.03
    static_accel_threshold_mps2: float = 0.4
    lateral_model_sigma_mps2: float = 1.0
    """Unmodelled lateral dynamics (tangential lever-arm term, slip build-up): vy process noise."""
    lateral_velocity_sigma_mps: float = 0.05
    """Without GNSS velocity the rear axle's lateral speed is held at zero (seed 001, II.A),
    apart from its tyres' slip (``rear_slip_rad_per_mps2``)."""
    rear_slip_rad_per_mps2: float = 0.0073
    """Rear-axle slip angle per lateral acceleration (rad per m/s^2): the lateral constraint is
    ``vy = -k vx^2 w``; see SlamConfig.rear_slip_rad_per_mps2. 0: the seed's zero."""
    rear_slip_saturation: bool = True
    """The slip angle grows as atanh(a_y / car.max_lateral_accel_mps2) near the grip limit
    (tanh tyre law); False: linear in a_y."""
    lateral_slip_sigma_fraction: float = 0.5
    """The lateral constraint's sigma grows by this fraction of the modelled slip speed (the
    steady-state tyre model is rough near the grip limit)."""
    imu_bias_states: bool = True
    """Estimate the gyro z and accelerometer x, y biases as states (random walks; each sigma
    point subtracts its own): the car may drive off without a standstill to calibrate them. With
    them the bias terms above (``gyro_bias_sigma_radps``, ``accel_bias_sigma_mps2``) are not
    spread into the process noise."""
    initial_gyro_bias_sigma_radps: float = 0.005
    initial_accel_bias_sigma_mps2: float = 0.2
    gyro_bias_walk_radps_rths: float = 2.0e-5
    """Gyro bias random walk (rad/s per sqrt(s))."""
    accel_bias_walk_mps2_rths: float = 1.0e-3
    """Accelerometer bias random walk (m/s^2 per sqrt(s)), with slow pitch/roll leakage."""
    accel_model_sigma_mps2: float = 0.05
    """With bias states: unmodelled longitudinal acceleration (m/s^2 per sqrt(Hz)), vx and vy
    process noise (pitch/roll leakage, vibration)."""
    yaw_model_sigma_rad_rts: float = 1.0e-4
    """With bias states: yaw process noise (rad per sqrt(s)) beyond the gyro's."""
    max_predict_dt_s: float = 0.05
    imu_predict_step_s: float = 0.01
    """IMU samples closer than this (s) are propagated together, with their mean input (issue
    42: half the prediction steps of a 200 Hz IMU, at a discretisation error far below the
    filter's noise); 0: one step per sample, as seed 001."""
    held_gyro_sigma_radps: float = 0.5
    """Without IMU samples (a stalled serial link) the prediction holds the last sample's
    input: the yaw rate's sigma (rad/s) added (as a variance) per ``max_predict_dt_s`` held,
    for how far the true yaw rate may have moved; the yaw's uncertainty grows with it."""
    held_accel_sigma_mps2: float = 5.0
    """The same for the acceleration (m/s^2): each held step of dt adds (this x dt)^2 to the
    speeds' variances."""
    initial_position_sigma_m: float = 0.01
    initial_yaw_sigma_rad: float = 0.001
    initial_velocity_sigma_mps: float = 0.05
    odometry_speed_sigma_mps: float = 0.07
    """Wheel speed noise (m/s), slip included (as SlamConfig.wheel_speed_sigma_mps)."""
    odometry_yaw_rate_sigma_radps: float = 0.1
    odometry_scale_sigma: float = 0.002
    """Relative tyre-radius uncertainty (a radius measured to 1 mm): a systematic speed error,
    spread on the position as a random walk over ``odometry_scale_time_s``."""
    odometry_scale_time_s: float = 10.0
    odometry_speed_scale: float = 1.0
    """The wheels' speeds are multiplied by this (the true rolling radius over the one the
    wheel speeds were computed with)."""
    odometry_scale_from_gnss: bool = False
    """Learn the wheel speed scale from the GNSS speed (:mod:`mapper.wheel_scale`), starting
    from ``odometry_speed_scale``."""
    odometry_yaw_rate_source: Literal["rear_wheels", "steering", "none"] = "rear_wheels"
    odometry_gate_sigma: float = 5.0
    odometry_reset_after_s: float = 0.5
    """Wheel speeds rejected by the gate without a break for this long (s, their own time)
    mean the filter, not the wheels, is wrong (it diverged: e.g. after the computer stalled
    and the sensors' data came in a burst): the speeds' covariance is reset around the wheels'
    reading, and the position's widened by what that error moved it, so the filter takes the
    wheels, the GNSS and the cones again. 0 or less: never (rejected for ever)."""
    gnss_position_sigma_m: float = 5.0
    """GNSS position noise (m), above the receiver's 2.5 m white noise: its wandering bias and
    the error of the estimated world frame are not in the model."""
    gnss_position_gate_sigma: float = 4.0
    gnss_sigma_from_receiver: bool = True
    """A fix with the receiver's own accuracy (NMEA GST: ``GpsFix.lat_sigma_m``,
    ``lon_sigma_m``) is fused with it, times ``gnss_receiver_sigma_scale`` and floored at
    ``gnss_receiver_sigma_floor_m``, instead of ``gnss_position_sigma_m``. (The simulated
    receiver sends no GST.)"""
    gnss_receiver_sigma_scale: float = 1.0
    gnss_receiver_sigma_floor_m: float = 0.05
    gnss_latency_s: float | None = None
    """The receiver's latency (s): a fix was measured this long before its time stamp (with
    ``gnss_time_from_utc``, before its UTC time on the receiving clock), and is applied there.
    Not set (the default): ``replay`` of a recording without commands (an imported or recorded
    drive, localisation only) estimates it from the log's own fixes and wheels
    (:mod:`mapper.gnss_latency`); elsewhere (simulation, a live drive) it is 0. Set, it wins."""
    gnss_time_from_utc: bool = False
    """Time a fix by its UTC time of day, put on the receiving clock by the smallest
    (receive - UTC) offset seen so far (the arrival jitter of the serial link removed), instead
    of its receive time."""
    gnss_speed_sigma_mps: float = 0.1
    gnss_min_speed_mps: float = 1.0
    """Seed 001: GNSS velocity and track are fused only above this speed."""
    gnss_antenna_x_m: float = 0.0
    """GNSS antenna ahead of the vehicle origin (m): its velocity has a yaw-rate component."""
    gnss_track_sigma_floor_rad: float = 0.05
    """The receiver's own course noise: the track's sigma is max(sigma_v / v, this)."""
    gnss_velocity_gate_sigma: float = 5.0
    cone_sigma_m: float = 0.05
    cone_association_m: float = 1.0
    """A detection is paired with the nearest map cone within this distance (world frame)."""
    cone_gate_sigma: float = 3.5
    cone_update_heading: bool = False
    """Seed 001 updates only the position from cones (its update mask); True also the yaw."""
    cone_max_yaw_rate_radps: float = 10.0
    """Seed 001's suggested fix: skip cone updates when turning faster than this."""
    heading_estimate_samples: int = 100
    """GNSS courses (above gnss_min_speed_mps, nearly straight) averaged for the start heading."""
    heading_estimate_max_yaw_rate_radps: float = 1.0
    """Heading samples only while the filter turns slower than this (tight corners, where the
    modelled slip angle is least sure, are left out)."""
    heading_yaw_error_correlation_s: float = 5.0
    """The filter's yaw error is taken as correlated over this long: averaging heading samples
    over a longer span divides its variance by the number of spans (the frame heading's sigma)."""
    gnss_heading_state: bool = True
    """Estimate the GNSS world frame's heading error as a state (a constant: the world-frame
    course reads yaw + slip + offset). An estimated frame heading is off by a few mrad, which
    thousands of course updates would otherwise write into the yaw as a bias the covariance does
    not know of."""
    initial_gnss_heading_sigma_rad: float = 1.0e-6
    """The offset state's sigma until the Mapper sets it from the frame estimate (about 0: a
    frame given by the caller is taken as exact)."""
    gnss_frame_refine: bool = True
    """With the SLAM backend: at the map freeze the frame heading is re-estimated from every
    course of the exploration lap against the SLAM's yaw (a few times finer than the first
    ``heading_estimate_samples``)."""
    track_alignment_distance_m: float = 20.0
    """Fallback without courses: align the GNSS track with the filter's over this travel."""
    track_alignment_heading_sigma_rad: float = 0.05
    """Sigma of a frame heading from the track alignment (2.5 m noise over 20 m of travel)."""


@dataclass(slots=True)
class FusionConfig:
    """Seed 000, 6.2.1: delay every measurement to the slowest sensor, then predict to now."""

    max_delay_s: float = 0.3
    """A source silent for longer than this no longer holds the lagged filter back."""
    imu_coalesce_backlog_s: float = 0.0
    """When one update takes IMU samples spanning more than this (s), each two consecutive
    ones are predicted as one (:mod:`mapper.imu_coalesce`): a mapper behind its sensors
    catches up. 0: every sample is predicted (the simulator and replay, whose map updates
    take what came in one tick); ``drive`` uses
    ``orchestrator.live_worker.DRIVE_IMU_COALESCE_BACKLOG_S`` when this is 0; negative: never,
    in ``drive`` too."""
    freeze_gap_s: float = 1.0
    """No reading at all for this long (s, on the caller's clock): the stack itself was not
    run (a stalled computer), not every sensor dead. The silence is not counted against the
    sources, and the horizon trails its old pace while their backlogs arrive, so what they
    made meanwhile is applied in order, not dropped as late (:mod:`mapper.delay_buffer`).
    Longer than every sensor's timeout: a stall that long stops a driving car anyway, while
    a shorter one is ridden through with the horizon running on (at 0.5 s, a 0.55 s stall of
    drive's executive process under load lagged the map by that much, and the car left the
    track corridor in `bench load`)."""
    colour_min_votes: int = 1
    colour_gate_m: float = 1.0
    """A camera cone votes for the nearest landmark within this distance (world frame)."""
    colour_stale_s: float = 1.0
    """While exploring, a camera that has reported and then been silent this long (s) takes
    the map's colours and its tentative cones with it: the landmarks are published alone, of
    unknown colour, so the planner explores as it does with no camera at all. Kept, the
    colours of the cones seen before met new cones of none ahead, and the planner took those
    for cones not voted yet among coloured ones (community and EPFL layouts, the camera dying
    8 s in, seeds 1-4: 71 of 92 runs clean, 17 cones hit; now 79 and 4). The frozen map keeps
    its colours."""
    loop_min_distance_m: float = 60.0
    """Smoother backend: the loop closes back at the big orange cones after this travel."""
    loop_close_radius_m: float = 4.0
    smoother_localise: bool = True
    """Smoother backend: during the exploration the UKF also localises on the objects the time
    smoother has confirmed (matched ``smoother_localise_min_matches`` times), before their
    sweep is merged into them: a SLAM without cross-covariances. Without it the map is drawn
    with the dead-reckoned pose (GNSS is metres off)."""
    smoother_localise_min_matches: int = 5
    smoother_localise_sigma_m: float = 0.02
    """Detection noise of that update (m): the LiDAR's (its range noise is 2 cm)."""
    smoother_localise_map_sigma_floor_m: float = 0.01
    """Floor of a confirmed object's position sigma (m) in that update."""
    smoother_localise_full_update: bool = True
    """The exploration's cone update also corrects the yaw and the IMU biases (seed 001's
    position-only mask is meant for a surveyed map)."""


@dataclass(slots=True)
class SlamConfig:
    """Seed 000, section 5.3: EKF SLAM with controlled loop closure (see mapper/slam/)."""

    gyro_noise_density_radps_rthz: float = 3.0e-4
    """Gyro white noise (rad/s/sqrt(Hz)), with model error; Q = G diag(sigma^2 / T) G^T."""
    accel_noise_density_mps2_rthz: float = 0.01
    """Accelerometer white noise (m/s^2/sqrt(Hz)), with pitch/roll leakage and vibration."""
    heading_mode: Literal["midpoint", "seed"] = "midpoint"
    """Eq. 5.2: 'seed' uses alpha = theta + T^2/2 * yaw rate literally; 'midpoint' uses T/2."""
    imu_lever_arm: bool = True
    """Move the IMU's specific force from car.imu_x_m to the rear axle (centripetal, tangential)."""
    max_predict_dt_s: float = 0.1
    initial_position_sigma_m: float = 1.0e-5
    initial_yaw_sigma_rad: float = 1.0e-5
    """The world frame IS the car's start pose (common/conventions), so the initial pose error
    is zero by definition; the tiny sigma only keeps P positive definite."""
    initial_velocity_sigma_mps: float = 0.05
    lidar_range_sigma_m: float = 0.02
    lidar_bearing_sigma_rad: float = 0.001
    measurement_sigma_floor_m: float = 0.01
    """Seed 5.3.5: no measurement noise below this (keeps S well conditioned)."""
    motion_compensation_sigma_mps: float = 0.05
    """Velocity uncertainty when a detection is moved to its sweep's timestamp (adds noise)."""
    max_range_m: float = 25.0
    gate_probability: float = 0.997
    """Chi-square gate (2 dof) for associating a detection with a landmark."""
    new_landmark_probability: float = 0.99999
    """A detection inside this gate of any landmark is ambiguous: never a new landmark."""
    new_landmark_min_distance_m: float = 1.0
    """A detection nearer than this (m) to a landmark of its own size class (or of no size
    yet), and not assigned, is ambiguous too: never a new landmark."""
    new_landmark_min_distance_other_size_m: float = 0.4
    """The same for a landmark of the other size class (a big cone beside a small one): the
    start line's big cones stand 0.6-0.9 m from the lane's small ones on EPFL's layouts, and
    with the 1 m floor a small cone mapped first hid its big neighbour when the car came back
    to the start, and the loop did not close on that return (EPFL track_2, seed 4: it closed a
    lap later, on a map holding the track twice)."""
    preliminary_gate_m: float = 0.5
    """Seed 5.3.3: a candidate enters the filter when seen again this close in the next sweep."""
    unseen_travel_m: float = 25.0
    """Seed 5.3.2: no association with landmarks not seen for this travel distance."""
    associate_all_after_closure: bool = True
    min_lap_distance_m: float = 80.0
    """Loop closure is tried only after this travel distance."""
    seen_through_min_lap_m: float = 40.0
    """On a lap so short that the start's big cones never go unseen for ``unseen_travel_m``
    (EPFL's 74 m autocross: they stay in view all the lap) they are never new nor old, and the
    pattern match never closes the loop; the cones out of view meanwhile are mapped again every
    lap. Such a loop closes as the car passes the very big cones it mapped at the start (mapped
    at least this far (m) ago, seen within ``unseen_travel_m``, passed on its line of travel,
    heading as it started); the backward sweep then merges the cones mapped twice."""
    big_cone_search_m: float = 6.0
    """Largest drift (m) at which old and new big orange cones are still paired."""
    big_cone_pattern_tolerance_m: float = 0.6
    """New big cones within this (m) of an old one under a shift pair with it."""
    min_big_cone_pairs: int = 2
    """Fewest big cone pairs that close the loop. While fewer new than old big cones are mapped
    and some old ones are still ahead of the car, the match must pair more than this and more
    than any other shift (the start's rows of big cones repeat a few metres apart)."""
    big_cone_lateral_max_m: float = 4.0
    """The new big cones close the loop only when at least ``min_big_cone_pairs`` of them lie
    within this distance (m) of the car's line of travel: the car is arriving at the start line,
    not passing it on a neighbouring stretch of track (a hairpin's straights side by side)."""
    big_cone_behind_max_m: float = 6.0
    """... and no more than this (m) behind the car along its heading: the car arrives at the
    start's big cones, so they are new ahead of it or just passed. A LiDAR that sees far maps
    the start's big cones again from another stretch of track across the infield (FSG, cones
    mapped to 15 m: 18 m behind the car, on its line of travel, they closed the loop half a
    lap early, the map froze and the exploration stopped at the end of the cones seen)."""
    big_cone_heading_max_rad: float = 1.0
    """... and only while the car heads within this (rad) of its heading at the start: it
    crosses the start line the way it left it. A stretch of track beside the start runs the
    other way (hard:hairpins: the car passed the start's big cones 4 m across the infield,
    heading back, and the loop closed 65 m early; the map froze without the hairpin ahead)."""
    min_big_cone_votes: float = 3.0
    """Votes (detections) a landmark needs before it counts as a big orange cone."""
    closure_covariance_inflation: float = 4.0
    """The drift between old and new big cones is gated on this multiple of its covariance."""
    merge_distance_m: float = 1.2
    duplicate_distance_m: float = 0.2
    """Two landmarks nearer than this (m) are one cone mapped twice, seen together or not
    (cones stand at least a base, 0.23 m, apart): the loop closure's backward sweep merges them,
    or drops the newer when the merge gate refuses their difference (their sigmas leave out the
    LiDAR's bias along the ray each was seen from)."""
    merge_gate_probability: float = 0.9999
    same_point_sigma_m: float = 1.0e-3
    """The 'zero-noise' same-point measurement's floor (m): seed 5.3.2 uses none."""
    wheel_speed_sigma_mps: float = 0.07
    """Rear wheel speed noise (m/s): sensor noise plus longitudinal slip."""
    wheel_speed_sigma_fraction: float = 0.02
    """Rear wheel speed noise proportional to the speed (white slip noise, a fraction); the
    variance is ``wheel_speed_sigma_mps^2 + (fraction vx)^2``. 0.02: each simulated wheel reads
    1 % off at random (``sim.can.wheel_slip_sigma``), and the longitudinal slip model
    (``wheel_slip_per_mps2``, a steady-state fit) errs by about as much again while the car
    drives and brakes hard. At 0 the absolute sigma alone says 0.6 % at 12 m/s, tighter than
    the sensor (issue 45: FSG, seeds 1-16, mean pose RMSE of the explored lap 0.127 m at 0 with
    the camera's tentative cones on, 0.096 m at 0.02)."""
    wheel_slip_per_mps2: float = 0.002
    """Longitudinal slip of the rear tyres per m/s^2 of the axle's longitudinal acceleration:
    the wheels read ``vx (1 + k a_x)`` (faster when driving, slower when braking); the slip at
    full grip over ``mu g``. 0: no slip model."""
    lateral_velocity_sigma_mps: float = 0.05
    """Non-holonomic pseudo-measurement: the rear axle slides sideways only by its slip."""
    rear_slip_rad_per_mps2: float = 0.0073
    """Rear-axle slip angle per lateral acceleration (rad per m/s^2): the rear axle slides
    outwards at ``vx * k * a_y`` in a corner. ``1 / (C * g)`` with C the rear cornering
    stiffness per axle load (1/rad; 14 for the default car's tyres); 0 = no slip."""
    rear_slip_saturation: bool = True
    """The slip angle grows as atanh(a_y / car.max_lateral_accel_mps2) near the grip limit
    (tanh tyre law); False: linear in a_y."""
    slip_from_accelerometer: bool = True
    """The slip's lateral acceleration is the accelerometer's, moved to the rear axle, and the
    grip left for it the friction circle's share after the longitudinal force
    (:func:`mapper.motion.rear_slip_from_accel`); False: the steady-state ``vx w`` with all the
    grip (``rear_slip_saturation`` then applies)."""
    lateral_slip_sigma_fraction: float = 0.5
    """The lateral constraint's sigma grows by this fraction of the modelled slip speed: the
    steady-state tyre model (``rear_slip_rad_per_mps2``) is rough while the slip builds up and
    decays at a bend's entry and exit and near the grip limit. The UKF's value (one tyre model,
    one uncertainty). It was 0.1 until the car explored at the pace the camera's view allows
    (issue 45); autocross seeds 1-8, mean pose RMSE of the explored lap with 0.1 and 0 for
    ``wheel_speed_sigma_fraction`` / with 0.5 and 0.02: FSG 0.130 / 0.103 m, the default track
    0.076 / 0.086 m (docs/tuning.md)."""
    imu_bias_states: bool = True
    """Estimate the gyro z and accelerometer x, y biases as states (the car may start moving
    without a standstill to calibrate them)."""
    standstill_gyro_calibration: bool = True
    """With bias states: while the car stands at the start, the gyro's mean is its bias (the
    UKF's static-calibration thresholds say when it moves); applied once as a zero-rate update
    of the bias state, with the samples' own standard error."""
    initial_gyro_bias_sigma_radps: float = 0.005
    initial_accel_bias_sigma_mps2: float = 0.2
    gyro_bias_walk_radps_rths: float = 2.0e-5
    """Gyro bias random walk (rad/s per sqrt(s))."""
    accel_bias_walk_mps2_rths: float = 1.0e-3
    """Accelerometer bias random walk (m/s^2 per sqrt(s)), with slow pitch/roll leakage."""
    use_odometry: bool = True
    use_gps: bool = True
    gps_sigma_m: float = 20.0
    """GNSS position noise for the SLAM (m), far above the receiver's 2.5 m: its error is
    correlated over minutes, so it only bounds gross drift and must not bend a centimetre cone
    map."""
    gps_gate_probability: float = 0.9999
    colour_gate_m: float = 1.0
    """Camera cones vote for the nearest landmark within this distance (world frame)."""


@dataclass(slots=True)
class TentativeConfig:
    """Camera cones beyond the LiDAR's landmarks, published for the exploring planner
    (:mod:`mapper.tentative_cones`, issue 45): never in the SLAM, gone at the map freeze."""

    enabled: bool = True
    """On: the track in view ends 17-19 m ahead instead of 14-15 m (the camera sees 20 m, the
    simulated VLP-16's landmarks begin 14-15 m ahead), and the unseen lap runs faster (autocross,
    the four shared closed tracks and gen:1..20, seeds 1-3: median explored ratio 2.20 -> 1.86,
    worst 2.66 -> 2.21, all clean). The car then corners harder in the bends it sees into; the
    SLAM's slip noise (``mapper.slam.lateral_slip_sigma_fraction``,
    ``wheel_speed_sigma_fraction``) is what keeps the explored lap's drift where it was with the
    landmarks alone (FSG, 16 seeds: mean pose RMSE 0.127 m with the old noise, 0.096 m with
    it). A narrow passage is slowed (``planner.exploration_narrow_room_m``): EUFS
    small_track_2's 2.5 m wide bend hit its outer cones at the speed a farther view allowed."""
    landmark_gate_m: float = 1.5
    """A camera cone this near (m) a landmark is that landmark (its colour vote only). Wider
    than ``gate_m``: a tentative cone averaged from 15-20 m away lay 1.0-1.3 m from the
    landmark the LiDAR then mapped of it often enough to stand as a phantom beside it (EPFL
    track 4, seed 1, duplicates folded: 15 of the 20 pairs still among the refused
    manoeuvres' worst cones), and a real cone that near a landmark is within the LiDAR's
    reach too."""
    gate_m: float = 1.0
    """Camera cones of successive frames this near (m) are one tentative cone; further out,
    where ``gate_sigmas`` of the camera's standard deviation at the cone's range are more,
    that much."""
    gate_sigmas: float = 0.0
    """The association gate in the camera's standard deviations at the range (``gate_m`` at
    least; 0: ``gate_m`` everywhere). Set it (3) for a camera that maps cones well beyond
    20 m: at 27 m one frame in a few places a cone 1.4 m aside, and a fixed 1 m gate started
    a second track of it, a phantom in the lane (EPFL ``fsds_competition_1``, seed 1, with a
    30 m camera: a cone hit at 10 m/s). Not the default: with the simulated 20 m camera it
    also folds a rules-minimum hairpin's inner cones (under a metre apart) seen at 15-20 m,
    and ``hard:hairpins`` seed 5 grazed a cone (docs/driving.md)."""
    min_frames: int = 2
    """Frames a tentative cone must be seen in before it is published."""
    max_age_s: float = 0.5
    """A tentative cone the camera has not seen for this long (s) goes."""
    min_range_m: float = 10.0
    """A tentative cone nearer the car than this (m) goes: the LiDAR maps a real cone there
    (14-15 m ahead with the simulated VLP-16)."""
    sigma_at_zero_m: float = 0.05
    """The camera's cone position standard deviation (m) at zero range; with ``sigma_per_m``
    it weights each frame's cone in a tentative cone's mean, whose own standard deviation is
    published with it (the simulated camera's model,
    ``sim.camera.position_sigma_m``; set it from your own camera's calibration)."""
    sigma_per_m: float = 0.02
    """What the camera's standard deviation grows by per metre of range (m/m;
    ``sim.camera.range_sigma_per_m``)."""
    confidence: float = 0.5
    """Its confidence in the :class:`~common.messages.ConeMap` (a SLAM landmark's is 1)."""


@dataclass(slots=True)
class MapperConfig:
    """Which backend maps, and its parameters."""

    backend: Literal["slam", "smoother"] = "slam"
    smoother: SmootherConfig = field(default_factory=SmootherConfig)
    slam: SlamConfig = field(default_factory=SlamConfig)
    object_filter: ObjectFilterConfig = field(default_factory=ObjectFilterConfig)
    ukf: UkfConfig = field(default_factory=UkfConfig)
    fusion: FusionConfig = field(default_factory=FusionConfig)
    tentative: TentativeConfig = field(default_factory=TentativeConfig)
