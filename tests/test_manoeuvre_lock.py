"""At a crawl a manoeuvre may bend to the steering's whole lock; at speed the controller keeps
5 % of it (planner/manoeuvres.py, ``ManoeuvreGenerator.curvature_limit_1pm``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from common.car import CarConfig
from planner.baseframe import SplineBaseframe
from planner.config import PlannerConfig
from planner.manoeuvres import ManoeuvreGenerator

CONFIG = PlannerConfig()
GENERATOR = ManoeuvreGenerator(CONFIG, CarConfig())
LOCK_1PM = GENERATOR.kappa_max_1pm / CONFIG.curvature_limit_fraction


def test_the_limit_is_the_whole_lock_at_a_crawl_and_95_percent_at_speed() -> None:
    crawl = CONFIG.crawl_speed_mps
    car = CarConfig()
    assert LOCK_1PM == pytest.approx(math.tan(car.max_steer_rad) / car.wheelbase_m)
    for speed in (0.0, 0.5 * crawl, crawl, -crawl):
        assert GENERATOR.curvature_limit_1pm(speed) == pytest.approx(LOCK_1PM)
    for speed in (2.0 * crawl, 3.0 * crawl, 20.0):
        assert GENERATOR.curvature_limit_1pm(speed) == pytest.approx(GENERATOR.kappa_max_1pm)
    halfway = 0.5 * (LOCK_1PM + GENERATOR.kappa_max_1pm)
    assert GENERATOR.curvature_limit_1pm(1.5 * crawl) == pytest.approx(halfway)


def test_a_bend_between_95_percent_and_the_lock_is_followed_at_a_crawl() -> None:
    """A half turn of 2.75 m radius (between the lock's 2.67 m and 95 % of it, 2.81 m) after
    a straight: at a crawl the manoeuvre on the line itself is taken; from twice the crawl
    speed on the line is too sharp, and the one taken runs outside it."""
    radius_m = 2.75
    assert GENERATOR.kappa_max_1pm < 1.0 / radius_m < LOCK_1PM
    straight = np.linspace(0.0, 10.0, 41)
    turn = np.linspace(0.0, math.pi, 60)[1:]
    points = np.r_[np.c_[straight, np.zeros_like(straight)],
                   np.c_[10.0 + radius_m * np.sin(turn), radius_m * (1.0 - np.cos(turn))]]
    frame = SplineBaseframe(points, False, resample_m=0.5, smoothing_m=0.0, step_m=0.1)
    no_cones = np.zeros((0, 2))
    for speed, on_the_line in ((CONFIG.crawl_speed_mps, True),
                               (2.0 * CONFIG.crawl_speed_mps, False)):
        cands, best = GENERATOR.generate(frame, 9.0, 0.0, 0.0, speed, no_cones, None)
        assert best >= 0
        assert (cands[best].offset_m == 0.0) == on_the_line, (speed, cands[best].offset_m)
        assert cands[best].max_curvature_1pm <= GENERATOR.curvature_limit_1pm(speed)
        if not on_the_line:  # outside the line: to the right of a left turn
            assert cands[best].offset_m < 0.0
