"""The Sensor Manager (Tier 2): builds the receivers from the config, runs them, hands Main
everything since its last call, and reports each source's health.

Two ways to run, ONE parsing path (an :class:`~sensors.receiver.Intake` per source):

- live (``drive``, the emulator): :meth:`SensorManager.start` starts one receiver thread per
  enabled source; :meth:`SensorManager.stop` stops them all against one deadline
  (``sensors.stop_timeout_s``).
- offline (simulation, replay): :meth:`SensorManager.ingest` runs raw units through the same
  parsers in the caller's thread.

Either way :meth:`SensorManager.take` returns a :class:`SensorBatch` and
:meth:`SensorManager.health` a :class:`~common.messages.Health`.
"""

from __future__ import annotations

import collections
import itertools
import logging
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from common.car import CarConfig
from common.clock import Clock
from common.errors import SensorError
from common.messages import (
    ActuatorCommand,
    AsStatus,
    CanFrame,
    Health,
    RawBytes,
    Reading,
    SourceHealth,
)
from sensors.can_codec import AS_STATUS_ID, CanCodec
from sensors.config import SensorsConfig
from sensors.receiver import FrameDecoder, Intake, Parser, RawUnit, Receiver, join_all

logger = logging.getLogger(__name__)

SLCAN_BYTE_WAIT_S = 0.01
"""How long (s) python-can's slcan bus waits for one byte of the adapter before it looks at
its own read timeout again (the receive loop's granularity, not a frame's latency)."""

SOURCES = ("gps", "imu", "can", "lidar", "camera")
"""Every source the manager knows, in the order health reports them ("res" follows "can")."""


@dataclass(frozen=True, slots=True)
class SensorBatch:
    """What arrived since the last :meth:`SensorManager.take`.

    ``raw``: the raw units (``RawBytes`` / ``CanFrame``) in time order, for the recorder;
    ``readings``: the parsed readings in time order (stable for equal times);
    ``latest``: the latest reading of each kind ever received, keyed ``gps``, ``imu``,
    ``wheel_speeds``, ``steering``, ``res``, ``lidar``, ``camera``.
    """

    raw: list[RawBytes | CanFrame] = field(default_factory=list)
    readings: list[Reading] = field(default_factory=list)
    latest: dict[str, Reading] = field(default_factory=dict)


def _time_key(item: tuple[int, Any]) -> tuple[float, int]:
    """Time order; ties in arrival order (the sort is stable within one raw unit)."""
    return float(item[1].timestamp_s), item[0]


def make_parser(source: str, config: SensorsConfig, car: CarConfig) -> Parser | FrameDecoder:
    """The parser of ``source`` (imported lazily: each lives in its own module)."""
    if source == "gps":
        from sensors.nmea import NmeaParser
        return NmeaParser()  # type: ignore[no-any-return]
    if source == "imu":
        from sensors.imu_protocol import ImuParser
        return ImuParser()  # type: ignore[no-any-return]
    if source == "can":
        return CanCodec(config.can.dbc or None)
    if source == "lidar":
        from sensors.lidar_parser import LidarParser
        return LidarParser(config.lidar, car)  # type: ignore[no-any-return]
    if source == "camera":
        from sensors.camera_codec import CameraParser
        return CameraParser(config.camera)  # type: ignore[no-any-return]
    raise SensorError(f"unknown sensor source {source!r} (expected one of {', '.join(SOURCES)})")


class SensorManager:
    """Receivers, parsers and health of every enabled sensor.

    ``parsers`` overrides the parser of a source (tests, tools); the others come from
    :func:`make_parser`. A source is enabled by ``config.<source>.enabled``. With
    ``keep_raw`` False, :meth:`take` returns no raw units (nothing will record them: replay).
    """

    def __init__(self, config: SensorsConfig, car: CarConfig, clock: Clock,
                 parsers: Mapping[str, Parser | FrameDecoder] | None = None,
                 keep_raw: bool = True) -> None:
        self.config = config
        self.clock = clock
        sc = config
        self.enabled: tuple[str, ...] = tuple(
            s for s in SOURCES if getattr(sc, s).enabled)
        overrides = dict(parsers or {})
        self.intakes: dict[str, Intake] = {}
        sequence = itertools.count()  # arrival order across sources (ties in time)
        for source in self.enabled:
            parser = overrides.get(source) or make_parser(source, config, car)
            self.intakes[source] = Intake(source, parser, sc.queue_length, sc.rate_window_s,
                                          sequence, keep_raw)
        self.receivers: dict[str, Receiver] = {}
        self.rejects: collections.Counter[str] = collections.Counter()
        self._command_codec = CanCodec(sc.can.dbc or None)
        self._status_period_s = self.status_period_s
        self._last_status: AsStatus | None = None
        self._next_status_s = -math.inf
        self._latest: dict[str, Reading] = {}
        self._stale_live: set[str] = set()
        """Live sources now stale (each logged once when it turned stale)."""
        self._started = False

    # -- live -----------------------------------------------------------------------------

    def _build_receiver(self, source: str) -> Receiver:
        sc = self.config
        cfg = getattr(sc, source)
        intake = self.intakes[source]
        common = dict(read_timeout_s=cfg.read_timeout_s, reconnect_min_s=sc.reconnect_min_s,
                      reconnect_max_s=sc.reconnect_max_s)
        receiver: Receiver
        if source in ("gps", "imu"):
            from sensors.serial_receiver import LineFramer, SerialReceiver
            framer = LineFramer() if source == "gps" else None
            receiver = SerialReceiver(self.clock, intake.parser, cfg.port,  # type: ignore[arg-type]
                                      cfg.baudrate, framer=framer, **common)
        elif source == "can":
            from sensors.can_receiver import CanReceiver
            bus_kwargs: dict[str, Any] = {}
            if cfg.interface == "slcan":
                bus_kwargs["sleep_after_open"] = cfg.slcan_open_delay_s
                # python-can waits for each byte at most this long (its default, 1 ms, wakes
                # the real-time receiver 1000 times a second for nothing: 12 % of a core
                # against 7 % at 220 frames/s, measured)
                bus_kwargs["timeout"] = SLCAN_BYTE_WAIT_S
            elif cfg.interface == "udp_multicast":
                bus_kwargs["port"] = cfg.udp_port
            codec = intake.parser
            assert isinstance(codec, CanCodec)
            receiver = CanReceiver(self.clock, codec, cfg.interface, cfg.channel, cfg.bitrate,
                                   bus_kwargs=bus_kwargs, **common)
        else:
            from sensors.udp_receiver import UdpReceiver
            receiver = UdpReceiver(self.clock, intake.parser, cfg.host,  # type: ignore[arg-type]
                                   cfg.port, **common)
        receiver.intake = intake  # one intake per source, shared with ingest()
        return receiver

    def start(self) -> None:
        """Start one receiver thread per enabled source (ports are opened in the threads and
        retried while they are missing)."""
        if self._started:
            return
        for source in self.enabled:
            if source not in self.receivers:
                self.receivers[source] = self._build_receiver(source)
        for receiver in self.receivers.values():
            receiver.start()
        self._started = True
        logger.info("sensor manager started: %s", ", ".join(self.receivers) or "no receivers")

    def stop(self) -> bool:
        """Stop every receiver against one deadline (``sensors.stop_timeout_s``); True when
        every thread ended in time."""
        if not self.receivers:
            self._started = False
            return True
        late = join_all(self.receivers.values(), self.config.stop_timeout_s)
        self._started = False
        return not late

    def __enter__(self) -> SensorManager:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def wait_connected(self, timeout_s: float) -> bool:
        """Block until every receiver has its transport open (True) or ``timeout_s`` passed."""
        import time
        deadline = time.monotonic() + timeout_s
        return all(r.wait_connected(max(0.0, deadline - time.monotonic()))
                   for r in self.receivers.values())

    # -- offline --------------------------------------------------------------------------

    def ingest(self, raw: Sequence[RawUnit]) -> None:
        """Parse raw units in this thread (simulation, replay); read them with :meth:`take`.

        A unit of a source that is not enabled is counted in ``rejects["unknown_source"]``.
        """
        intakes = self.intakes
        for unit in raw:
            source = "can" if isinstance(unit, CanFrame) else unit.source
            intake = intakes.get(source)
            if intake is None:
                if not self.rejects[f"unknown_source:{source}"]:
                    logger.warning("raw unit of source %r that is not enabled: ignored", source)
                self.rejects[f"unknown_source:{source}"] += 1
                self.rejects["unknown_source"] += 1
                continue
            intake.ingest(unit)

    # -- both -----------------------------------------------------------------------------

    def take(self) -> SensorBatch:
        """Everything since the last call, in time order, and the latest reading of each kind."""
        raw: list[tuple[int, RawUnit]] = []
        readings: list[tuple[int, Reading]] = []
        for intake in self.intakes.values():
            r, p = intake.take_tagged()
            raw.extend(r)
            if p:  # the latest readings change only with new ones
                readings.extend(p)
                self._latest.update(intake.latest_copy())
        raw.sort(key=_time_key)
        readings.sort(key=_time_key)
        return SensorBatch([u for _, u in raw], [r for _, r in readings], dict(self._latest))

    def health(self, now_s: float) -> Health:
        """Freshness of each enabled source at ``now_s`` (the run's clock).

        A source is stale when its last reading is older than its ``timeout_s`` (or it has none
        yet). With CAN enabled, ``res`` reports the RES_STATE frames alone (stale after
        ``sensors.can.res_timeout_s``), since a lost RES must stop the car even while the wheel
        speeds keep coming.

        Live, a receiver thread must also have seen the silence: a thread that has not come back
        from its transport since the last reading (a busy process delays it, as it delays the
        map and the plan) says nothing about the sensor. Its source turns stale only once the
        silence it saw exceeds ``timeout_s``, or the reading's age exceeds ``timeout_s`` plus
        ``reader_late_grace_s`` (a stuck thread still ends in a stop).
        """
        sc = self.config
        out: list[SourceHealth] = []
        for source, intake in self.intakes.items():
            receiver = self.receivers.get(source)
            awake_s: float | None = None
            if receiver is not None:
                alive = receiver.is_alive() and receiver.connected.is_set()
                awake_s = receiver.awake_s  # before the figures: a later reading only helps
            else:
                alive = intake.raw_count > 0
            rate, age, errors, rejects = intake.health_figures(now_s)
            timeout_s = getattr(sc, source).timeout_s
            out.append(SourceHealth(now_s, source, alive, rate, age, errors,
                                    self._stale(now_s, age, timeout_s, awake_s, source),
                                    rejects))
            if source == "can":
                rate, age, _, _ = intake.health_figures(now_s, "res")
                out.append(SourceHealth(now_s, "res", alive, rate, age, 0,
                                        self._stale(now_s, age, sc.can.res_timeout_s, awake_s,
                                                    "res"),
                                        ()))
        return Health(now_s, tuple(out))

    def _stale(self, now_s: float, age_s: float, timeout_s: float,
               awake_s: float | None, source: str = "") -> bool:
        """Stale, from the last reading's age (s) and when the receiver thread was last awake
        (None: parsed in the caller's thread, which is never behind its own sensors). A live
        source turning stale is logged once, with what its reader saw."""
        if age_s <= timeout_s:
            self._stale_live.discard(source)
            return False
        if awake_s is None:
            return True
        silence_seen_s = awake_s - (now_s - age_s)
        stale = silence_seen_s > timeout_s or age_s > timeout_s + self.config.reader_late_grace_s
        if stale and source not in self._stale_live and math.isfinite(age_s):
            self._stale_live.add(source)
            logger.warning("%s stale: last reading %.3f s ago; its reader proved %.3f s of "
                           "silence (timeout %.3f s) and was last back %.3f s ago", source,
                           age_s, silence_seen_s, timeout_s, now_s - awake_s)
        return stale

    def send_command(self, cmd: ActuatorCommand) -> CanFrame:
        """Encode ``cmd`` as the DBC's AS_COMMAND frame and, when live, send it on the CAN bus.

        Returns the frame (also offline, where the simulator takes it). Live, the CAN
        receiver's sender thread writes it (:meth:`CanReceiver.post`): this never waits on the
        bus. A send failure is counted in the CAN source's errors and logged; it does not raise.
        """
        frame = self._command_codec.encode_command(cmd)
        receiver = self.receivers.get("can")
        if receiver is not None and self._started:
            from sensors.can_receiver import CanReceiver
            if isinstance(receiver, CanReceiver):
                receiver.post(frame)
        return frame

    @property
    def status_period_s(self) -> float:
        """The ``AS_STATUS`` cycle time (s) of the DBC (0.1 s when it names none)."""
        message = self._command_codec.db.get_message_by_frame_id(AS_STATUS_ID)
        cycle_ms = message.cycle_time
        return cycle_ms / 1e3 if cycle_ms else 0.1

    def report_status(self, status: AsStatus) -> CanFrame | None:
        """Send ``status`` when it is due: every :attr:`status_period_s` (the DBC's cycle time),
        and at once when the AS state, mission, lap or ASSI mode changed. Returns the frame
        sent, None when none was due."""
        last = self._last_status
        changed = last is None or (last.state, last.mission, last.lap, last.assi) != (
            status.state, status.mission, status.lap, status.assi)
        if not changed and status.timestamp_s + 1e-9 < self._next_status_s:
            return None
        self._last_status = status
        self._next_status_s = status.timestamp_s + self._status_period_s
        return self.send_status(status)

    def send_status(self, status: AsStatus) -> CanFrame:
        """Encode ``status`` as the DBC's AS_STATUS frame and, when live, send it on the CAN
        bus (as :meth:`send_command`). Returns the frame (offline the simulator takes it)."""
        frame = self._command_codec.encode_as_status(status)
        receiver = self.receivers.get("can")
        if receiver is not None and self._started:
            from sensors.can_receiver import CanReceiver
            if isinstance(receiver, CanReceiver):
                receiver.post(frame)
        return frame
