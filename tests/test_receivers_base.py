"""The receiver base on a fake transport: failures are counted and retried, queues are bounded."""

from __future__ import annotations

import collections
import queue
import time
from collections.abc import Callable

from common.clock import SimClock
from common.messages import RawBytes
from sensors.receiver import Intake, RawUnit, Receiver, join_all


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.01)
    return condition()


class EchoParser:
    source = "fake"

    def __init__(self) -> None:
        self.rejects: collections.Counter[str] = collections.Counter()

    def feed(self, timestamp_s: float, data: bytes) -> list[RawBytes]:
        return [RawBytes(timestamp_s, "fake", data)]


class FlakyReceiver(Receiver):
    """Opening fails twice; every read that finds b'fail' raises like a vanished port."""

    def __init__(self, clock: SimClock) -> None:
        super().__init__("fake", clock, Intake("fake", EchoParser(), queue_length=8),
                         read_timeout_s=0.01, reconnect_min_s=0.01, reconnect_max_s=0.05)
        self.inbox: queue.Queue[bytes] = queue.Queue()
        self.open_attempts = 0

    def _open(self) -> None:
        self.open_attempts += 1
        if self.open_attempts <= 2:
            raise OSError("no such device")

    def _close(self) -> None:
        pass

    def _read(self, timeout_s: float) -> list[RawUnit]:
        try:
            data = self.inbox.get(timeout=timeout_s)
        except queue.Empty:
            return []
        if data == b"fail":
            raise TypeError("unexpected failure inside the driver")
        return [RawBytes(self.clock.now_s(), self.source, data)]


def test_open_failures_and_read_exceptions_are_counted_and_retried() -> None:
    clock = SimClock(10.0)
    receiver = FlakyReceiver(clock)
    with receiver:
        assert receiver.wait_connected(5.0)
        assert receiver.open_attempts == 3
        receiver.inbox.put(b"a")
        assert wait_for(lambda: receiver.intake.count == 1)
        receiver.inbox.put(b"fail")
        assert wait_for(lambda: receiver.reconnects == 1)
        clock.set(11.0)
        receiver.inbox.put(b"b")
        assert wait_for(lambda: receiver.intake.count == 2)
        stats = receiver.stats(11.5)
        assert stats.errors == 3  # two failed opens, one failed read
        assert stats.running and stats.connected
        assert stats.age_s == 0.5  # stamped with the Clock (SimClock here), not wall time
        _, readings = receiver.intake.take()
        assert [r.timestamp_s for r in readings] == [10.0, 11.0]
    assert not receiver.is_alive()


def test_pending_queue_is_bounded_and_drops_are_counted() -> None:
    intake = Intake("fake", EchoParser(), queue_length=8)
    for k in range(20):
        intake.ingest(RawBytes(float(k), "fake", b"%d" % k))
    raw, readings = intake.take()
    assert len(raw) == 8 and len(readings) == 8
    assert readings[0].timestamp_s == 12.0  # the oldest were dropped
    assert intake.all_rejects() == {"dropped": 12, "dropped_raw": 12}
    assert len(intake.recent) == 8
    assert intake.latest["rawbytes"].timestamp_s == 19.0


def test_wrong_unit_type_is_a_counted_parser_error() -> None:
    from common.messages import CanFrame

    intake = Intake("fake", EchoParser())
    assert intake.ingest(CanFrame(0.0, 0x100, b"")) == []
    assert intake.errors == 1 and intake.all_rejects() == {"parser_exception": 1}


def test_join_all_uses_one_deadline() -> None:
    receivers = [FlakyReceiver(SimClock()) for _ in range(5)]
    for r in receivers:
        r.start()
    t0 = time.monotonic()
    assert join_all(receivers, 1.0) == []
    assert time.monotonic() - t0 < 1.0
    assert not any(r.is_alive() for r in receivers)
