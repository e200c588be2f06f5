"""The link between drive's two processes, and the health the control process builds."""

from __future__ import annotations

import math
import threading
from typing import Any

import numpy as np

from common.messages import Health, PoseEstimate, SourceHealth
from orchestrator.live import merge_health
from orchestrator.live_link import Link, link_pair

TIMEOUTS_S = {"gps": 0.5, "imu": 0.1, "can": 0.1, "lidar": 0.3, "camera": 0.3}


def test_messages_arrive_whole_and_in_order() -> None:
    a, b = link_pair()
    sender, receiver = Link(a), Link(b)
    pose = PoseEstimate(1.5, 2.0, -3.0, 0.25, 7.0, covariance=np.eye(3) * 0.01)
    big = np.arange(300_000, dtype=np.float64)  # 2.4 MB: many socket reads
    for message in (("pose", pose, True, 12), ("big", big), ("stop",)):
        assert sender.send_nowait(message)
    got: list[Any] = []
    for _ in range(10_000):  # the sender's outbox drains as the receiver reads
        sender.flush()
        got.extend(receiver.recv(0.01))
        if len(got) == 3:
            break
    assert got[0][0] == "pose" and got[0][1].x_m == 2.0 and got[0][2] is True
    np.testing.assert_array_equal(got[0][1].covariance, pose.covariance)
    np.testing.assert_array_equal(got[1][1], big)
    assert got[2] == ("stop",)
    assert receiver.received == 3 and sender.sent == 3 and sender.dropped == 0


def test_send_nowait_never_waits_for_a_reader_that_stopped() -> None:
    a, b = link_pair()
    sender = Link(a, max_outbox_bytes=1 << 20)
    payload = b"x" * 100_000
    sent = sum(sender.send_nowait(("tick", payload)) for _ in range(100))  # 10 MB, never read
    assert sent < 100
    assert sender.dropped == 100 - sent
    assert not sender.closed
    b.close()


def test_a_peer_that_is_gone_closes_the_link() -> None:
    a, b = link_pair()
    left, right = Link(a), Link(b)
    right.send(("error", "mapper: boom"))
    right.close()
    assert left.recv(1.0) == [("error", "mapper: boom")]
    assert left.poll() == []
    assert left.closed
    assert not left.send_nowait(("tick",))
    assert not left.send(("tick",))


def test_recv_returns_empty_after_its_timeout() -> None:
    a, b = link_pair()
    assert Link(b).recv(0.05) == []
    a.close()


def test_blocking_sends_from_several_threads_do_not_interleave() -> None:
    a, b = link_pair()
    sender, receiver = Link(a), Link(b)

    def send(tag: int) -> None:
        for i in range(200):
            sender.send((tag, i, bytes(5000)))

    threads = [threading.Thread(target=send, args=(t,)) for t in range(3)]
    for t in threads:
        t.start()
    got: list[tuple[int, int, bytes]] = []
    while len(got) < 600:
        got.extend(receiver.recv(1.0))
    for t in threads:
        t.join()
    for tag in range(3):
        assert [i for g, i, _ in got if g == tag] == list(range(200))


def _source(t_s: float, name: str, age_s: float, stale: bool | None = None) -> SourceHealth:
    """A source as the reporting process judged it (by default: stale past its timeout)."""
    if stale is None:
        stale = age_s > TIMEOUTS_S.get(name, math.inf)
    return SourceHealth(t_s, name, True, 10.0, age_s, 0, stale)


def test_merged_health_ages_the_remote_report_to_now() -> None:
    own = Health(10.0, (_source(10.0, "can", 0.004), _source(10.0, "res", 0.05)))
    remote = Health(9.95, (_source(9.95, "gps", 0.02), _source(9.95, "imu", 0.004),
                           _source(9.95, "lidar", 0.1), _source(9.95, "camera", 0.01)))
    merged = merge_health(10.0, own, remote, ("gps", "imu", "lidar", "camera"), TIMEOUTS_S)
    assert [s.source for s in merged.sources] == ["gps", "imu", "can", "res", "lidar", "camera"]
    by = {s.source: s for s in merged.sources}
    assert math.isclose(by["imu"].age_s, 0.054) and not by["imu"].stale
    assert math.isclose(by["lidar"].age_s, 0.15) and not by["lidar"].stale
    assert by["can"] is own.sources[0]
    # the executive process stalls: with no grace the same report 80 ms later makes the IMU
    # stale; with a grace of 0.4 s only once the report is that much later still
    later = merge_health(10.08, own, remote, ("gps", "imu", "lidar", "camera"), TIMEOUTS_S)
    assert later.stale_sources() == ("imu",)
    graced = merge_health(10.08, own, remote, ("gps", "imu", "lidar", "camera"), TIMEOUTS_S,
                          report_grace_s=0.4)
    assert graced.stale_sources() == ()
    lost = merge_health(10.5, own, remote, ("gps", "imu", "lidar", "camera"), TIMEOUTS_S,
                        report_grace_s=0.4)
    assert "imu" in lost.stale_sources()


def test_a_report_that_a_sensor_is_silent_counts_at_once_whatever_the_grace() -> None:
    own = Health(10.0, (_source(10.0, "can", 0.004), _source(10.0, "res", 0.05)))
    remote = Health(10.0, (_source(10.0, "imu", 0.5), _source(10.0, "lidar", 0.05)))
    merged = merge_health(10.0, own, remote, ("imu", "lidar"), TIMEOUTS_S, report_grace_s=0.4)
    assert merged.stale_sources() == ("imu",)


def test_a_report_of_a_late_reader_is_not_a_silent_sensor_within_the_grace() -> None:
    # The executive's IMU reader was itself late (its process busy): its last reading is
    # 0.15 s old but the report does not call the IMU stale (the reader did not see it silent).
    own = Health(10.0, (_source(10.0, "can", 0.004), _source(10.0, "res", 0.05)))
    remote = Health(10.0, (_source(10.0, "imu", 0.15, stale=False),))
    merged = merge_health(10.0, own, remote, ("imu",), TIMEOUTS_S, report_grace_s=0.4)
    assert merged.stale_sources() == ()
    # ... but the age still counts against the report's grace
    later = merge_health(10.4, own, remote, ("imu",), TIMEOUTS_S, report_grace_s=0.4)
    assert later.stale_sources() == ("imu",)


def test_merged_health_before_any_report_is_stale() -> None:
    own = Health(1.0, (_source(1.0, "can", 0.004), _source(1.0, "res", 0.05)))
    merged = merge_health(1.0, own, None, ("imu", "lidar"), TIMEOUTS_S)
    assert merged.stale_sources() == ("imu", "lidar")
    assert all(math.isinf(s.age_s) for s in merged.sources if s.source in ("imu", "lidar"))
