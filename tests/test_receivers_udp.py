"""UDP receivers on loopback: real VLP-16 packets, camera datagrams, truncated and garbage ones."""

from __future__ import annotations

import collections
import socket
import struct
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from common.clock import RealClock
from common.errors import DecodeError
from common.messages import CameraCones, ConeColour, ConeDetection, RawBytes
from orchestrator.config import AppConfig
from sensors.udp_receiver import UdpReceiver, camera_receiver, lidar_receiver
from support.shared_data import shared_path

PCAP = shared_path("lidar", "velodyne_vlp16.pcap")
FAST = dict(read_timeout_s=0.02, reconnect_min_s=0.02, reconnect_max_s=0.1)


def wait_for(condition: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


def pcap_udp_payloads(path: Path, port: int) -> list[bytes]:
    """UDP payloads to ``port`` in a classic little-endian pcap of Ethernet/IPv4 frames."""
    data = path.read_bytes()
    assert data[:4] == b"\xd4\xc3\xb2\xa1"
    pos, out = 24, []
    while pos + 16 <= len(data):
        incl = struct.unpack_from("<I", data, pos + 8)[0]
        pkt = data[pos + 16:pos + 16 + incl]
        pos += 16 + incl
        if len(pkt) < 42 or pkt[12:14] != b"\x08\x00" or pkt[23] != 17:
            continue
        ihl = (pkt[14] & 0x0F) * 4
        udp = pkt[14 + ihl:]
        if struct.unpack_from(">H", udp, 2)[0] == port:
            out.append(udp[8:])
    return out


class DatagramParser:
    """Trivial parser: a datagram b'OK<n>' is a reading; b'BAD' raises DecodeError."""

    source = "camera"

    def __init__(self) -> None:
        self.rejects: collections.Counter[str] = collections.Counter()

    def feed(self, timestamp_s: float, payload: bytes) -> list[RawBytes]:
        if payload.startswith(b"BAD"):
            raise DecodeError("bad datagram")
        if not payload.startswith(b"OK"):
            self.rejects["garbage"] += 1
            return []
        return [RawBytes(timestamp_s, "camera", payload)]


def send_to(address: tuple[str, int], payloads: list[bytes], pause_every: int = 50) -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        for i, p in enumerate(payloads):
            sock.sendto(p, ("127.0.0.1", address[1]))
            if i % pause_every == pause_every - 1:
                time.sleep(0.002)  # let a loaded 2-core machine keep up


def test_udp_base_counts_garbage_and_decode_errors_and_keeps_running() -> None:
    clock = RealClock()
    receiver = UdpReceiver(clock, DatagramParser(), "127.0.0.1", 0, **FAST)
    with receiver:
        assert receiver.wait_connected(5.0)
        assert receiver.bound_address is not None and receiver.bound_address[1] > 0
        send_to(receiver.bound_address, [b"OK1", b"BAD", b"\x00\x01", b"", b"OK2",
                                         bytes(9000)])
        assert wait_for(lambda: receiver.intake.raw_count >= 6)
        raw, readings = receiver.intake.take()
        assert [r.payload for r in readings] == [b"OK1", b"OK2"]
        assert len(raw) == 6
        stats = receiver.stats(clock.now_s())
        assert stats.rejects == {"decode_error": 1, "garbage": 3}
        assert stats.errors == 0 and stats.running and stats.connected
    assert not receiver.is_alive()


def test_port_in_use_is_an_error_retried_not_a_crash() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as blocker:
        blocker.bind(("127.0.0.1", 0))
        port = blocker.getsockname()[1]
        receiver = UdpReceiver(RealClock(), DatagramParser(), "127.0.0.1", port,
                               **FAST)
        # SO_REUSEADDR lets a UDP socket share the port on Linux; either way nothing crashes
        with receiver:
            wait_for(lambda: receiver.connected.is_set() or receiver.intake.errors > 0, 2.0)
            assert receiver.is_alive()
        assert not receiver.is_alive()


@pytest.mark.shared_data("lidar/velodyne_vlp16.pcap")
def test_lidar_receiver_real_vlp16_packets_and_truncated_ones() -> None:
    packets = pcap_udp_payloads(PCAP, 2368)
    assert packets and all(len(p) == 1206 for p in packets)
    clock = RealClock()
    config = AppConfig()
    receiver = lidar_receiver(clock, config.sensors.lidar, config.car, "127.0.0.1", 0, **FAST)
    with receiver:
        assert receiver.wait_connected(5.0)
        assert receiver.bound_address is not None
        bad = [packets[0][:600], b"\xff" * 1206, b"garbage"]
        send_to(receiver.bound_address, packets + bad)
        n = len(packets) + len(bad)
        assert wait_for(lambda: receiver.intake.raw_count >= n)
        raw, _ = receiver.intake.take()
        assert [r.payload for r in raw[:len(packets)]] == packets
        stats = receiver.stats(clock.now_s())
        assert sum(stats.rejects.values()) == len(bad)
        assert stats.errors == 0
        parser = receiver.intake.parser
        assert parser.counts["packets"] == len(packets)  # type: ignore[attr-defined]
        assert receiver.is_alive()


def test_camera_receiver_with_the_project_codec() -> None:
    from sensors import camera_codec as codec
    clock = RealClock()
    receiver = camera_receiver(clock, "127.0.0.1", 0, **FAST)
    cc = CameraCones(1.25, (ConeDetection(1.25, 5.0, 1.5, ConeColour.BLUE, confidence=0.9),
                            ConeDetection(1.25, 6.0, -1.5, ConeColour.YELLOW, confidence=0.8)),
                     frame_id=7)
    with receiver:
        assert receiver.wait_connected(5.0)
        assert receiver.bound_address is not None
        good = codec.encode_camera_cones(cc)
        send_to(receiver.bound_address, [good, good[: len(good) // 2], b"\xff\x00garbage", good])
        assert wait_for(lambda: receiver.intake.raw_count >= 4)
        _, readings = receiver.intake.take()
        assert len(readings) >= 2
        first = readings[0]
        assert isinstance(first, CameraCones)
        assert [c.colour for c in first.cones] == [ConeColour.BLUE, ConeColour.YELLOW]
        assert first.cones[0].x_m == pytest.approx(5.0, abs=1e-3)
        stats = receiver.stats(clock.now_s())
        assert sum(stats.rejects.values()) >= 1
        assert receiver.is_alive()
