"""LiDAR data packets to cone detections: model check, sweep assembly and the cone detector.

The sensor is the config's ``lidar.model`` (:mod:`sensors.lidar_models`): the Velodyne VLP-16
(the default) or HDL-32E (:mod:`sensors.velodyne`, :mod:`sensors.hdl32e`), or the Ouster
OS1-64 in the legacy packet format (:mod:`sensors.ouster`, with its metadata file
``lidar.meta_file``). The other names of the table (``vlp32c``, ``pandar40p``) are refused at
start with one clear error: their packets are not decoded.

The same object serves the live UDP receiver, the simulation loop and replay: feed it each
datagram with its arrival time on the Clock and it returns a :class:`LidarCones` whenever a
sweep completes. Bad datagrams are counted in ``rejects`` by reason and logged, never raised;
well-formed packets of another model than the configured one (another Velodyne, told by
:mod:`sensors.velodyne_model`; an Ouster packet to a Velodyne's parser or a Velodyne packet to
an Ouster's, told by their size and flags) are refused, counted as ``wrong_model`` (by model in
``refused``) and logged in one line.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from common.car import CarConfig
from common.errors import ConfigError, DecodeError
from common.messages import LidarCones, LidarPoints
from sensors.cone_detector import ConeDetector
from sensors.config import LidarConfig
from sensors.lidar_models import LidarModel, lidar_model
from sensors.ouster import (
    OusterMeta,
    OusterPacketInfo,
    OusterSweepAssembler,
    legacy_beams_of_size,
    load_meta,
)
from sensors.ouster import check_packet as check_ouster_packet
from sensors.ouster import decode_packets as decode_ouster_packets
from sensors.velodyne import (
    BLOCKS_PER_PACKET,
    PACKET_SIZE,
    VLP16_LAYOUT,
    ReturnWindow,
    SweepAssembler,
    VelodyneLayout,
    check_packet,
    decode_packets,
    reject_reason,
)
from sensors.velodyne_model import LOG_EVERY, PRODUCT_IDS, ModelGuard

log = logging.getLogger(__name__)

DECODED_MODELS = ("vlp16", "hdl32e", "os1-64")
"""The ``lidar.model`` names whose packets are decoded."""
_VelodyneItem = tuple[float, bytes, tuple[int, ...]]
_HOUR_US = 3_600_000_000
"""A Velodyne packet's timestamp counts microseconds past the hour."""


def _velodyne_layout(name: str) -> VelodyneLayout:
    if name == "hdl32e":
        from sensors.hdl32e import HDL32E_LAYOUT
        return HDL32E_LAYOUT
    return VLP16_LAYOUT


def open_model(name: str, meta_file: str | None = None) -> tuple[LidarModel, OusterMeta | None]:
    """The sensor called ``name`` (``lidar.model``) and, for an Ouster, its metadata read from
    ``meta_file`` (its beam elevations replace the nominal table). Raises :class:`ConfigError`
    (one line) for an unknown or undecoded model, or a missing or bad metadata file."""
    try:
        model = lidar_model(name)
    except ValueError as exc:
        raise ConfigError(f"lidar.model: {exc}") from None
    if model.name not in DECODED_MODELS:
        raise ConfigError(f"lidar.model {model.name!r} ({model.title}): its packets are not "
                          f"decoded; choose one of {', '.join(DECODED_MODELS)}")
    if model.name != "os1-64":
        return model, None
    if not meta_file:
        raise ConfigError(f"lidar.model {model.name!r} needs the sensor's metadata JSON file "
                          "(lidar.meta_file, or --meta FILE): its beam angles come from there")
    meta = load_meta(meta_file)
    if meta.beams != model.beams:
        raise ConfigError(f"{meta.source}: metadata of a sensor with {meta.beams} beams, but "
                          f"lidar.model {model.name!r} has {model.beams}")
    return model.with_elevations(tuple(float(e) for e in meta.beam_altitude_deg)), meta


def foreign_model(payload: bytes, ouster: bool) -> str | None:
    """The sensor a datagram that is not the configured model's comes from, if it is one we
    know: a Velodyne data packet (1206 bytes, every block flagged 0xFFEE; named by its product
    id) when an Ouster (``ouster``) is configured, a legacy Ouster lidar packet (told by its
    size, of any OS1's beam count); None when it is neither (garbage, a truncated packet)."""
    if (ouster and len(payload) == PACKET_SIZE
            and payload[0:1200:100] == b"\xff" * BLOCKS_PER_PACKET
            and payload[1:1200:100] == b"\xee" * BLOCKS_PER_PACKET):
        product = payload[1205]
        return "Velodyne " + PRODUCT_IDS.get(product, f"(product id 0x{product:02X})")
    beams = legacy_beams_of_size(len(payload))
    return None if beams is None else f"Ouster OS1 ({beams} beams, legacy packets)"


class SweepSource:
    """Datagrams of the configured LiDAR in, sweeps (:class:`~common.messages.LidarPoints`)
    out: packet checks, the model check and the sweep assembly, no detection.

    ``model`` and ``meta`` as :func:`open_model` returns them; ``window`` chooses the returns
    decoded (None: all). ``rejects`` counts bad and refused datagrams by reason,
    ``refused`` the refused ones by model, ``counts["packets"]`` the decoded ones.
    ``on_packet(timestamp_s, payload)``, when set, sees every packet that is decoded, in order.

    A Velodyne datagram of n whole packets (n x 1206 bytes, n > 1) is a sweep unit, the packets
    back to back as the simulator hands them out a sweep at a time
    (:class:`simulator.lidar_model.LidarModel`, issue 42): it is read as its n packets, stamped
    with the last one's arrival, each earlier one arrived its device-time gap to the last
    before it (the sensor sends a packet as it fills). A sensor never sends such a datagram.
    """

    def __init__(self, model: LidarModel, meta: OusterMeta | None = None,
                 cut_azimuth_deg: float = 180.0, window: ReturnWindow | None = None,
                 source: str = "lidar") -> None:
        self.model = model
        self.meta = meta
        self.source = source
        self.rejects: Counter[str] = Counter()
        self.counts: Counter[str] = Counter()
        self.on_packet: Callable[[float, bytes], None] | None = None
        self._foreign: Counter[str] = Counter()
        self.ouster: OusterSweepAssembler | None = None
        self.velodyne: SweepAssembler | None = None
        self.guard: ModelGuard[_VelodyneItem] | None = None
        if meta is not None:
            self.ouster = OusterSweepAssembler(meta, cut_azimuth_deg, window=window)
        else:
            layout = _velodyne_layout(model.name)
            self.velodyne = SweepAssembler(cut_azimuth_deg=cut_azimuth_deg, window=window,
                                           layout=layout)
            self.guard = ModelGuard(source, expected=layout.name)
            """Items: a packet's arrival time, payload and :func:`check_packet` fields."""

    @property
    def refused(self) -> Counter[str]:
        """Packets refused as another sensor's, by model."""
        out = Counter(self._foreign)
        if self.guard is not None:
            out.update(self.guard.refused)
        return out

    def feed(self, timestamp_s: float, payload: bytes) -> list[LidarPoints]:
        """Take one datagram, or a Velodyne sweep unit (see the class docstring); return the
        sweeps it completes (usually none)."""
        if self.ouster is not None:
            return self._feed_ouster(self.ouster, timestamp_s, payload)
        n = len(payload) // PACKET_SIZE
        if n > 1 and len(payload) == n * PACKET_SIZE:
            return self._feed_unit(timestamp_s, payload, n)
        return self._feed_packet(timestamp_s, payload)

    def _feed_unit(self, timestamp_s: float, payload: bytes, n: int) -> list[LidarPoints]:
        """The ``n`` packets of a sweep unit, the last arrived at ``timestamp_s`` (s), each
        earlier one its device-time gap to the last before it (at most 1 s, never later than
        the one after it)."""
        stamps_us = np.ndarray((n,), dtype="<u4", buffer=payload, offset=PACKET_SIZE - 6,
                               strides=(PACKET_SIZE,)).astype(np.int64)
        ahead_us = np.minimum((stamps_us[-1] - stamps_us) % _HOUR_US, 1_000_000)
        arrival_s = np.minimum.accumulate((timestamp_s - ahead_us * 1e-6)[::-1])[::-1]
        packets = [payload[i * PACKET_SIZE:(i + 1) * PACKET_SIZE] for i in range(n)]
        fast = self._unit_at_once(payload, n, stamps_us, arrival_s, packets)
        if fast is not None:
            return fast
        out: list[LidarPoints] = []
        for t_s, packet in zip(arrival_s.tolist(), packets, strict=True):
            out.extend(self._feed_packet(t_s, packet))
        return out

    def _unit_at_once(self, payload: bytes, n: int, stamps_us: NDArray[np.int64],
                      arrival_s: NDArray[np.float64], packets: list[bytes]
                      ) -> list[LidarPoints] | None:
        """A sweep unit's packets checked and admitted together, then assembled, when every
        one is well formed and of the configured model (as one by one, without a call per
        packet to the checks); None (nothing done) otherwise, or when ``on_packet`` watches."""
        guard, assembler = self.guard, self.velodyne
        if self.on_packet is not None or guard is None or assembler is None:
            return None
        rows = np.frombuffer(payload, dtype=np.uint8).reshape(n, PACKET_SIZE)
        if not ((rows[:, 0:1200:100] == 0xFF).all() and (rows[:, 1:1200:100] == 0xEE).all()):
            return None
        azimuths = np.ndarray((n, BLOCKS_PER_PACKET), dtype="<u2", buffer=payload, offset=2,
                              strides=(PACKET_SIZE, 100))
        modes, products = rows[:, 1204], rows[:, 1205]
        if (int(azimuths.max()) >= 36000 or (modes != modes[0]).any()
                or (products != products[0]).any()):
            return None
        stamps = stamps_us.tolist()
        if not guard.admit_all(stamps, int(modes[0]), int(products[0])):
            return None
        fields = np.column_stack([azimuths, stamps_us]).tolist()
        out: list[LidarPoints] = []
        for t_s, packet, f in zip(arrival_s.tolist(), packets, fields, strict=True):
            out.extend(assembler.add_checked(t_s, packet, f))
        self.counts["packets"] += n
        return out

    def _feed_packet(self, timestamp_s: float, payload: bytes) -> list[LidarPoints]:
        """One Velodyne datagram."""
        try:
            fields = check_packet(payload)
        except DecodeError as exc:
            foreign = foreign_model(payload, ouster=False)
            if foreign is not None:
                self._refuse_foreign(foreign, f"a datagram of {len(payload)} bytes")
            else:
                self._reject(exc)
            return []
        assert self.guard is not None
        guard = self.guard
        refused = guard.refused_count
        admitted = guard.admit((timestamp_s, payload, fields), payload)
        self._count_refused(guard.refused_count - refused)
        return self._assemble(admitted)

    def flush(self) -> list[LidarPoints]:
        """End of a file or a stream: the packets held back and the partial sweep."""
        if self.ouster is not None:
            return self.ouster.flush()
        assert self.guard is not None and self.velodyne is not None
        refused = self.guard.refused_count
        out = self._assemble(self.guard.flush())
        self._count_refused(self.guard.refused_count - refused)
        return out + self.velodyne.flush()

    def decode_points(self, payload: bytes) -> NDArray[np.float64]:
        """Every return of one packet that was decoded (``on_packet`` saw it), (N, 4): x, y, z
        (m, sensor frame), intensity."""
        if self.ouster is not None:
            return decode_ouster_packets([payload], self.ouster.geometry).points
        assert self.velodyne is not None
        return decode_packets([payload], checked=True, layout=self.velodyne.layout).points

    def _assemble(self, admitted: list[_VelodyneItem]) -> list[LidarPoints]:
        assert self.velodyne is not None
        out: list[LidarPoints] = []
        for timestamp_s, payload, fields in admitted:
            if self.on_packet is not None:
                self.on_packet(timestamp_s, payload)
            out.extend(self.velodyne.add_checked(timestamp_s, payload, fields))
            self.counts["packets"] += 1
        return out

    def _feed_ouster(self, assembler: OusterSweepAssembler, timestamp_s: float,
                     payload: bytes) -> list[LidarPoints]:
        if len(payload) != assembler.geometry.meta.packet_size:
            foreign = foreign_model(payload, ouster=True)
            if foreign is not None:
                self._refuse_foreign(foreign, f"a datagram of {len(payload)} bytes")
                return []
        try:
            info: OusterPacketInfo | None = check_ouster_packet(payload, assembler.geometry)
        except DecodeError as exc:
            self._reject(exc)
            return []
        self.counts["packets"] += 1
        if self.on_packet is not None:
            self.on_packet(timestamp_s, payload)
        if info is None:
            return []  # no good column: nothing to decode
        return assembler.add_checked(timestamp_s, payload, info)

    def _reject(self, exc: DecodeError) -> None:
        reason = reject_reason(exc)
        self.rejects[reason] += 1
        if self.rejects[reason] <= 3 or self.rejects[reason] % 1000 == 0:
            log.warning("%s: rejected datagram (%s; %d so far)", self.source, exc,
                        self.rejects[reason])

    def _count_refused(self, n: int) -> None:
        if n:
            self.rejects["wrong_model"] += n

    def _refuse_foreign(self, model: str, why: str) -> None:
        self.rejects["wrong_model"] += 1
        self._foreign[model] += 1
        n = self._foreign[model]
        if n == 1 or n % LOG_EVERY == 0:
            log.warning("%s: refusing the packets of another sensor, %s (%s): only the %s's "
                        "are decoded (lidar.model), another sensor's data is never turned into "
                        "points (%d refused so far)", self.source, model, why, self.model.title,
                        n)


class LidarParser:
    """Datagrams of the configured LiDAR in, one :class:`LidarCones` per completed sweep out.

    ``feed(timestamp_s, payload)``: ``timestamp_s`` is the datagram's arrival time (s), taken
    as the packet's duration after its first firing (a Velodyne) or as its last column's time
    (an Ouster). ``rejects`` counts bad datagrams by reason (``bad_length``, ``bad_flag``,
    ``bad_azimuth``, ``bad_column``, ``wrong_model``: another sensor's packets, by model in
    ``refused``); ``counts`` counts ``packets``, ``sweeps``, ``points`` and ``cones``.
    ``on_packet(timestamp_s, payload)``, when set, sees every packet that is decoded (the
    configured model's, in order). ``last_sweep`` keeps the last sweep's points (for drawing
    and tests): only those that can be part of a cone (the detector's
    :meth:`~sensors.cone_detector.ConeDetector.return_window`: the ground and the car's own
    body are left out while decoding), or every return with ``all_points``.

    Raises :class:`ConfigError` (one line) when ``config.model`` is unknown or not decoded, or
    an Ouster's ``config.meta_file`` is missing or bad.
    """

    source = "lidar"

    def __init__(self, config: LidarConfig | None = None, car: CarConfig | None = None,
                 all_points: bool = False) -> None:
        config = config if config is not None else LidarConfig()
        model, meta = open_model(config.model, config.meta_file)
        self.model = model
        """The sensor (with an Ouster's own beam elevations)."""
        self.detector = ConeDetector(config.detector, car if car is not None else CarConfig(),
                                     model)
        window = None if all_points else self.detector.return_window()
        self.decoder = SweepSource(model, meta, config.cut_azimuth_deg, window, self.source)
        self.rejects = self.decoder.rejects
        self.counts = self.decoder.counts
        self.last_sweep: LidarPoints | None = None

    @property
    def on_packet(self) -> Callable[[float, bytes], None] | None:
        """Sees every packet that is decoded (see the class docstring)."""
        return self.decoder.on_packet

    @on_packet.setter
    def on_packet(self, hook: Callable[[float, bytes], None] | None) -> None:
        self.decoder.on_packet = hook

    @property
    def refused(self) -> Counter[str]:
        """Packets refused as another sensor's, by model."""
        return self.decoder.refused

    def feed(self, timestamp_s: float, payload: bytes) -> list[LidarCones]:
        """Take one datagram; return the cones of the sweeps it completes (usually none)."""
        return [self._detect(s) for s in self.decoder.feed(timestamp_s, bytes(payload))]

    def flush(self) -> list[LidarCones]:
        """Detect cones in the partial sweep collected so far (end of a file or a stream)."""
        return [self._detect(s) for s in self.decoder.flush()]

    def _detect(self, sweep: LidarPoints) -> LidarCones:
        self.last_sweep = sweep
        cones = self.detector.detect(sweep.points, sweep.rings, sweep.times_s,
                                     sweep.timestamp_s, sweep.return_count, sweep.start_s)
        self.counts["sweeps"] += 1
        self.counts["points"] += cones.point_count
        self.counts["cones"] += len(cones.cones)
        return cones
