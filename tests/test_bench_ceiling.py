"""``bench ceiling``: the explored lap's ceiling when only the track in view holds the car
back (issue 45)."""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.bench_ceiling import speed_in_view_mps, view_list
from controller.safety import late_stop_distance_m
from orchestrator.config import AppConfig
from planner.speed_profile import min_lap_time_s

ROOT = Path(__file__).resolve().parents[1]


def test_the_view_speed_leaves_exactly_the_room_in_view() -> None:
    config = AppConfig()
    late_s = config.planner.exploration_late_cover_s
    for view_m in (10.0, 17.0, 30.0):
        v = speed_in_view_mps(view_m, config)
        room = v * late_s + late_stop_distance_m(v, config.controller.safety)
        assert room <= view_m + 1e-9
        faster = v + 0.1  # the table's step is 0.05 m/s: a tenth more no longer fits
        assert faster * late_s + late_stop_distance_m(faster, config.controller.safety) > view_m


def test_more_in_view_and_a_harder_stop_allow_more_speed() -> None:
    config = AppConfig()
    speeds = [speed_in_view_mps(v, config) for v in (12.0, 16.0, 20.0, 40.0)]
    assert speeds == sorted(speeds) and speeds[0] < speeds[-1]
    harder = AppConfig()
    harder.controller.safety.stop_decel_mps2 = 12.0
    assert speed_in_view_mps(16.0, harder) > speed_in_view_mps(16.0, config)


def test_a_capped_lap_is_never_faster_than_the_friction_limit() -> None:
    config = AppConfig()
    theta = np.linspace(0.0, 2.0 * np.pi, 200, endpoint=False)
    oval = np.c_[60.0 * np.cos(theta), 25.0 * np.sin(theta)]  # straights reach the top speed
    free = min_lap_time_s(oval, config.car)
    capped = [min_lap_time_s(oval, config.car, max_speed_mps=cap) for cap in (8.0, 12.0, 40.0)]
    assert capped[0] > capped[1] > free
    assert capped[2] == pytest.approx(free)  # above the car's top speed: no cap
    # at 8 m/s a point mass corners at the cap everywhere: the lap is its length over 8
    length = float(np.sum(np.hypot(*np.diff(np.r_[oval, oval[:1]], axis=0).T)))
    assert capped[0] == pytest.approx(length / 8.0, rel=0.01)


def test_view_list_refuses_what_is_not_a_length() -> None:
    assert view_list("14, 17,20") == [14.0, 17.0, 20.0]
    for bad in ("", "0", "-3", "nan", "x"):
        with pytest.raises(argparse.ArgumentTypeError):
            view_list(bad)


def test_the_command_prints_a_row_per_track_and_the_ceiling() -> None:
    out = subprocess.run([sys.executable, "main.py", "bench", "ceiling", "--tracks",
                          "gen:1,gen:2", "--view-m", "17,60"], cwd=ROOT, capture_output=True,
                         text=True, timeout=300, check=True).stdout
    rows = [line.split() for line in out.splitlines() if line.strip().startswith("gen:")]
    assert [r[0] for r in rows] == ["gen:1", "gen:2"]
    for row in rows:
        at_17, at_60 = float(row[2]), float(row[3])
        assert at_17 > at_60 >= 1.0  # more in view, nearer the friction limit
    last = out.strip().splitlines()[-1]
    assert last.startswith("view_m=17 median_ceiling_ratio=")
    median = float(last.split("median_ceiling_ratio=")[1].split()[0])
    assert math.isclose(median, float(np.median([float(r[2]) for r in rows])), abs_tol=1e-3)
