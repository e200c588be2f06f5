"""OutputHasher: same outputs, same digest (across processes); any change, another digest."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from common.messages import (
    ActuatorCommand,
    AsState,
    ConeMap,
    MapState,
    Plan,
    PoseEstimate,
    TargetStates,
)
from recordings import topics
from recordings.codec import from_proto, to_proto
from recordings.hashing import OutputHasher

PROJECT = Path(__file__).resolve().parents[1]


def outputs(seed: int = 11, nudge: float = 0.0) -> list[tuple[str, object]]:
    rng = np.random.default_rng(seed)
    out: list[tuple[str, object]] = []
    for i in range(20):
        t = 0.1 * i
        n = 5 + i
        cones = ConeMap(rng.normal(size=(n, 2)), np.tile(np.eye(2) * 0.01, (n, 1, 1)),
                        rng.integers(0, 5, n), rng.integers(0, 3, n), np.ones(n), np.arange(n))
        pose = PoseEstimate(t, 0.5 * i + nudge, 0.0, 0.01 * i, 5.0, covariance=np.eye(3) * 1e-3)
        out.append((topics.MAP_STATE, MapState(t, pose, cones, backend="ekf")))
        k = 10
        manoeuvre = TargetStates(t + np.arange(k) * 0.1, rng.normal(size=k), rng.normal(size=k),
                                 np.zeros(k), np.full(k, 5.0), np.full(k, np.nan))
        out.append((topics.PLAN, Plan(t, None, manoeuvre, 5.0)))
        out.append((topics.COMMAND, ActuatorCommand(t, 0.2, 0.0, -0.05, AsState.DRIVING)))
    return out


def digest(items: list[tuple[str, object]]) -> str:
    hasher = OutputHasher()
    for topic, message in items:
        hasher.update(topic, message)
    assert hasher.count == len(items)
    return hasher.hexdigest()


def test_same_outputs_same_hash() -> None:
    assert digest(outputs()) == digest(outputs())
    assert len(digest(outputs())) == 64


def test_hash_survives_a_round_trip_through_protobuf() -> None:
    items = outputs()
    back = [(t, from_proto(type(to_proto(m)).FromString(to_proto(m).SerializeToString())))
            for t, m in items]
    assert digest(items) == digest(back)


def test_any_change_changes_the_hash() -> None:
    base = digest(outputs())
    assert digest(outputs(nudge=1e-12)) != base
    assert digest(outputs(seed=12)) != base
    items = outputs()
    assert digest(items[:-1]) != base  # one command fewer
    swapped = items[:]
    swapped[0], swapped[1] = swapped[1], swapped[0]
    assert digest(swapped) != base  # order matters
    retopiced = [("/other" if t == topics.COMMAND else t, m) for t, m in items]
    assert digest(retopiced) != base


def test_same_hash_in_another_process() -> None:
    code = (
        "import sys; sys.path.insert(0, 'tests');"
        "from test_recordings_hashing import digest, outputs; print(digest(outputs()))"
    )
    env = dict(os.environ, PYTHONPATH=str(PROJECT), PYTHONHASHSEED="123")
    result = subprocess.run([sys.executable, "-c", code], cwd=PROJECT, env=env,
                            capture_output=True, text=True, check=True, timeout=60)
    assert result.stdout.strip() == digest(outputs())
