"""bench faults: the moment it injects at and the verdict of each cell."""

from __future__ import annotations

import pytest

from bench.bench_faults import _fast_moment_s, _verdict


def test_fast_moment_is_the_first_after_the_handover() -> None:
    summary = {"handover_time_s": 10.0, "_t_s": [5.0, 9.0, 11.0, 12.0, 13.0],
               "_speed_mps": [13.0, 12.5, 8.0, 12.2, 14.0]}
    assert _fast_moment_s(summary, 12.0) == 12.0  # not 5 s or 9 s: the person was driving
    assert _fast_moment_s(summary, 20.0) is None


def _summary(**kw: object) -> dict[str, object]:
    base: dict[str, object] = {"cones_hit": 0, "off_track": 0, "laps_completed": 2,
                               "stop_reason": "finished: 2 laps", "estop": None}
    base.update(kw)
    return base


@pytest.mark.parametrize(("kind", "summary", "safe"), [
    ("gps-dropout", _summary(), True),
    ("lidar-dead", _summary(laps_completed=1, stop_reason="stale sensor: lidar"), True),
    ("lidar-dead", _summary(laps_completed=1, stop_reason="stale sensor: lidar", cones_hit=1),
     False),
    ("imu-nan", _summary(laps_completed=1, stop_reason="timeout"), False),
    ("estop", _summary(laps_completed=1, stop_reason="remote emergency stop",
                       estop={"stop_distance_m": 6.7, "allowed_distance_m": 8.4}), True),
    ("estop", _summary(laps_completed=1, stop_reason="remote emergency stop",
                       estop={"stop_distance_m": 9.0, "allowed_distance_m": 8.4}), False),
    ("estop", _summary(laps_completed=1, stop_reason="remote emergency stop"), False),
])
def test_verdict(kind: str, summary: dict[str, object], safe: bool) -> None:
    assert _verdict(kind, summary, 2)[0] is safe
