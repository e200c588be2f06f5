"""End to end: ``sim --live 127.0.0.1:PORT --realtime --laps 1`` serves the scene over a Foxglove
WebSocket; a plain ``websockets`` client sees ``/foxglove/scene`` advertised as
``foxglove.SceneUpdate``, subscribes, receives it at >= 5 Hz of simulated time, and one message
decodes (``foxglove-schemas-protobuf``) into cones at the map's positions.

The foxglove-sdk server speaks the Foxglove WebSocket protocol under its current subprotocol
name ``foxglove.sdk.v1`` (the same protocol as ``foxglove.websocket.v1``); the client offers both,
as current Foxglove and Lichtblick clients do, and an old client offering only
``foxglove.websocket.v1`` is refused (HTTP 400).
"""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import websockets
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from websockets.exceptions import InvalidStatus

from simulator.tracks import load_track

ROOT = Path(__file__).resolve().parents[1]
SUBPROTOCOLS = ["foxglove.websocket.v1", "foxglove.sdk.v1"]
WINDOW_S = 4.0
"""Wall time (s) the client listens after subscribing."""
CONNECT_TIMEOUT_S = 60.0
"""Start-up of the sim process on a loaded machine (normally 2 to 5 s)."""


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


async def _connect(url: str, subprotocols: list[str], proc: subprocess.Popen[bytes]) -> object:
    deadline = time.monotonic() + CONNECT_TIMEOUT_S
    while True:
        try:
            return await websockets.connect(url, subprotocols=subprotocols,  # type: ignore[arg-type]
                                            max_size=None, open_timeout=10)
        except OSError:
            if proc.poll() is not None or time.monotonic() > deadline:
                raise
            await asyncio.sleep(0.2)


async def _session(url: str, proc: subprocess.Popen[bytes]) -> dict[str, object]:
    ws = await _connect(url, SUBPROTOCOLS, proc)
    out: dict[str, object] = {"subprotocol": ws.subprotocol}  # type: ignore[attr-defined]
    try:
        scene = None
        while scene is None:
            text = await asyncio.wait_for(ws.recv(), 10)  # type: ignore[attr-defined]
            if isinstance(text, str):
                message = json.loads(text)
                if message["op"] == "advertise":
                    by_topic = {c["topic"]: c for c in message["channels"]}
                    scene = by_topic.get("/foxglove/scene")
        out["scene_channel"] = scene
        await ws.send(json.dumps({"op": "subscribe",  # type: ignore[attr-defined]
                                  "subscriptions": [{"id": 7, "channelId": scene["id"]}]}))
        frames: list[tuple[int, bytes]] = []
        end = time.monotonic() + WINDOW_S
        while time.monotonic() < end:
            try:
                data = await asyncio.wait_for(ws.recv(), 1.0)  # type: ignore[attr-defined]
            except TimeoutError:
                continue
            if isinstance(data, bytes) and data[0] == 0x01:  # MessageData
                subscription, log_time_ns = struct.unpack_from("<IQ", data, 1)
                assert subscription == 7
                frames.append((log_time_ns, data[13:]))
        out["frames"] = frames
        # An old client that offers only the former subprotocol name is refused cleanly.
        with pytest.raises(InvalidStatus):
            await websockets.connect(url, subprotocols=["foxglove.websocket.v1"],  # type: ignore[list-item]
                                     open_timeout=10)
    finally:
        await ws.close()  # type: ignore[attr-defined]
    return out


def test_sim_live_serves_the_scene(tmp_path: Path) -> None:
    port = _free_port()
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen(
        [sys.executable, "main.py", "sim", "--live", f"127.0.0.1:{port}", "--realtime",
         "--laps", "1", "--no-render", "--no-record", "--out", str(tmp_path / "run")],
        cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        result = asyncio.run(_session(f"ws://127.0.0.1:{port}", proc))
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            _, stderr = proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, stderr = proc.communicate()
    assert result["subprotocol"] == "foxglove.sdk.v1"
    channel = result["scene_channel"]
    assert isinstance(channel, dict)
    assert channel["schemaName"] == "foxglove.SceneUpdate"
    assert channel["encoding"] == "protobuf"

    frames = result["frames"]
    assert isinstance(frames, list)
    scenes = [(t, SceneUpdate.FromString(payload)) for t, payload in frames]
    map_scenes = [(t, s) for t, s in scenes if any(e.id == "cones" for e in s.entities)]
    assert len(map_scenes) >= 5, (len(scenes), stderr.decode()[-2000:])
    # Rate against the run's own (simulated) clock: a slow machine slows the run, not the view.
    span_s = (map_scenes[-1][0] - map_scenes[0][0]) * 1e-9
    assert span_s > 0.0
    rate_hz = (len(map_scenes) - 1) / span_s
    assert rate_hz >= 5.0, rate_hz

    track = load_track("default")
    truth_xy = np.asarray(track.cones_xy_m, dtype=float)
    # The map's cones (the last scene has seen the most) are where the track's cones are: the
    # estimate's error is centimetres on the exploration lap; 0.5 m is half a cone spacing.
    _, last = map_scenes[-1]
    cones = next(e for e in last.entities if e.id == "cones")
    xy = np.array([[c.pose.position.x, c.pose.position.y] for c in cones.cylinders])
    assert len(xy) >= 4
    nearest_m = np.min(np.linalg.norm(xy[:, None, :] - truth_xy[None, :, :], axis=2), axis=1)
    assert np.all(nearest_m < 0.5), nearest_m.max()
    # The true track is sent too (late joiners get it again every 2 s): exactly the track's cones.
    truth = [e for _, s in scenes for e in s.entities if e.id == "truth_track"]
    assert truth, "no truth_track entity received"
    truth_sent = np.array([[c.pose.position.x, c.pose.position.y] for c in truth[0].cylinders])
    np.testing.assert_allclose(truth_sent, truth_xy, atol=1e-9)


def test_a_live_port_in_use_stops_the_run_before_anything_is_made(tmp_path: Path) -> None:
    """``--realtime`` forks its recorder's process before the live view starts; a port in use
    still ends the run with one line, no recording and no process left behind."""
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        proc = subprocess.Popen(
            [sys.executable, "main.py", "sim", "--realtime", "--live", f"127.0.0.1:{port}",
             "--no-render", "--out", str(tmp_path / "run")],
            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            start_new_session=True)
        _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 2, stderr
    assert f"cannot serve the live view on 127.0.0.1:{port}" in stderr
    assert "Traceback" not in stderr
    assert not (tmp_path / "run" / "recording.mcap").exists()
    with pytest.raises(ProcessLookupError):  # the recorder's process ended with the run
        os.killpg(proc.pid, 0)
