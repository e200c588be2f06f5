"""The live view's server in-process: ``--live`` addresses, nothing done without a client, and a
stalled client (connected, subscribed, never reading) never makes a write wait: what cannot be
queued is dropped and counted."""

from __future__ import annotations

import argparse
import asyncio
import json
import socket

import numpy as np
import pytest
import websockets

from common.cli_types import host_port
from common.messages import ConeMap, MapState, PoseEstimate
from recordings import topics
from recordings.live_server import LiveError, LiveServer, check_address


def _map_state(t_s: float, n_cones: int = 200) -> MapState:
    rng = np.random.default_rng(3)
    xy = rng.uniform(-30, 30, (n_cones, 2))
    cones = ConeMap(xy, np.tile(np.eye(2) * 0.01, (n_cones, 1, 1)),
                    np.ones(n_cones, dtype=int), np.ones(n_cones, dtype=int),
                    np.ones(n_cones), np.arange(n_cones))
    pose = PoseEstimate(t_s, 1.0, 2.0, 0.3, 5.0, covariance=np.eye(3) * 1e-3)
    return MapState(t_s, pose, cones, False, "test")


def test_host_port() -> None:
    assert host_port("8765") == ("127.0.0.1", 8765)
    assert host_port("0.0.0.0:9000") == ("0.0.0.0", 9000)
    assert host_port("[::1]:9000") == ("::1", 9000)
    for bad in ("", "x", "host:", ":80", "1:99999", "-1"):
        with pytest.raises(argparse.ArgumentTypeError):
            host_port(bad)


def test_port_in_use_is_a_clear_error() -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        sock.listen()
        port = sock.getsockname()[1]
        with pytest.raises(LiveError, match=f"127.0.0.1:{port}"):
            LiveServer("127.0.0.1", port)
        with pytest.raises(LiveError, match=f"127.0.0.1:{port}"):
            check_address("127.0.0.1", port)
    check_address("127.0.0.1", 0)


def test_no_client_costs_nothing() -> None:
    with LiveServer("127.0.0.1", 0) as server:
        for k in range(50):
            assert not server.write(topics.MAP_STATE, _map_state(0.1 * k), 0.1 * k)
        assert server.skipped == 50
        assert server.sent == 0
        assert server.stats()["clients_max"] == 0


async def _stalled_client(port: int, server: LiveServer, writes: int) -> list[bool]:
    async with websockets.connect(f"ws://127.0.0.1:{port}",
                                  subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                  close_timeout=0.5) as ws:
        channels: dict[str, int] = {}
        while not channels:
            message = json.loads(await ws.recv())
            if message["op"] == "advertise":
                channels = {c["topic"]: c["id"] for c in message["channels"]}
        await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": i, "channelId": cid} for i, cid in enumerate(channels.values())]}))
        while server.clients == 0:
            await asyncio.sleep(0.01)
        # From here on the client never reads again: the server's per-client backlog fills.
        state = _map_state(0.0)
        return [server.write(topics.MAP_STATE, state, 0.1 * k) for k in range(writes)]


def test_stalled_client_never_blocks_a_write() -> None:
    server = LiveServer("127.0.0.1", 0, queue_length=8, backlog=4)
    try:
        results = asyncio.run(_stalled_client(server.port, server, 2000))
    finally:
        server.close()
    stats = server.stats()
    assert stats["clients_max"] == 1
    # The publisher converts a 200-cone scene far slower than 2000 bare queue puts: the queue
    # fills and the rest is dropped, counted, instead of waiting.
    assert results.count(False) == stats["messages_dropped"] > 0
    assert results.count(True) > 0
    assert stats["messages_sent"] > 0
