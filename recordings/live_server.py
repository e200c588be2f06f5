"""The live view: the recording's topics served over a Foxglove WebSocket while the stack runs.

``sim``, ``replay`` and ``drive`` take ``--live [HOST:]PORT``; a :class:`LiveServer` then serves
the same topics, in the same schemas, as ``recording.mcap`` (:mod:`recordings.topics`), so one
Foxglove layout (``recordings/foxglove/layout.json``) serves both: the scene
(``/foxglove/scene``, ``foxglove.SceneUpdate``: cones by colour, the car and its uncertainty
ellipse, the baseframe, the candidate manoeuvres and the chosen one, the driven trace, the true
track in simulation), the pose (``/foxglove/tf``,
``foxglove.FrameTransform``: ``world`` -> ``base_link``), the GNSS fix, and the stack's own
messages (``/map/state``, ``/plan``, ``/command`` with the AS state, ``/health``) in the
``fsd.*`` protobuf schemas. The WebSocket protocol is the ``foxglove-sdk`` package's.

It never delays the control loop. The caller's side (:meth:`LiveServer.write`, the output-sink
form Main already feeds the recorder with) returns at once: with no client subscribed it does
nothing; otherwise it puts a reference to the (immutable) message on a bounded queue, or drops
it (counted in :attr:`LiveServer.dropped`) when the queue is full. One publisher thread converts
and hands the bytes to the SDK, whose server keeps a bounded backlog per client and drops a slow
or stalled client's oldest messages (the SDK does not expose that count); the scene is built at
most every ``scene_period_s`` of log time.
"""

from __future__ import annotations

import logging
import queue
import threading
from dataclasses import dataclass
from typing import Any

import foxglove
from foxglove.websocket import ServerListener
from google.protobuf.message import Message as ProtoMessage
from mcap_protobuf.schema import build_file_descriptor_set

from common.car import CarConfig
from common.errors import FsdError
from common.messages import GpsFix, MapState, Plan
from common.track import TrackLayout
from recordings import foxglove_views, fsd_pb2, topics
from recordings.codec import to_proto
from recordings.foxglove import schemas as fg

log = logging.getLogger(__name__)

DEFAULT_HOST = "127.0.0.1"

#: The protobuf class of every topic the live server advertises.
LIVE_TOPIC_CLASSES: dict[str, type[ProtoMessage]] = {
    topics.FOXGLOVE_SCENE: fg.SceneUpdate,
    topics.FOXGLOVE_TF: fg.FrameTransform,
    topics.FOXGLOVE_GPS: fg.LocationFix,
    topics.MAP_STATE: fsd_pb2.MapState,
    topics.PLAN: fsd_pb2.Plan,
    topics.COMMAND: fsd_pb2.ActuatorCommand,
    topics.HEALTH: fsd_pb2.Health,
    topics.TRUTH_POSE: fsd_pb2.GroundTruth,
    topics.EVAL_POSE_ERROR: fsd_pb2.PoseError,
}


class LiveError(FsdError):
    """The live server cannot start (bad address, port in use)."""


def check_address(host: str, port: int) -> None:
    """Raise :class:`LiveError` (one line) when ``host:port`` cannot be listened on now: for a
    server started in another process (``drive``), whose own error would come late."""
    import socket

    try:
        infos = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)
        with socket.socket(infos[0][0], socket.SOCK_STREAM) as sock:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind(infos[0][4])
    except OSError as exc:
        raise LiveError(f"cannot serve the live view on {host}:{port}: {exc}") from exc


@dataclass(frozen=True, slots=True)
class _Item:
    topic: str
    payload: Any
    log_time_s: float
    proto: bool


class _Listener(ServerListener):
    """Counts the clients subscribed to at least one channel (SDK callbacks, its thread)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._subscriptions: dict[int, int] = {}
        self.clients_max = 0

    @property
    def clients(self) -> int:
        return len(self._subscriptions)

    def on_subscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._subscriptions[client.id] = self._subscriptions.get(client.id, 0) + 1
            self.clients_max = max(self.clients_max, len(self._subscriptions))

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            left = self._subscriptions.get(client.id, 0) - 1
            if left > 0:
                self._subscriptions[client.id] = left
            else:
                self._subscriptions.pop(client.id, None)


class LiveServer:
    """A Foxglove WebSocket server fed like the recorder (an output sink of Main).

    ``host``/``port``: where to listen (port 0: any free port, see :attr:`port`). ``car`` gives
    the car's box in the scene. ``queue_length`` bounds the messages waiting for the publisher
    thread; ``backlog`` the SDK's per-client queue. ``track_period_s``: the true track (when
    given) is sent again this often (s, wall clock) so that a client joining late sees it.

    Thread-safe; every ``write*`` method returns at once.
    """

    def __init__(
        self,
        host: str = DEFAULT_HOST,
        port: int = 8765,
        car: CarConfig | None = None,
        *,
        scene_period_s: float = 0.1,
        queue_length: int = 512,
        backlog: int = 256,
        track_period_s: float = 2.0,
        name: str = "fsd-stack",
    ) -> None:
        self._car = car if car is not None else CarConfig()
        self.scene_period_s = scene_period_s
        self.track_period_s = track_period_s
        self._listener = _Listener()
        self._context = foxglove.Context()
        self._channels: dict[str, Any] = {}
        for topic, cls in LIVE_TOPIC_CLASSES.items():
            schema = foxglove.Schema(
                name=cls.DESCRIPTOR.full_name, encoding="protobuf",
                data=build_file_descriptor_set(cls).SerializeToString(),
            )
            self._channels[topic] = foxglove.Channel(topic, schema=schema,
                                                     message_encoding="protobuf",
                                                     context=self._context)
        try:
            self._server = foxglove.start_server(
                name=name, host=host, port=port, context=self._context,
                server_listener=self._listener, message_backlog_size=backlog,
            )
        except Exception as exc:  # the SDK raises its own error types (bind failures)
            raise LiveError(f"cannot serve the live view on {host}:{port}: {exc}") from exc
        self.host = host
        self.port: int = int(self._server.port)
        self.sent = 0
        """Messages handed to the server (each goes to every subscribed client)."""
        self.dropped = 0
        """Messages not published because the publisher's queue was full (or it was closed)."""
        self.skipped = 0
        """Messages not converted because no client was subscribed."""
        self.errors = 0
        self._track: TrackLayout | None = None
        self._next_track_s = 0.0
        self._last_scene_s: float | None = None
        self._trace = foxglove_views.TraceSegments()
        self._cone_drawer = foxglove_views.ConeDrawer()
        self._baseframe_memo = foxglove_views.LineMemo()
        self._closed = False
        self._queue: queue.Queue[_Item] = queue.Queue(maxsize=max(1, queue_length))
        self._thread = threading.Thread(target=self._run, name="live-server", daemon=True)
        self._thread.start()
        log.info("live view on ws://%s:%d (Foxglove: open connection, Foxglove WebSocket)",
                 host, self.port)

    # -------------------------------------------------------------------- the caller's side
    def write(self, topic: str, message: object, log_time_s: float) -> bool:
        """Queue a :mod:`common.messages` object for ``topic``; False when not queued."""
        if isinstance(message, TrackLayout):
            self._track = message
            self._next_track_s = 0.0
        return self._put(_Item(topic, message, log_time_s, False))

    def write_proto(self, topic: str, proto: ProtoMessage, log_time_s: float) -> bool:
        """Queue a protobuf message as it is (``topic`` must be one of the advertised ones)."""
        return self._put(_Item(topic, proto, log_time_s, True))

    def write_gps_fix(self, fix: GpsFix) -> bool:
        """Queue a GNSS fix for ``/foxglove/gps``."""
        return self._put(_Item(topics.FOXGLOVE_GPS, fix, fix.timestamp_s, False))

    def __call__(self, topic: str, message: object, log_time_s: float) -> bool:
        return self.write(topic, message, log_time_s)

    def _put(self, item: _Item) -> bool:
        if self._listener.clients == 0:
            self.skipped += 1
            return False
        if not self._closed:
            try:
                self._queue.put_nowait(item)
                return True
            except queue.Full:
                pass
        self.dropped += 1
        if self.dropped & (self.dropped - 1) == 0:
            log.warning("live view dropped %d message(s) so far (publisher behind)",
                        self.dropped)
        return False

    # -------------------------------------------------------------------- stats, closing
    @property
    def clients(self) -> int:
        """Clients subscribed to at least one topic now."""
        return self._listener.clients

    def stats(self) -> dict[str, Any]:
        """What ``summary.json`` reports under ``live``."""
        return {
            "address": f"{self.host}:{self.port}",
            "clients_max": self._listener.clients_max,
            "messages_sent": self.sent,
            "messages_dropped": self.dropped,
            "errors": self.errors,
        }

    def close(self) -> None:
        """Stop the publisher thread (what is queued is discarded) and the server. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._thread.join(2.0)
        self._server.stop()
        for channel in self._channels.values():
            channel.close()
        log.info("live view closed: %s", self.stats())

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -------------------------------------------------------------------- publisher thread
    def _run(self) -> None:
        import time

        while not self._closed:
            try:
                item = self._queue.get(timeout=0.1)
            except queue.Empty:
                item = None
            if item is not None:
                try:
                    self._publish(item)
                except Exception as exc:  # noqa: BLE001 (one bad message must not stop the view)
                    self.errors += 1
                    if self.errors & (self.errors - 1) == 0:
                        log.error("live view could not publish on %s (%d so far): %s",
                                  item.topic, self.errors, exc)
            if self._track is not None and self._listener.clients:
                now = time.monotonic()
                if now >= self._next_track_s:
                    self._next_track_s = now + self.track_period_s
                    t_s = item.log_time_s if item is not None else 0.0
                    self._log(topics.FOXGLOVE_SCENE,
                              foxglove_views.track_scene(self._track, t_s), t_s)

    def _publish(self, item: _Item) -> None:
        t_s = item.log_time_s
        if item.proto:
            self._log(item.topic, item.payload, t_s)
            return
        message = item.payload
        if isinstance(message, GpsFix):
            self._log(topics.FOXGLOVE_GPS, foxglove_views.location_fix(message), t_s)
            return
        if isinstance(message, TrackLayout):
            return  # sent by the loop in _run, again every track_period_s
        if item.topic in self._channels:
            self._log(item.topic, to_proto(message), t_s)
        if isinstance(message, MapState):
            self._log(topics.FOXGLOVE_TF, foxglove_views.frame_transform(message.pose), t_s)
            trace = self._trace.add(t_s, message.pose.x_m, message.pose.y_m)
            if trace is not None:
                self._log(topics.FOXGLOVE_SCENE, trace, t_s)
            if (self._last_scene_s is None
                    or abs(t_s - self._last_scene_s) >= self.scene_period_s - 1e-6):
                self._last_scene_s = t_s
                car = self._car
                self._log(topics.FOXGLOVE_SCENE, foxglove_views.map_scene(
                    message, car.length_m, car.width_m, car.rear_overhang_m,
                    self._cone_drawer), t_s)
        elif isinstance(message, Plan):
            self._log(topics.FOXGLOVE_SCENE,
                      foxglove_views.plan_scene(message, baseframe_memo=self._baseframe_memo),
                      t_s)

    def _log(self, topic: str, proto: ProtoMessage, t_s: float) -> None:
        channel = self._channels[topic]
        channel.log(proto.SerializeToString(), log_time=round(max(t_s, 0.0) * 1e9))
        self.sent += 1
