"""Clocks: the simulated clock moves only when told and never backwards."""

from __future__ import annotations

import threading
import time

import pytest

from common.clock import RealClock, SimClock


def test_sim_clock_advances_only_when_told() -> None:
    clock = SimClock(5.0)
    assert clock.now_s() == 5.0
    assert clock.advance(0.25) == pytest.approx(5.25)
    clock.set(7.0)
    assert clock.now_s() == 7.0
    with pytest.raises(ValueError):
        clock.set(6.0)
    with pytest.raises(ValueError):
        clock.advance(-0.1)


def test_sim_clock_sleep_until_wakes_when_advanced() -> None:
    clock = SimClock()
    woke = threading.Event()

    def sleeper() -> None:
        clock.sleep_until(1.0, timeout_s=5.0)
        woke.set()

    thread = threading.Thread(target=sleeper)
    thread.start()
    time.sleep(0.05)
    assert not woke.is_set()
    clock.advance(1.0)
    thread.join(2.0)
    assert woke.is_set()


def test_real_clock_is_monotonic_and_sleeps() -> None:
    clock = RealClock()
    t0 = clock.now_s()
    clock.sleep_until(t0 + 0.02)
    t1 = clock.now_s()
    assert t1 >= t0 + 0.02
    clock.sleep_until(t0)  # in the past: returns at once
    assert clock.now_s() >= t1
