"""Configuration of the Path Planner."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal


@dataclass(slots=True)
class PlannerConfig:
    """Waypoints, baseframe, manoeuvres and speed profile (SI units, unit in every name)."""

    rate_hz: float = 10.0

    # Waypoint book (seed 002, 3.2.1)
    waypoint_reach_m: float = 2.5
    """A waypoint is dropped once the car is within this distance of it."""
    waypoint_spacing_m: float = 1.5
    """Distance between waypoints recorded during the exploration drive."""
    waypoints_served: int = 3
    """How many upcoming waypoints the book serves (seed 002: the next three)."""
    loop_close_distance_m: float = 4.0
    """The recorded drive is a closed lap when it comes back within this of its first waypoint."""
    min_loop_length_m: float = 30.0
    loop_bridge_max_m: float = 12.0
    """A drive that ends this close to its start, heading for it, is a lap (the map's loop
    may close before the car is back at its first waypoint)."""

    # Waypoints from the cone map (no exploration drive)
    max_cone_pair_distance_m: float = 7.0
    """Blue-yellow Delaunay edges longer than this are not track crossings."""
    min_cone_pair_distance_m: float = 2.0
    nominal_track_width_m: float = 3.5
    """Used when only one side of the track has cones: the path is offset by half of it."""
    waypoint_max_step_m: float = 8.0
    waypoint_max_turn_rad: float = 1.2

    # Baseframe
    baseframe_resample_m: float = 1.0
    baseframe_smoothing_m: float = 2.5
    """Gaussian smoothing (standard deviation along the path) before the spline fit."""
    smoothing_per_radius: float = 0.5
    """The smoothing's largest standard deviation in a bend, per metre of its radius: 2.5 m
    everywhere pulled the path 0.3 m inside a 3 m bend (a rules-minimum hairpin) onto the inner
    cones, while 1 m everywhere kept the zig-zag of gates far apart along the track."""
    baseframe_step_m: float = 0.25
    centre_on_cones: bool = True
    max_centring_shift_m: float = 2.0

    # Track model and racing line (closed laps)
    racing_line: bool = True
    """Race on the minimum-curvature line inside the mapped boundaries (else the centreline)."""
    track_step_m: float = 1.0
    """Spacing of the track model's centreline samples."""
    track_max_lateral_m: float = 6.0
    """Cones farther than this from the guide path belong to no boundary."""
    cone_radius_m: float = 0.15
    """Base radius of the largest cone (285 mm base): contact is a car body this close."""
    racing_margin_m: float = 0.4
    """Room the racing line leaves between the car's body and a cone's base: tracking plus
    localisation error."""
    racing_line_smoothing_m: float = 1.0
    racing_line_background: bool = False
    """Build the racing line in a process of its own and drive the centre line until it is
    done (``drive``: the planner's loop does not stop for a second); off in simulation, which
    then stays the same from one run to the next."""

    # Manoeuvres (seed 002, 3.2.2)
    offsets_max_m: float = 1.5
    offsets_count: int = 13
    horizon_time_s: float = 0.8
    horizon_min_m: float = 6.0
    horizon_max_m: float = 20.0
    extension_m: float = 12.0
    """Length the chosen offset is held along the baseframe beyond the horizon (for look-ahead)."""
    late_cover_s: float = 0.5
    """A manoeuvre also reaches as far as the car drives in this long (s) plus the controlled
    stop a late plan must leave room for (``controller.safety.late_stop_distance_m``, handed in
    by Main): a plan this late still covers a stop, so the car follows it, slower, instead of
    stopping (issue 19: under load a plan is 0.2-0.25 s old at times)."""
    path_step_m: float = 0.5
    far_conflict_stop: bool = True
    """With no candidate clear all along: take one whose only conflict (a cone nearer than the
    margin, a bend beyond the steering's limit) lies beyond the car's commitment (the horizon,
    and a late plan's stop), its targets standing before it, instead of the slower fallbacks.
    Only with colours on the cones ahead: without, a conflict ahead is the sign the lane was
    guessed wrong."""
    stitch_tolerance_m: float = 0.0
    """A new manoeuvre starts from the previous one's offset and slope at the car's arc length
    when the car is within this of it (0: always from the car's pose and heading)."""
    cone_clearance_m: float = 0.2
    """Hard limit: a cone's centre at least this far from the circles covering the car's body,
    at every point of a candidate (a cone's base radius plus a few centimetres)."""
    cone_clearance_near_m: float = 0.15
    """Hard limit at the car's own position (it is already there): a cone's base radius."""
    cone_clearance_per_mps: float = 0.03
    """While exploring, the hard limit ``cone_clearance_m`` of the manoeuvres with the full
    margin grows by this (m) per m/s the car drives faster than ``cone_clearance_speed_mps``
    (0.35 m at 13 m/s, 0.38 m at the exploring cap; the mapped laps' racing line keeps its
    own ``racing_margin_m``, the acceleration run its lane's middle at 25 m/s):
    the car follows a plan to 2-3 cm, but each plan starts where the last left the car, and a
    lane that one plan takes at the hard limit the next may take tighter still. Without it,
    FSSIM's 'thin' was taken at 12-13 m/s (autocross, seed 1, exploring at up to 14 m/s)
    by manoeuvres passing a cone at the 0.2 m limit, and the car hit it. A lane with less
    room falls to the slower fallback families."""
    cone_clearance_speed_mps: float = 8.0
    """The speed (m/s) above which the hard limit grows (``cone_clearance_per_mps``)."""
    clearance_ramp_m: float = 4.0
    """The margin grows from the near to the full value over this distance along a candidate
    (or over the distance driven in ``clearance_ramp_time_s``, whichever is longer)."""
    clearance_ramp_time_s: float = 0.6
    curvature_limit_fraction: float = 0.95
    """Candidates whose curvature exceeds this fraction of tan(max_steer)/wheelbase are dropped."""
    weight_curvature: float = 0.2
    """The baseframe is the racing line: a candidate's own curvature counts little."""
    weight_offset: float = 2.0
    weight_consistency: float = 1.0
    weight_clearance: float = 20.0
    preferred_clearance_m: float = 0.45
    """Room (cone centre to the car's body) below which a candidate pays a cost: the cone's
    radius plus the racing margin."""
    offsets_wide_max_m: float = 2.5
    offsets_wide_count: int = 41
    """The widened search when no configured offset is feasible."""
    exploration_speed_mps: float = 14.0
    """Top speed (m/s) while exploring an unseen track from its cones: a sanity cap. Below it,
    what sets the pace is being able to stop within the track seen so far
    (``exploration_late_cover_s`` and the supervisor's stop; :mod:`planner.exploration_speed`),
    the friction circle and the steering on the path; with the track seen 17-19 m ahead
    and the supervisor's stop at 8 m/s^2 the invariant alone allows about 13 m/s on a
    straight. At 14 m/s FSSIM's community layout 'thin' (autocross, seed 1) hit a cone at
    12-13 m/s, passed by the chosen manoeuvres at the hard clearance, until that clearance
    grew with the speed (``cone_clearance_per_mps``); before, 12 m/s had been kept for it
    (at 15 m/s two cones where its infield runs close beside the lane)."""
    exploration_speed_lead_s: float = 0.75
    """While exploring, the limit of being able to stop within the track seen is asked this
    long (s) of driving ahead of where it holds (the controller's ``speed_preview_s``: it
    reads the speed that far ahead), at most ``exploration_speed_lead_max_m``
    (:mod:`planner.exploration_speed`). 0.75 s: its preview (0.25 s) and the span its
    feedforward reads the slope over (0.5 s). FSG autocross seed 1: 49.7 s at 0 (the car
    braked all the time for an end of the track that moves on), 42.8 s at 0.75."""
    exploration_speed_lead_max_m: float = 12.0
    """The lead's longest (m): 0.75 s at 16 m/s. At 8 m (0.75 s at 10.7 m/s) the controller
    read a stop's slope beyond the lead at the 12 m/s the invariant allows, and braked."""
    exploration_curvature_window_m: float = 0.0
    """While exploring, the path's curvature sets its speed without its peaks narrower than
    this (m): the kinks of a path through cones seen partly, not its bends
    (:func:`planner.exploration_speed.speed_curvature`). 0: off. At 1.5 m FSG's autocross
    took 41.4 s instead of 42.8 s (seed 1), but hard:hairpins hit 2 cones (0 at 0 m)."""
    exploration_rate_sigma_m: float = 1.5
    """While exploring, the path's curvature is smoothed over this (m, a Gaussian's standard
    deviation) for the steering rate's speed limit alone
    (:func:`planner.exploration_speed.exploring_curvature`): the rate is the curvature's slope,
    which the kinks of a path through cones seen partly make steep. Autocross seed 1, at 0 ->
    1.5: FSG 42.9 -> 39.7 s, peanut 19.2 -> 15.9 s, small_oval 14.5 -> 13.3 s."""
    exploration_late_cover_s: float = 0.3
    """While exploring, the speed leaves room, before the end of the track known so far, for
    this long (s) of driving on plus the controlled stop a late plan must leave room for (the
    safety supervisor's rule): a plan this late still covers a stop. At least the supervisor's
    ``plan_timeout_s`` (0.2 s): a plan younger than that is followed at speed. 0.3 s rides out
    a planner that stalls for 0.4 s just as the end of the track in view stops moving on
    (``tests/test_exploring_stop.py``); at 0.2 s a stall of 0.25 s there ended the run ("plan
    too old"), for 4 % less time on the generated layouts' explored laps (autocross, shared
    tracks and gen:1..20, seeds 1-3: median 1.673x instead of 1.725x). Measured on small_track,
    seed 3, before issue 45: the exploration lap 20.2 s with no such room, 22.2 s with the stop
    alone, 24.3 s with 0.3 s (``bench load`` met plans 0.21-0.23 s late while exploring)."""
    exploration_start_m: float = 1.0
    """While exploring, the path's curvature over its first metres (from the car to the middle
    of the track) does not set the speed profile; the manoeuvre's own curvature is checked.
    Short: the path starts at the gate beside the car, and a bend that begins a few metres
    ahead (the community layouts 'thin', 'small_track_2') must slow the car (3 m hit a cone)."""
    exploration_lateral_safety_factor: float = 0.7
    """While exploring, the fraction of the car's lateral limit the profile plans with where
    the path has room (``exploration_wide_room_m``); ``lateral_safety_factor`` where it has
    the room of a lane as narrow as the rules allow (``exploration_tight_room_m``), in
    proportion between (:func:`planner.exploration_speed.room_lateral_factor`). 0.7
    everywhere took the community layouts' explored laps from 1.422x to 1.384x (autocross,
    seeds 1-3, all clean), but in EPFL's 3 m lanes it hit a cone (track 4 seed 1, running
    wide out of a bend at 9.5 m/s) and ran no faster. Graded by the room: 1.382x, EPFL's
    1.502x -> 1.506x, all clean (``docs/driving.md``, "Cornering by the room")."""
    exploration_wide_room_m: float = 1.5
    """The room (m, :func:`planner.exploration_speed.passage_room_m`) from which the exploring
    profile plans with ``exploration_lateral_safety_factor``: about a 3.4 m lane's middle."""
    exploration_line_room_m: float = 1.5
    """While exploring, the frame is the least curved line through the cones seen that keeps
    this much room (m, :func:`planner.exploration_speed.passage_room_m`) where the lane has it
    (:mod:`planner.seen_line`), the gates' path elsewhere; 0: the gates' path everywhere. At
    1.5 (``exploration_wide_room_m``) issue 45's 141 autocross runs' 81 outside the generated
    layouts went from a median 1.405x to 1.32x of the friction limit, FSG from 1.29x to 1.21x,
    the outside layouts' seeds 4-8 from 1.399x to 1.338x, all clean. It is built only while
    the map holds a coloured cone (:func:`planner.gate_search.has_colours`, as the
    colour-blind exploring path is chosen): with the camera dead EUFS Hairpin seeds 2-3, which
    stop either way, touched a cone on it first (``docs/driving.md``)."""
    exploration_tight_room_m: float = 1.1
    """The room (m) up to which it plans with ``lateral_safety_factor``: the middle of the
    rules' narrowest lane (3 m between cone centres) has 1.08 m."""
    exploration_narrow_room_m: float = 0.8
    """While exploring, the path is a narrow passage where it could move less than half this
    (m) to one side before the car's body comes within the manoeuvres' full margin of a cone
    (:func:`planner.exploration_speed.passage_room_m`): driven at no more than
    ``exploration_narrow_speed_mps``. On the middle of a straight lane with cone centres
    2.72 m apart the room is 0.8 m, in the rules' narrowest (3 m) 1.08 m. 0: off."""
    exploration_narrow_speed_mps: float = 6.0
    """The speed (m/s) of a narrow passage while exploring: a manoeuvre passes its cones with
    little more than a cone's margin, and at speed in a bend the car follows its path to
    0.1-0.3 m (EUFS small_track_2's 2.5 m wide bend and its exit hit their outer cones at
    6.5-8.5 m/s). Applied on every plan, whatever cones the map holds. Autocross on
    small_track_2, epfl_21_05_2023 and EPFL Vaudoise, seeds 1-3, least clearance and median
    lap: 5 m/s 0.061 m, 16.6 s; 6 m/s 0.057 m, 15.8 s; 6.5 m/s 0.010 m (Vaudoise seed 3),
    15.5 s. (Before: 5 m/s only while the camera's tentative cones were in the map: 0.008 m,
    15.6 s.)"""
    loop_through_start_m: float = 3.0
    """While exploring, a loop found in the cones is the track only when it passes this near
    the start (m): a loop of part of the track (one lobe of a figure-like layout, closed
    through another stretch's cones) is not."""
    loop_unseen_max_m: float = 5.0
    """While exploring, a loop found in the cones is the track only when the car has driven
    all but this much of its length (m): earlier, a loop through cones seen across the track
    (a narrow waist, an infield) cuts a bend whose outer side is not mapped yet. And the loop
    is raced at once, on a map whose loop is not closed yet: with cones mapped 14-15 m ahead
    (issue 45), 15 m let FSG's trackdrive race its last 15 m of the explored lap on the drifted
    map (0.27 m off the start's cones) and hit the start line's cones (1 lap, seeds 8-13:
    1 of 6 clean at a 15 m/s exploring cap; 6 of 6 at 5 m)."""
    loop_off_driven_max_m: float = 2.5
    """While exploring, a loop found in the cones is the track only when it strays no further
    than this (m) from the way the car drove: the car explored through the gates' middles
    (:meth:`planner.explored_lap.ExploredLap.loop_off_driven_m`). Measured: the track's loop
    0.5-1.1 m on FSG and FSSIM FSI, 2.1-2.2 m on EUFS Hairpin (the car swings wide of a hairpin
    at the steering lock); loops that were not the track (gates paired across a bend's inside,
    whose racing line then met a cone: a safe stop for 'no feasible path' in the next lap)
    2.7 m (FSI, seed 1) and 5.8 m (FSG after a camera outage). At 2 m Hairpin's track was
    refused and its mapped laps driven at exploring pace (best lap 1.43x instead of 1.12x)."""
    start_line_search_m: float = 15.0
    """Big orange cones this near the start (m) mark the start line of an explored track."""
    lap_min_m: float = 15.0
    """While exploring, a crossing of the start line is a lap only this far (m) past the last
    crossing or the start: the crossing of a car that starts behind the line starts the lap."""
    fallback_speed_mps: float = 4.0
    """Speed cap of the short-horizon manoeuvres tried last."""
    fallback_hold_s: float = 0.0
    """After a plan that brakes for a fallback (a capped manoeuvre or a stop) with the car above
    ``fallback_speed_mps``, the plans of the next this many seconds (s) ask no more speed than
    the car had then (nor less than ``fallback_speed_mps``): a fallback says the way ahead is
    in doubt, and the plan after it, clear again, would otherwise drive the car back to full
    speed between two fallbacks' brakings. 0: off."""
    crawl_speed_mps: float = 2.0
    """Speed cap (m/s) of the last resort, candidates with only the cone's radius to spare: at
    walking pace the car turns as the kinematic bicycle and follows its path closely."""
    cone_search_radius_m: float = 30.0

    # Speed profile
    speed_mode: Literal["profile", "two_level"] = "profile"
    friction_safety_factor: float = 0.7
    """Fraction of the car's drive and brake limits the profile plans with."""
    lateral_safety_factor: float = 0.6
    """Fraction of the car's lateral limit the profile plans with: the tyres' response flattens
    towards the limit, and the steering needs room left to correct the car."""
    steer_rate_fraction: float = 0.5
    """Fraction of the car's steering rate the profile lets the path's curvature changes use
    (the rest corrects the car)."""
    understeer_rad_per_mps2: float = 0.004
    """The car's understeer (extra steering per lateral acceleration) for that limit."""
    steer_lock_fraction: float = 0.95
    """Fraction of the car's steering lock the profile lets a bend and the understeer use (the
    rest corrects the car); a bend tighter than that is driven at ``crawl_speed_mps``."""
    max_speed_mps: float = 18.0
    two_level_fast_mps: float = 8.0
    two_level_slow_mps: float = 4.0
    two_level_turn_rad: float = 0.35
    """Two-level mode: slow when the baseframe turns by more than this over the preview."""
    two_level_preview_m: float = 10.0
    min_plan_speed_mps: float = 1.0

    # Acceleration and skidpad: paths known from the rules' geometry (planner/known_path.py)
    acceleration_length_m: float = 75.0
    """Start line to finish line of the acceleration event (FS rules D5)."""
    acceleration_stop_after_finish_m: float = 20.0
    """The car stands this far (m) past the acceleration finish line (nearer when a cone
    across the lane is mapped before it): inside the shortest run-off of the layouts at hand
    (EUFS: 25 m to its closing cones; the rules allow more)."""
    acceleration_lane_width_m: float = 3.0
    """Nominal lane width (m): the path keeps half of it from a lane with one side mapped."""
    acceleration_max_speed_mps: float = 25.0
    """Top speed (m/s) on the acceleration straight (``max_speed_mps`` caps the rest)."""
    skidpad_inner_diameter_m: float = 15.25
    """Inner diameter of the skidpad circles (FS rules D4)."""
    skidpad_lane_width_m: float = 3.0
    """Width of the skidpad's lane between the inner and outer circle (FS rules D4)."""
    skidpad_lateral_safety_factor: float = 0.8
    """Fraction of the car's lateral limit the skidpad's profile plans with (the others:
    ``lateral_safety_factor``): the circles are steady cornering, which the controller's
    understeer table was measured on, with two changes of direction only."""
    skidpad_stop_after_centre_m: float = 15.0
    """The car stands this far (m) past the skidpad's centre gate in the exit lane (nearer
    when a cone across the lane is mapped before it)."""
    mission_end_clearance_m: float = 2.0
    """The car's front stops this far (m) short of a cone across the lane ahead (the path
    runs on past the stop, and the manoeuvres along it must clear that cone)."""
    mission_done_speed_mps: float = 0.5
    """A known-path mission is over when the car is past its finish and this slow."""

    # Laps
    lap_min_fraction: float = 0.5
    """A start-line crossing counts as a lap only after this fraction of a lap of travel."""
    projection_window_m: float = 15.0
