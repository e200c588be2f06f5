"""EKF SLAM (seed 000, 5.3) on the simulator's car: one lap of FSG with loop closure, generated
loops; and the pieces."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from scipy.stats import chi2

from bench.textbook_ekf import textbook_update
from common.car import CarConfig
from common.messages import ConeColour, ConeDetection, ConeSize, ImuSample, WheelSpeeds
from mapper.config import MapperConfig
from mapper.slam.blas import limit_blas_threads
from mapper.slam.ekf_slam import EkfSlam
from mapper.slam.models import POSE_DIM, observation_model
from support import drives
from support.slam_runs import SlamRun, run_slam

limit_blas_threads(1)


@pytest.fixture(scope="module")
def fsg_run() -> SlamRun:
    """The exploration lap of FSG (the simulator's default seed) through EKF SLAM alone."""
    return run_slam(drives.drive(drives.FSG, seed=1), MapperConfig(), CarConfig())


@pytest.mark.slow
def test_fsg_lap_closes_the_loop(fsg_run: SlamRun) -> None:
    assert fsg_run.slam.loop_closed
    assert fsg_run.slam.try_close_loop()
    # Duplicates of the start area were created (no association after unseen_travel_m) and merged.
    assert fsg_run.slam.merged_on_closure >= 4


def test_fsg_map_accuracy(fsg_run: SlamRun) -> None:
    """Seeds 0-2: map RMSE 0.009-0.032 m, no false landmark, 2 of 188 cones missed (a pair the
    lap passes at the edge of the LiDAR's reach), colours 0.978-0.984 right (the camera
    mislabels 2 %; the Mapper's votes go on after the freeze)."""
    m = fsg_run.map_metrics
    assert m["rmse_m"] <= 0.05
    assert m["false_landmarks"] <= 0.02 * m["true_cones"]
    assert m["missed_cones"] <= 0.02 * m["true_cones"]
    assert m["colour_accuracy"] >= 0.97


def test_fsg_pose_accuracy(fsg_run: SlamRun) -> None:
    """The pose after each sweep: seeds 0-2 give an RMSE of 0.035-0.099 m, a heading RMSE of
    0.7-3 mrad and a final offset of 1-2 cm."""
    p = fsg_run.pose_metrics
    assert p["pose_rmse_m"] <= 0.15
    assert p["heading_rmse_rad"] <= 0.01
    assert p["final_offset_m"] <= 0.10


def test_fsg_nees_inside_the_95_percent_band(fsg_run: SlamRun) -> None:
    """Seeds 0-2 with cones mapped to 11.5 m: 0.88, 0.93, 0.99 of the steps inside the
    two-sided 95 % band; the mean NEES (0.9-1.9, below 3) says the filter errs on the cautious
    side. Mapped to 15 m (issue 45) seed 1's pose RMSE fell from 0.12 to 0.037 m and the band
    holds 0.82 of the steps: 12 % below it (cautious), 5.8 % above (as at 11.5 m, 5.6 %). With
    the camera's tentative cones the drive is faster, and with the slip noise that came with
    them (``lateral_slip_sigma_fraction`` 0.5, ``wheel_speed_sigma_fraction`` 0.02) seed 1
    holds 0.81: 11.5 % below, 7.45 % above (seeds 0 and 2: 4.5 and 5.3 % above). The filter
    must not be overconfident: at most 7.5 % above the band's top."""
    lo, hi = chi2.ppf([0.025, 0.975], 3)
    assert fsg_run.nees_in_band >= 0.80
    assert float(np.mean(fsg_run.nees_values > hi)) <= 0.075
    assert fsg_run.nees_values.mean() <= 3.0
    assert lo < fsg_run.nees_values.mean()


def test_fsg_pose_estimate_has_vehicle_frame_velocity(fsg_run: SlamRun) -> None:
    moving = np.hypot(*fsg_run.true_velocity.T) > 1.0
    assert np.count_nonzero(moving) > 200
    err = fsg_run.est_velocity[moving] - fsg_run.true_velocity[moving]
    assert float(np.sqrt(np.mean(err ** 2))) < 0.1
    pose = fsg_run.slam.pose()
    assert np.allclose(pose.covariance, pose.covariance.T)


@pytest.mark.parametrize("seed", [0, 5, 11])
@pytest.mark.slow
def test_loop_closure_on_generated_tracks(seed: int) -> None:
    run = run_slam(drives.drive(f"gen:{seed}", seed=seed), MapperConfig(), CarConfig())
    assert run.slam.loop_closed
    assert run.map_metrics["false_landmarks"] <= 0.02 * run.map_metrics["true_cones"]
    assert run.map_metrics["rmse_m"] <= 0.15


# ---------------------------------------------------------------------------------------------
# Pieces
# ---------------------------------------------------------------------------------------------


def _filter_with_landmarks(lm_xy: np.ndarray, sigma_m: float = 0.05) -> EkfSlam:
    slam = EkfSlam(MapperConfig(), CarConfig())
    n = POSE_DIM + 2 * lm_xy.shape[0]
    x = np.zeros(n)
    x[POSE_DIM:] = lm_xy.ravel()
    p = np.eye(n) * sigma_m ** 2
    p[2, 2] = 1e-6
    slam.load_state(x, p)
    return slam


def _det(x: float, y: float, size: ConeSize = ConeSize.SMALL) -> ConeDetection:
    return ConeDetection(0.0, x, y, size=size)


def test_batched_update_equals_the_textbook_update() -> None:
    rng = np.random.default_rng(1)
    lm = rng.uniform(-10, 10, (12, 2))
    slam = _filter_with_landmarks(lm)
    n = slam.x.size
    b = rng.normal(0, 0.02, (n, n))
    p0 = b @ b.T + np.eye(n) * 1e-3
    x0 = slam.x.copy()
    x0[:5] = [0.3, -0.2, 0.1, 5.0, 0.5]
    slam.load_state(x0, p0)
    idx = np.array([1, 4, 7, 9])
    z = observation_model(x0[:3], lm[idx])[0] + rng.normal(0, 0.02, (4, 2))
    r = np.tile(np.diag([4e-4, 9e-4]), (4, 1, 1))
    assert slam.update_landmarks(z, r, idx)
    for form in ("joseph", "simple"):
        x_ref, p_ref = textbook_update(x0, p0, z, r, idx, form)
        assert np.max(np.abs(slam.x - x_ref)) < 1e-9
        assert np.max(np.abs(slam.P - p_ref)) < 1e-9
    assert np.array_equal(slam.P, slam.P.T)


def test_preliminary_list_needs_a_second_sighting() -> None:
    slam = EkfSlam(MapperConfig(), CarConfig())
    slam.update_cones([_det(6.0, 2.0), _det(8.0, -3.0)], 0.0)
    assert slam.n_landmarks == 0 and len(slam.preliminary_xy_m) == 2
    # Only the first is seen again; the second (a false cone) is forgotten.
    slam.update_cones([_det(6.01, 2.0), _det(3.0, 5.0)], 0.1)
    assert slam.n_landmarks == 1
    assert np.allclose(slam.landmarks_xy_m[0], [6.01, 2.0], atol=0.02)
    slam.update_cones([_det(6.0, 2.0)], 0.2)
    assert slam.n_landmarks == 1


def test_global_assignment_and_gating() -> None:
    slam = _filter_with_landmarks(np.array([[5.0, 1.0], [5.0, -1.0], [10.0, 0.0]]), 0.02)
    # Two detections near the first two landmarks, one far from everything (a new candidate).
    n = slam.update_cones([_det(5.02, 0.99), _det(4.98, -1.01), _det(7.5, 4.0)], 0.0)
    assert n == 2
    assert slam.n_landmarks == 3 and len(slam.preliminary_xy_m) == 1
    # A detection between landmarks but outside every gate is neither associated nor new.
    before = slam.stats["cones_ambiguous"]
    assert slam.update_cones([_det(5.0, 0.3)], 0.0) == 0
    assert slam.stats["cones_ambiguous"] == before + 1 and len(slam.preliminary_xy_m) == 0


def _beside_a_small_landmark(size: ConeSize) -> EkfSlam:
    """A filter with one landmark seen as a small cone, after two sweeps that also see a cone
    of ``size`` 0.7 m beside it."""
    slam = _filter_with_landmarks(np.array([[8.0, 2.0]]), 0.02)
    assert slam.update_cones([_det(8.0, 2.0)], 0.0) == 1  # its size: small, by vote
    for t_s in (0.1, 0.2):
        slam.update_cones([_det(8.0, 2.0), _det(8.0, 2.7, size)], t_s)
    return slam


def test_a_big_cone_beside_a_small_landmark_is_a_cone_of_its_own() -> None:
    """The start line's big cones stand 0.6-0.9 m from the lane's small ones (EPFL's layouts).
    A detection that near a landmark of the other size class is a new cone; one of the same
    size stays ambiguous (``new_landmark_min_distance_m``)."""
    big = _beside_a_small_landmark(ConeSize.LARGE)
    assert big.n_landmarks == 2
    assert np.allclose(big.landmarks_xy_m[1], [8.0, 2.7], atol=0.05)
    small = _beside_a_small_landmark(ConeSize.SMALL)
    assert small.n_landmarks == 1
    assert small.stats["cones_ambiguous"] == 2


def test_landmarks_unseen_for_long_are_not_associated() -> None:
    slam = _filter_with_landmarks(np.array([[5.0, 0.0]]), 0.02)
    slam.odometer_m = slam.cfg.unseen_travel_m + 1.0
    assert slam.update_cones([_det(5.0, 0.0)], 0.0) == 0
    assert len(slam.preliminary_xy_m) == 1


def test_merge_deletes_rows_and_columns() -> None:
    slam = _filter_with_landmarks(np.array([[5.0, 0.0], [9.0, 3.0], [5.05, 0.02]]), 0.05)
    ids_before = slam.cone_map().ids.tolist()
    slam.merge_landmarks(np.array([0]), np.array([2]))
    assert slam.n_landmarks == 2 and slam.P.shape == (9, 9)
    assert slam.cone_map().ids.tolist() == ids_before[:2]
    # Equal weights: the merged landmark lies between the two.
    assert np.allclose(slam.landmarks_xy_m[0], [5.025, 0.01], atol=1e-3)
    assert np.all(np.linalg.eigvalsh(slam.P) > 0)


def _start_with_big_cones(new_xy: np.ndarray, car_x_m: float, car_yaw_rad: float = 0.0
                          ) -> EkfSlam:
    """A filter a lap after the start: the start's four big orange cones mapped long ago (two
    rows 2.6 m apart, FSG's layout) and ``new_xy`` mapped again just now, 0.3 m off by drift;
    the car, which started heading +x, now at ``car_x_m`` on the x axis heading
    ``car_yaw_rad``."""
    old_xy = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5], [9.55, -2.5]])
    slam = _filter_with_landmarks(np.vstack([old_xy, new_xy + [0.3, 0.1]]), 0.1)
    assert not slam.try_close_loop()  # at the start, heading +x
    x = slam.x.copy()
    x[0] = car_x_m
    x[2] = car_yaw_rad
    slam.load_state(x, slam.P)
    slam.odometer_m = 300.0
    book = slam.book
    book.first_seen_m[:4] = book.last_seen_m[:4] = 0.0
    book.first_seen_m[4:] = book.last_seen_m[4:] = 298.0
    book.size_votes[:, int(ConeSize.LARGE)] = 5.0
    return slam


def test_loop_closes_on_an_unambiguous_part_of_the_start_pattern() -> None:
    # Three of the four big cones mapped again: no other shift pairs three, so the loop closes
    # although the car has not passed the old cones yet.
    three = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5]])
    slam = _start_with_big_cones(three, car_x_m=2.0)
    assert slam.try_close_loop()
    assert slam.merged_on_closure >= 3 and slam.n_landmarks == 4


def test_loop_waits_while_the_start_pattern_is_ambiguous() -> None:
    # One row of two: a shift of one row (2.6 m) pairs them as well as the true one. Wait
    # until the old cones are behind the car; then the smaller drift wins.
    row = np.array([[6.95, 2.5], [6.95, -2.5]])
    slam = _start_with_big_cones(row, car_x_m=2.0)
    assert not slam.try_close_loop()
    slam = _start_with_big_cones(row, car_x_m=10.0)
    assert slam.try_close_loop()
    assert np.allclose(slam.landmarks_xy_m[:2], [[7.1, 2.55], [7.1, -2.45]], atol=0.05)


def test_loop_does_not_close_on_big_cones_far_behind_the_car() -> None:
    # The start's big cones mapped again from another stretch (across the infield): on the
    # car's line of travel but 20 m behind it, the car is not arriving at the start line.
    three = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5]])
    slam = _start_with_big_cones(three, car_x_m=30.0)
    assert not slam.try_close_loop()
    slam = _start_with_big_cones(three, car_x_m=7.25 + slam.cfg.big_cone_behind_max_m - 1.0)
    assert slam.try_close_loop()


def test_loop_does_not_close_on_big_cones_passed_heading_the_other_way() -> None:
    # The start's big cones mapped again from a stretch beside the start that runs back the
    # other way (a hairpin's straights side by side): near the car's line of travel and just
    # behind it, but the car does not cross the start line the way it left it.
    three = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5]])
    slam = _start_with_big_cones(three, car_x_m=4.0, car_yaw_rad=math.pi)
    assert not slam.try_close_loop()
    slam = _start_with_big_cones(three, car_x_m=4.0, car_yaw_rad=0.5 * math.pi)
    assert not slam.try_close_loop()  # across the start line: a crossing stretch
    slam = _start_with_big_cones(three, car_x_m=4.0, car_yaw_rad=0.3)
    assert slam.try_close_loop()  # arriving, a little askew


def _closure_with_twins(gap_m: float, twin_sigma_m: float | None = None) -> EkfSlam:
    """A filter a lap after the start, the car arriving at the start's four big cones (three
    mapped again, 0.3 m off), with a cone 20 m on mapped twice ``gap_m`` apart: once at 100 m,
    again at 200 m, both seen since (each sure to ``twin_sigma_m``; default the filter's
    0.1 m)."""
    old_big = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5], [9.55, -2.5]])
    new_big = old_big[:3] + [0.3, 0.1]
    twins = np.array([[20.0, 3.0], [20.0 + gap_m, 3.0]])
    slam = _filter_with_landmarks(np.vstack([old_big, new_big, twins]), 0.1)
    x, p = slam.x.copy(), slam.P.copy()
    x[0] = 2.0
    if twin_sigma_m is not None:
        for i in (7, 8):
            c = POSE_DIM + 2 * i
            p[c:c + 2, c:c + 2] = np.eye(2) * twin_sigma_m ** 2
    slam.load_state(x, p)
    slam.odometer_m = 300.0
    book = slam.book
    book.first_seen_m[:4] = book.last_seen_m[:4] = 0.0
    book.first_seen_m[4:7] = book.last_seen_m[4:7] = 298.0
    book.size_votes[:7, int(ConeSize.LARGE)] = 5.0
    book.first_seen_m[7:] = [100.0, 200.0]
    book.last_seen_m[7:] = 299.0  # both seen since the second was mapped
    return slam


def test_closure_merges_a_cone_mapped_twice_even_if_both_were_seen_since() -> None:
    # A cone mapped again mid-lap (seen across the infield, the old landmark unseen for
    # long), then both associated again: never-seen-together does not hold, yet 3 cm apart
    # they are one cone (two cones stand a base apart at least).
    slam = _closure_with_twins(0.03)
    assert slam.try_close_loop()
    xy = slam.landmarks_xy_m
    assert np.count_nonzero(np.hypot(xy[:, 0] - 20.0, xy[:, 1] - 3.0) < 0.1) == 1
    assert slam.n_landmarks == 5


def test_closure_drops_a_twin_nearer_than_two_cones_can_stand_that_the_gate_refuses() -> None:
    # A cone seen again from across the infield lands 8 cm from its first landmark, each
    # landmark sure to 1 cm: the merge gate refuses the pair (d^2 32), yet two cones cannot
    # stand that close. The newer is dropped; the older keeps its place, and a same-point
    # merge (which would drag both and their correlates) is not made.
    slam = _closure_with_twins(0.08, twin_sigma_m=0.01)
    slam.book.colour_votes[8, int(ConeColour.BLUE)] = 4.0
    assert slam.try_close_loop()
    xy = slam.landmarks_xy_m
    twin = np.flatnonzero(np.hypot(xy[:, 0] - 20.0, xy[:, 1] - 3.0) < 0.2)
    assert twin.size == 1 and slam.n_landmarks == 5
    assert np.allclose(xy[twin[0]], [20.0, 3.0], atol=1e-9)  # the older, where it was
    assert slam.book.colour_votes[twin[0], int(ConeColour.BLUE)] == 4.0  # the newer's votes
    assert slam.stats["duplicates_dropped"] == 1


def _short_lap(car_x_m: float, odometer_m: float, car_yaw_rad: float = 0.0) -> EkfSlam:
    """A filter on a lap so short that the start's four big cones (mapped at the start) were
    seen all the way round; a cone 20 m down the track mapped twice, the second time after the
    first went unseen for long. The car, which started heading +x, is at ``car_x_m`` heading
    ``car_yaw_rad`` after ``odometer_m`` of travel."""
    big = np.array([[6.95, 2.5], [6.95, -2.5], [9.55, 2.5], [9.55, -2.5]])
    twins = np.array([[20.0, 3.0], [20.25, 3.1]])
    slam = _filter_with_landmarks(np.vstack([big, twins]), 0.1)
    assert not slam.try_close_loop()  # at the start, heading +x
    x = slam.x.copy()
    x[0] = car_x_m
    x[2] = car_yaw_rad
    slam.load_state(x, slam.P)
    slam.odometer_m = odometer_m
    book = slam.book
    book.first_seen_m[:4] = 0.0
    book.last_seen_m[:4] = odometer_m - 1.0
    book.size_votes[:4, int(ConeSize.LARGE)] = 5.0
    book.first_seen_m[4:] = [12.0, odometer_m - 30.0]
    book.last_seen_m[4:] = [20.0, odometer_m - 20.0]
    return slam


def test_a_lap_whose_start_stays_in_view_closes_as_the_car_passes_its_big_cones() -> None:
    # EPFL's 74 m autocross: the start's big cones never go unseen, so none is old or new and
    # the pattern match cannot close the loop; without this rule the map held every cone out
    # of view for a while once more each lap (199 landmarks for 57 cones after 3 laps).
    lap_m = 74.0
    slam = _short_lap(car_x_m=10.5, odometer_m=lap_m + 10.5)
    assert slam.try_close_loop()
    assert slam.n_landmarks == 5  # the twins merged, the big cones kept
    assert np.allclose(slam.landmarks_xy_m[:4], [[6.95, 2.5], [6.95, -2.5], [9.55, 2.5],
                                                 [9.55, -2.5]], atol=1e-6)
    assert slam.stats["loop_closures_seen_through"] == 1


def test_a_short_lap_does_not_close_before_the_car_passes_the_start_the_way_it_left() -> None:
    lap_m = 74.0
    assert not _short_lap(car_x_m=5.0, odometer_m=lap_m + 5.0).try_close_loop()  # not yet
    assert not _short_lap(car_x_m=10.5, odometer_m=30.0).try_close_loop()  # too short a lap
    assert not _short_lap(car_x_m=10.5, odometer_m=lap_m + 10.5,
                          car_yaw_rad=math.pi).try_close_loop()  # passing the other way
    # passed 20 m ago: on a stretch further on, not at the start line
    assert not _short_lap(car_x_m=29.0, odometer_m=lap_m + 29.0).try_close_loop()


def test_a_short_lap_closes_beside_big_landmarks_lost_at_the_start() -> None:
    # EPFL's 74 m lap, seed 3: two small cones beside the start's big ones were taken for big
    # at the start and then lost to their neighbours' landmarks, so two "old" big landmarks
    # stand by the ones seen all the way round; the loop closes all the same.
    lap_m = 74.0
    slam = _short_lap(car_x_m=10.5, odometer_m=lap_m + 10.5)
    x, p = slam.x.copy(), slam.P.copy()
    n = slam.n_landmarks
    stale = np.array([[7.45, 2.5], [7.45, -2.5]])
    x2 = np.concatenate([x, stale.ravel()])
    p2 = np.eye(len(x2)) * 0.1 ** 2
    p2[:len(x), :len(x)] = p
    book = slam.book
    first, last = book.first_seen_m.copy(), book.last_seen_m.copy()
    votes = book.size_votes.copy()
    slam.load_state(x2, p2)
    book = slam.book
    book.first_seen_m[:n], book.last_seen_m[:n] = first, last
    book.size_votes[:n] = votes
    book.first_seen_m[n:] = 0.0
    book.last_seen_m[n:] = 5.0
    book.size_votes[n:, int(ConeSize.LARGE)] = 4.0
    assert slam.try_close_loop()
    assert slam.n_landmarks == n - 1 + 2  # the twins merged, the stale big ones kept


def test_the_seen_through_rule_leaves_a_start_that_went_out_of_view_to_the_pattern() -> None:
    # A normal lap: the start's big cones unseen for long are old; the car passing where they
    # stand does not close the loop until new big cones are mapped to pair with them.
    slam = _short_lap(car_x_m=10.5, odometer_m=300.0)
    slam.book.last_seen_m[:4] = 20.0
    assert not slam.try_close_loop()


def test_odometry_and_gps_reduce_uncertainty_and_reject_bad_input() -> None:
    slam = EkfSlam(MapperConfig(), CarConfig())
    for k in range(200):
        slam.predict(ImuSample(k * 0.005, 1.0, 0.0, 9.81, 0.0, 0.0, 0.0))
    var_v = slam.P[3, 3]
    slam.update_odometry(WheelSpeeds(1.0, 1.0, 1.0, 1.0, 1.0), None)
    assert slam.P[3, 3] < var_v
    assert slam.pose().vx_mps == pytest.approx(1.0, abs=0.05)
    slam.update_odometry(WheelSpeeds(1.0, math.nan, 1.0, math.nan, 1.0), None)
    assert slam.stats["odometry_rejected_nonfinite"] == 1
    var_x = slam.P[0, 0]
    assert slam.update_gps_xy(np.array([0.5, 0.0]), np.eye(2) * 0.01, 1.0)
    assert slam.P[0, 0] < var_x
    assert not slam.update_gps_xy(np.array([500.0, 0.0]), np.eye(2) * 0.01, 1.0)
    assert slam.stats["gps_rejected_gate"] == 1
    slam.predict(ImuSample(0.5, 0.0, 0.0, 9.81, 0.0, 0.0, 0.0))   # older than the filter
    assert slam.stats["imu_rejected_old"] == 1
    slam.update_cones([ConeDetection(1.0, math.inf, 0.0)], 1.0)
    assert slam.stats["cones_rejected"] == 1


def test_colour_votes_and_sizes_make_the_cone_map() -> None:
    slam = _filter_with_landmarks(np.array([[5.0, 2.0], [5.0, -2.0]]))
    camera = [ConeDetection(0.0, 5.1, 2.0, ConeColour.BLUE, confidence=0.9),
              ConeDetection(0.0, 5.0, -2.1, ConeColour.YELLOW, confidence=0.9),
              ConeDetection(0.0, 20.0, 0.0, ConeColour.ORANGE, confidence=0.9)]
    assert slam.add_colour_votes(camera) == 2
    # one vote of 0.9 is no lead of a full vote: the colours are not known yet
    assert slam.cone_map().colour.tolist() == [ConeColour.UNKNOWN, ConeColour.UNKNOWN]
    assert slam.add_colour_votes(camera) == 2
    slam.add_colour_votes([ConeDetection(0.0, 5.0, 2.0, ConeColour.YELLOW, confidence=0.5)])
    cones = slam.cone_map()
    assert cones.colour.tolist() == [ConeColour.BLUE, ConeColour.YELLOW]
    assert cones.covariance.shape == (2, 2, 2)
    assert np.allclose(cones.covariance[0], np.eye(2) * 0.05 ** 2)


def test_sweep_detections_are_moved_to_the_sweep_time() -> None:
    """A cone seen 50 ms before the sweep's end while driving at 8 m/s is 0.4 m closer at the
    end: the update must agree with a landmark 0.4 m closer."""
    slam = _filter_with_landmarks(np.array([[10.0, 0.0]]), 0.01)
    slam.x[3] = 8.0
    slam.P[3, 3] = 1e-6
    det = ConeDetection(-0.05, 10.4, 0.0)
    assert slam.update_cones([det], 0.0) == 1
    assert slam.x[0] == pytest.approx(0.0, abs=0.01)


@pytest.mark.parametrize("slip", [0.0, 0.002])
def test_wheel_slip_model_removes_the_launch_speed_bias(slip: float) -> None:
    """Under 5 m/s^2 the rear wheels read 1 % fast (k = 0.002): with the slip model the speed
    estimate stays unbiased, without it it follows the wheels (the odometry outweighs the
    integrated IMU)."""
    cfg = MapperConfig()
    cfg.slam.wheel_slip_per_mps2 = slip
    slam = EkfSlam(cfg, CarConfig(imu_x_m=0.0))
    accel, k_true = 5.0, 0.002
    for k in range(401):                                  # 2 s at 200 Hz, wheels at 100 Hz
        t = k * 0.005
        slam.predict(ImuSample(t, accel, 0.0, 9.81, 0.0, 0.0, 0.0))
        if k % 2 == 0 and k > 0:
            v = accel * t * (1.0 + k_true * accel)
            slam.update_odometry(WheelSpeeds(t, v, v, v, v), None)
    err = slam.pose().vx_mps - accel * 2.0
    if slip:
        assert abs(err) < 0.01
    else:
        assert err > 0.03                                  # 1 % of 10 m/s, mostly followed
    assert np.all(np.linalg.eigvalsh(slam.P) > 0)


def test_odometry_jacobian_matches_numerical() -> None:
    """The odometry update's H (slip model, lever arm, biases) against central differences."""
    slam = EkfSlam(MapperConfig(), CarConfig())
    for k in range(100):
        slam.predict(ImuSample(k * 0.005, 3.0, 2.0, 9.81, 0.0, 0.0, 0.4 + 0.001 * k))
    slam.ekf.xbuf[2:8] = [0.3, 5.0, 1.0, 0.001, 0.05, -0.03]
    got: dict[str, np.ndarray] = {}

    def capture(cols: np.ndarray, h: np.ndarray, innovation: np.ndarray, r: np.ndarray) -> bool:
        got["cols"], got["h"], got["y"] = cols, h.copy(), innovation.copy()
        return True

    def innovation(s: EkfSlam) -> np.ndarray:
        s.ekf.update_vehicle = capture  # type: ignore[method-assign]
        s.update_odometry(WheelSpeeds(float(slam.t_s or 0.0), 5.0, 5.0, 5.0, 5.0), None)
        return got["y"].copy()

    innovation(copy.deepcopy(slam))
    h, cols = got["h"], got["cols"]
    num = np.zeros_like(h)
    for j, c in enumerate(cols):
        lo, hi = copy.deepcopy(slam), copy.deepcopy(slam)
        lo.ekf.xbuf[c] -= 1e-6
        hi.ekf.xbuf[c] += 1e-6
        num[:, j] = -(innovation(hi) - innovation(lo)) / 2e-6
    assert np.allclose(num, h, atol=1e-6)
