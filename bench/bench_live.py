"""``python main.py bench live``: what the Foxglove live view (``--live``) does to a 100 Hz control
loop's 99th-percentile period, with no client, one client reading, one stalled client (connected
and subscribed to every topic, never reading), and a reading client beside a stalled one.

The loop (in this process, like ``sim``) does a little numpy work per tick, writes the command
every tick and a 300-cone map state and a plan every 10 ticks to the live server, as Main does.
The clients run in processes of their own (``websockets``; as a laptop at the track side would).
Rounds are interleaved (none, reading, stalled, both, then the next round in another order) so
that other load on the machine falls on every case alike; each case's figure is the median of
its rounds' p99.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from typing import Any

import numpy as np

from common.cli_types import positive_int, positive_seconds
from orchestrator.config import AppConfig

HELP = "control-loop p99 period with the live view: no client, reading, stalled, both"

STALL_FILL_S = 4.0
"""Loop time (s) run before measuring with a stalled client, to fill its socket buffers."""

CASES: dict[str, tuple[str, ...]] = {
    "no client": (),
    "one client reading": ("read",),
    "one stalled client": ("stall",),
    "reading + stalled": ("read", "stall"),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--loop-seconds", type=positive_seconds, default=2.0,
                        help="length of each control-loop measurement (s)")
    parser.add_argument("--rounds", type=positive_int, default=5,
                        help="interleaved rounds of every case")


def _client(port: int, mode: str, ready: Any, stop: Any) -> None:
    """A Foxglove WebSocket client: subscribes to every channel; reads all (``read``) or never
    reads again (``stall``: the server's per-client backlog fills and drops)."""
    import asyncio
    import json
    import socket

    import websockets

    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    if mode == "stall":  # a small receive buffer: the stall reaches the server at once
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    sock.connect(("127.0.0.1", port))

    async def session() -> None:
        async with websockets.connect(f"ws://127.0.0.1:{port}", sock=sock, max_size=None,
                                      subprotocols=["foxglove.sdk.v1"],  # type: ignore[list-item]
                                      max_queue=1 if mode == "stall" else 64,
                                      close_timeout=0.2) as ws:
            channels: list[int] = []
            while not channels:
                message = await ws.recv()
                if isinstance(message, str):
                    parsed = json.loads(message)
                    if parsed["op"] == "advertise":
                        channels = [c["id"] for c in parsed["channels"]]
            await ws.send(json.dumps({"op": "subscribe", "subscriptions": [
                {"id": i, "channelId": c} for i, c in enumerate(channels)]}))
            ready.set()
            while not stop.is_set():
                if mode == "read":
                    try:
                        await asyncio.wait_for(ws.recv(), 0.2)
                    except TimeoutError:
                        pass
                else:
                    await asyncio.sleep(0.1)

    asyncio.run(session())


def _loop_periods(seconds: float, server: Any) -> np.ndarray:
    """Periods (ms) of a 100 Hz loop writing what Main writes to the live server."""
    from bench.bench_render import paced_loop_periods_ms, synthetic_scene
    from recordings import topics

    scenes = [synthetic_scene(0.1 * k) for k in range(10)]

    def tick(k: int) -> None:
        map_state, plan, command = scenes[(k // 10) % 10]
        t_s = 0.01 * k
        server.write(topics.COMMAND, command, t_s)
        if k % 10 == 0:
            server.write(topics.MAP_STATE, map_state, t_s)
            server.write(topics.PLAN, plan, t_s)

    return paced_loop_periods_ms(seconds, tick)


def run(args: argparse.Namespace, config: AppConfig) -> int:
    from recordings.live_server import LiveServer

    ctx = mp.get_context("spawn")
    p99: dict[str, list[float]] = {case: [] for case in CASES}
    sent: dict[str, int] = dict.fromkeys(CASES, 0)
    dropped: dict[str, int] = dict.fromkeys(CASES, 0)
    with LiveServer("127.0.0.1", 0, config.car) as server:
        names = list(CASES)
        for r in range(args.rounds):
            # Each round in another order: no case always follows another's teardown.
            for case in names[r % len(names):] + names[:r % len(names)]:
                modes = CASES[case]
                stop = ctx.Event()
                clients = []
                for mode in modes:
                    ready = ctx.Event()
                    proc = ctx.Process(target=_client, args=(server.port, mode, ready, stop),
                                       daemon=True)
                    proc.start()
                    if not ready.wait(30.0):
                        raise SystemExit(f"bench live: the {mode} client did not connect")
                    clients.append(proc)
                deadline = time.monotonic() + 10.0
                while server.clients < len(modes) and time.monotonic() < deadline:
                    time.sleep(0.02)
                time.sleep(1.0)  # let the clients (and the previous case's ending) settle
                if "stall" in modes:
                    # Unmeasured ticks until the stalled client's socket buffers are full (the
                    # server's send queue on localhost holds about 3 s of this traffic): the
                    # measurement sees the server's backlog full and dropping.
                    _loop_periods(STALL_FILL_S, server)
                sent0, dropped0 = server.sent, server.dropped
                periods = _loop_periods(args.loop_seconds, server)
                p99[case].append(float(np.percentile(periods, 99)))
                sent[case] += server.sent - sent0
                dropped[case] += server.dropped - dropped0
                stop.set()
                for proc in clients:
                    proc.join(5.0)
                    if proc.is_alive():
                        proc.terminate()
                        proc.join(1.0)
                while server.clients and time.monotonic() < deadline + 5.0:
                    time.sleep(0.02)
    base = float(np.median(p99["no client"]))
    print(f"control loop p99 period, median of {args.rounds} interleaved rounds of "
          f"{args.loop_seconds:g} s (100 Hz, command every tick, 300-cone map and plan at 10 Hz):")
    worst = 0.0
    for case in CASES:
        median = float(np.median(p99[case]))
        delta = median - base
        if case != "no client":
            worst = max(worst, delta)
        print(f"  {case:>20}: p99 {median:7.3f} ms  (delta {delta:+.3f} ms; rounds "
              f"{', '.join(f'{v:.2f}' for v in p99[case])}; {sent[case]} messages sent, "
              f"{dropped[case]} dropped by the publisher's queue)")
    print(f"live_p99_delta_ms={worst:.3f}")
    return 0
