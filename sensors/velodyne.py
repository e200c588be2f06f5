"""Velodyne data packets (VLP-16, HDL-32E): decoding (vectorised numpy) and sweep assembly.

A data packet is the 1206-byte UDP payload the sensor sends to port 2368 (described here for
the VLP-16; the HDL-32E's differs only in its :class:`VelodyneLayout`, :mod:`sensors.hdl32e`:
32 returns of one firing sequence per block, lasers 1.152 us apart in a 46.08 us sequence):

- 12 data blocks of 100 bytes: flag ``0xFFEE`` (bytes ``FF EE``), azimuth (uint16 LE,
  hundredths of a degree, clockwise seen from above, 0 = the sensor's front), then 32 channel
  returns of 3 bytes each: distance (uint16 LE, 2 mm units, 0 = no return) and reflectivity
  (uint8). Returns 0..15 are the first firing sequence of lasers 0..15, returns 16..31 the
  second firing sequence, fired 55.296 us later.
- a 4-byte timestamp (uint32 LE, microseconds past the hour, of the first firing of block 0),
- 2 factory bytes: return mode (0x37 strongest, 0x38 last, 0x39 dual) and product id
  (0x22 VLP-16; early VLP-16 firmware reports 0x21, the HDL-32E's id). This module decodes
  whatever it is given with the layout it is told (default the VLP-16's);
  :mod:`sensors.velodyne_model` decides beforehand, from these bytes and the packet timing,
  which packets are the configured model's.

Lasers fire every 2.304 us inside a 55.296 us firing sequence (VLP-16 user manual, 63-9243
rev E, section 9). The azimuth of every return is interpolated from the block azimuth with the
packet's mean rotation rate and rounded to 0.01 deg, exactly as ``velodyne-decoder`` (and the
ROS ``velodyne_pointcloud`` driver) do, so that both give the same points.

Frame of the decoded points: the ROS sensor frame of ``velodyne-decoder`` -- x forward (azimuth
0), y left, z up, origin at the sensor's optical centre. It is our vehicle-frame convention
(x forward, y left, z up), only shifted by the mount offset (car.lidar_x_m, car.lidar_z_m).

Each laser's origin sits a few mm above or below the optical centre (the manual's vertical
correction, :data:`LASER_VERTICAL_OFFSET_M`), added to z as the manual (and velodyne-decoder
3.x) do: ``z = d sin(el) + off``, ``xy = d cos(el)``.

``ring`` numbers lasers by elevation, 0 = lowest (-15 deg) to 15 = highest (+15 deg), as
``velodyne-decoder``'s ring field does; ``LASER_ELEVATION_DEG[laser_id]`` is by laser id.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from common.errors import DecodeError
from common.messages import LidarPoints

PACKET_SIZE = 1206
"""Bytes in one VLP-16 data packet (UDP payload)."""
POSITION_PACKET_SIZE = 512
"""Bytes in one VLP-16 position (GPS/telemetry) packet, sent to port 8308."""
BLOCKS_PER_PACKET = 12
BLOCK_SIZE = 100
LASERS = 16
RETURNS_PER_BLOCK = 32
BLOCK_FLAG = b"\xff\xee"
LASER_TIME_S = 2.304e-6
"""Time between two successive laser firings inside a firing sequence (s)."""
FIRING_CYCLE_S = 55.296e-6
"""Duration of one firing sequence of all 16 lasers, recharge included (s)."""
BLOCK_DURATION_S = 2 * FIRING_CYCLE_S
"""Each data block holds two firing sequences (s)."""
PACKET_DURATION_S = BLOCKS_PER_PACKET * BLOCK_DURATION_S
"""Time spanned by one single-return packet: 1.327104 ms, i.e. 753.5 packets/s (s)."""
DISTANCE_UNIT_M = 0.002
RETURN_MODE_STRONGEST = 0x37
RETURN_MODE_LAST = 0x38
RETURN_MODE_DUAL = 0x39
PRODUCT_VLP16 = 0x22

LASER_ELEVATION_DEG = np.array(
    [-15.0, 1.0, -13.0, 3.0, -11.0, 5.0, -9.0, 7.0, -7.0, 9.0, -5.0, 11.0, -3.0, 13.0, -1.0, 15.0]
)
"""Vertical angle of each laser id 0..15 (deg), the VLP-16's interleaved table."""
LASER_VERTICAL_OFFSET_M = 1e-3 * np.array(
    [11.2, -0.7, 9.7, -2.2, 8.1, -3.7, 6.6, -5.1, 5.1, -6.6, 3.7, -8.1, 2.2, -9.7, 0.7, -11.2]
)
"""Vertical offset of each laser id's origin from the optical centre (m), VLP-16 manual
table 9-1; velodyne-decoder's default VLP-16 calibration applies it too."""
LASER_RING = np.argsort(np.argsort(LASER_ELEVATION_DEG)).astype(np.int64)
"""Ring number (0 = lowest) of each laser id."""
RING_ELEVATION_DEG = np.sort(LASER_ELEVATION_DEG)
"""Vertical angle of each ring 0..15 (deg), ascending."""

_RETURN = np.dtype({"names": ["d", "r"], "formats": ["<u2", "u1"], "offsets": [0, 2],
                    "itemsize": 3})
_BLOCK_AZIMUTHS_AND_TIME = struct.Struct("<" + "2xH96x" * BLOCKS_PER_PACKET + "I")
_FLAGS_FF = b"\xff" * BLOCKS_PER_PACKET
_FLAGS_EE = b"\xee" * BLOCKS_PER_PACKET
_COS_AZ = np.cos(np.radians(np.arange(36000) * 0.01))
_SIN_AZ = np.sin(np.radians(np.arange(36000) * 0.01))


class VelodyneLayout:
    """One Velodyne model's laser angles and firing timing in the common 1206-byte packet.

    ``elevation_deg`` and ``vertical_offset_m`` (m, added to z) are by laser id, (lasers,);
    ``lasers`` is 16 (each data block holds two firing sequences, as the VLP-16's) or 32 (one,
    as the HDL-32E's). ``firing_cycle_s`` is one firing sequence of every laser, recharge
    included; ``laser_time_s`` the time between two successive lasers of a sequence.

    The timing table ``return_time_s`` (12, 32) float32 (s after the packet's first firing) and
    the azimuth interpolation follow ``velodyne-decoder`` (and the ROS driver) exactly, in
    float32, so that both give the same points.
    """

    def __init__(self, name: str, elevation_deg: Sequence[float] | NDArray[np.float64],
                 vertical_offset_m: Sequence[float] | NDArray[np.float64],
                 firing_cycle_s: float, laser_time_s: float,
                 distance_unit_m: float = 0.002) -> None:
        elevation = np.asarray(elevation_deg, dtype=np.float64)
        lasers = int(elevation.shape[0])
        if lasers not in (16, 32) or len(vertical_offset_m) != lasers:
            raise ValueError(f"{name}: 16 or 32 lasers with one offset each, not {lasers}")
        self.name = name
        """The model's name as :mod:`sensors.velodyne_model` writes it (``"HDL-32E"``)."""
        self.lasers = lasers
        self.firings_per_block = RETURNS_PER_BLOCK // lasers
        self.elevation_deg = elevation
        self.vertical_offset_m = np.asarray(vertical_offset_m, dtype=np.float64)
        self.distance_unit_m = distance_unit_m
        self.firing_cycle_s = firing_cycle_s
        self.laser_time_s = laser_time_s
        self.packet_duration_s = BLOCKS_PER_PACKET * self.firings_per_block * firing_cycle_s
        """Time spanned by one single-return packet (s)."""
        self.laser_ring = np.argsort(np.argsort(elevation, kind="stable"),
                                     kind="stable").astype(np.int64)
        """Ring number (0 = lowest) of each laser id, (lasers,)."""
        self.ring_elevation_deg = np.sort(elevation)
        k = self.firings_per_block
        self.return_time_s = np.array(
            [[np.float32(firing_cycle_s * (k * i + j // lasers) + laser_time_s * (j % lasers))
              for j in range(RETURNS_PER_BLOCK)] for i in range(BLOCKS_PER_PACKET)],
            dtype=np.float32)
        """Time of each (block, return) after the first firing of block 0 (s), (12, 32)."""
        self.return_time_flat = self.return_time_s.ravel().astype(np.float64)
        self.dt_in_block_s = (self.return_time_s - self.return_time_s[:, :1]).ravel()
        """Each (block, return)'s time after its block's first firing, float32 (s), (384,)."""
        self.single_span_s = np.float32(self.return_time_s[BLOCKS_PER_PACKET - 1, 0]
                                        - self.return_time_s[0, 0])
        self.dual_span_s = np.float32(self.return_time_s[(BLOCKS_PER_PACKET - 1) // 2, 0]
                                      - self.return_time_s[0, 0])
        self.cos_el = np.cos(np.radians(elevation))
        self.sin_el = np.sin(np.radians(elevation))


VLP16_LAYOUT = VelodyneLayout("VLP-16", LASER_ELEVATION_DEG, LASER_VERTICAL_OFFSET_M,
                              FIRING_CYCLE_S, LASER_TIME_S, DISTANCE_UNIT_M)
"""The VLP-16 (the default everywhere in this module)."""


@dataclass(frozen=True, slots=True)
class ReturnWindow:
    """The returns a consumer can use, chosen while decoding, before their azimuth and x, y are
    computed (as the ROS velodyne driver's ``min_range`` / ``max_range``): horizontal range
    ``d cos(el)`` in [``min_range_m``, ``max_range_m``] and height ``z`` in [``z_min_m``,
    ``z_max_m``], sensor frame (m)."""

    min_range_m: float = 0.0
    max_range_m: float = math.inf
    z_min_m: float = -math.inf
    z_max_m: float = math.inf

    def inside(self, xy: NDArray[np.float64], z: NDArray[np.float64]) -> NDArray[np.intp]:
        """The indices of the returns (horizontal range ``xy``, height ``z``, (N,), m) inside."""
        return np.flatnonzero((xy >= self.min_range_m) & (xy <= self.max_range_m)
                              & (z >= self.z_min_m) & (z <= self.z_max_m))


@dataclass(frozen=True, slots=True)
class DecodedPackets:
    """The returns of one or more packets (empty returns, distance 0, are left out, and those
    outside the :class:`ReturnWindow` when one was given).

    ``points`` (N, 4): x, y, z (m, sensor frame), reflectivity (0..255);
    ``azimuth_deg`` (N,) each return's interpolated azimuth, [0, 360), clockwise from x;
    ``rings`` (N,) 0..15 by elevation; ``time_offset_s`` (N,) after the first firing of its
    packet; ``packet_index`` (N,) which of the given payloads it came from; ``returns`` the
    non-empty returns before the window.
    """

    points: NDArray[np.float64]
    azimuth_deg: NDArray[np.float64]
    rings: NDArray[np.int64]
    time_offset_s: NDArray[np.float64]
    packet_index: NDArray[np.int64]
    returns: int = 0


def check_packet(payload: bytes) -> tuple[int, ...]:
    """Raise :class:`DecodeError` unless ``payload`` is a well-formed VLP-16 data packet;
    return its 12 block azimuths (hundredths of a degree) and its timestamp (us past the
    hour), 13 ints."""
    if len(payload) != PACKET_SIZE:
        raise DecodeError(f"bad_length: VLP-16 data packet of {len(payload)} bytes, "
                          f"expected {PACKET_SIZE}")
    if payload[0:1200:100] != _FLAGS_FF or payload[1:1200:100] != _FLAGS_EE:
        raise DecodeError("bad_flag: a data block does not start with 0xFFEE")
    fields = _BLOCK_AZIMUTHS_AND_TIME.unpack_from(payload)
    top = max(fields[:BLOCKS_PER_PACKET])
    if top >= 36000:
        raise DecodeError(f"bad_azimuth: block azimuth {top} >= 36000")
    return fields


def decode_packets(payloads: Sequence[bytes], checked: bool = False,
                   window: ReturnWindow | None = None,
                   layout: VelodyneLayout = VLP16_LAYOUT) -> DecodedPackets:
    """Decode the data packets of the Velodyne ``layout`` (default VLP-16), vectorised over all
    of them; only the returns inside ``window`` when one is given.

    Raises :class:`DecodeError` (message starting with the reject reason ``bad_length``,
    ``bad_flag`` or ``bad_azimuth``) if any of them is malformed; ``checked=True`` skips the
    checks for packets that already passed :func:`check_packet`.
    """
    if not checked:
        for payload in payloads:
            check_packet(payload)
    n_packets = len(payloads)
    if n_packets == 0:
        empty = np.zeros(0)
        return DecodedPackets(np.zeros((0, 4)), empty, np.zeros(0, np.int64), empty,
                              np.zeros(0, np.int64))
    buf = b"".join(payloads)
    # block azimuths: uint16 at byte 2 + 100 b of each packet (all offsets even)
    words = np.frombuffer(buf, dtype="<u2").reshape(n_packets, PACKET_SIZE // 2)
    block_az = words[:, 1:600:50]  # (P, 12)
    mode = np.frombuffer(buf, dtype=np.uint8)[1204::PACKET_SIZE]
    rets = np.ndarray(shape=(n_packets, BLOCKS_PER_PACKET, RETURNS_PER_BLOCK), dtype=_RETURN,
                      buffer=buf, offset=4, strides=(PACKET_SIZE, BLOCK_SIZE, 3))
    distance = rets["d"]
    dual = mode == RETURN_MODE_DUAL
    any_dual = bool(dual.any())

    valid = distance > 0
    if any_dual:
        # keep the strongest return (odd blocks) only, so each ring is one line of returns
        valid &= (~dual[:, None] | (np.arange(BLOCKS_PER_PACKET)[None, :] % 2 == 1))[:, :, None]
    flat = np.flatnonzero(valid)
    returns = int(flat.size)
    laser_id = flat & (layout.lasers - 1)
    dist_m = distance.ravel()[flat] * layout.distance_unit_m
    xy = dist_m * layout.cos_el[laser_id]
    z = dist_m * layout.sin_el[laser_id] + layout.vertical_offset_m[laser_id]
    if window is not None:
        inside = window.inside(xy, z)
        flat, laser_id = flat[inside], laser_id[inside]
        xy, z = xy[inside], z[inside]

    # azimuth of each return: block azimuth + packet rotation rate x time since the block's
    # first firing, in float32 and rounded like velodyne-decoder; dual-return packets hold
    # each firing twice (blocks 2i, 2i+1) and span half the time
    packet_index = flat // (BLOCKS_PER_PACKET * RETURNS_PER_BLOCK)
    in_block = flat & (RETURNS_PER_BLOCK - 1)
    in_packet = flat - packet_index * (BLOCKS_PER_PACKET * RETURNS_PER_BLOCK)
    if any_dual:
        block = in_packet // RETURNS_PER_BLOCK
        timing = np.where(dual[packet_index], block // 2, block) * RETURNS_PER_BLOCK + in_block
    else:
        timing = in_packet
    az_diff = (block_az[:, -1].astype(np.int64) - block_az[:, 0] + 36000) % 36000
    duration = np.where(dual, layout.dual_span_s, layout.single_span_s)
    rate = az_diff.astype(np.float32) / duration  # (P,) hundredths of a degree per second
    az_f = (block_az.ravel().astype(np.float32)[flat // RETURNS_PER_BLOCK]
            + rate[packet_index] * layout.dt_in_block_s[timing])
    az_f += np.float32(36000)
    az_idx = np.floor(az_f.astype(np.float64) + 0.5).astype(np.int64) - 36000
    az_idx[az_idx >= 36000] -= 36000
    time_offset = layout.return_time_flat[timing]
    points = np.empty((flat.size, 4))
    points[:, 0] = xy * _COS_AZ[az_idx]
    points[:, 1] = -xy * _SIN_AZ[az_idx]
    points[:, 2] = z
    points[:, 3] = rets["r"].ravel()[flat]
    return DecodedPackets(
        points=points,
        azimuth_deg=az_idx * 0.01,
        rings=layout.laser_ring[laser_id],
        time_offset_s=time_offset,
        packet_index=packet_index,
        returns=returns,
    )


def decode_packet(
    payload: bytes,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.int64], NDArray[np.float64]]:
    """Decode one VLP-16 data packet.

    Returns ``(points (N, 4) x, y, z (m, sensor frame), reflectivity; azimuth_deg (N,);
    ring (N,); time_offset_s (N,) after the packet's first firing)``. Raises
    :class:`DecodeError` on a malformed packet.
    """
    d = decode_packets([payload])
    return d.points, d.azimuth_deg, d.rings, d.time_offset_s


def reject_reason(error: DecodeError) -> str:
    """The reject-counter key of a :class:`DecodeError` raised here (``bad_length``...)."""
    text = str(error)
    head = text.split(":", 1)[0]
    return head if head.isidentifier() else "undecodable"


class DeviceClock:
    """Maps the packets' own timestamps (us past the hour) onto the receiver's Clock.

    Arrival times jitter (the network batches datagrams) but are never earlier than the
    packet was complete, so the offset Clock - device is the smallest seen ``arrival -
    PACKET_DURATION_S - device``; it may grow by ``drift_ppm`` (clock drift). Packets later
    than the offset by more than ``reset_s`` are late (a stalled receiver reading the
    kernel's backlog in a burst): they keep the offset, and so the times they were made at,
    unless every packet stays that late for ``late_persist_s`` of arrival time, which is the
    device's clock having jumped back (then the offset is reset). The hour wrap of the device
    time is unwrapped (``hour_wrap=False``: stamps that never wrap, an Ouster's).

    ``packet_duration_s`` is the time from a packet's stamp to its sending (default the
    VLP-16's :data:`PACKET_DURATION_S`; another model's layout has its own).
    """

    def __init__(self, drift_ppm: float = 100.0, reset_s: float = 0.5,
                 late_persist_s: float = 1.0, packet_duration_s: float = PACKET_DURATION_S,
                 hour_wrap: bool = True) -> None:
        self.drift = drift_ppm * 1e-6
        self.packet_duration_s = packet_duration_s
        self.hour_wrap = hour_wrap
        self.reset_s = reset_s
        self.late_persist_s = late_persist_s
        self.offset_s: float | None = None
        self._last_device_s: float | None = None
        self._hours = 0
        self._late_since_s: float | None = None
        """Arrival time (s) of the first of the packets late by more than ``reset_s`` in a row."""

    def update(self, arrival_s: float, device_us: float) -> float:
        """Take a packet's arrival time (Clock, s) and timestamp; return its device time (s,
        unwrapped) and update the offset."""
        device_s = device_us * 1e-6 + 3600.0 * self._hours
        if (self.hour_wrap and self._last_device_s is not None
                and device_s < self._last_device_s - 1800.0):
            self._hours += 1
            device_s += 3600.0
        cand = arrival_s - self.packet_duration_s - device_s
        if self.offset_s is None or self._last_device_s is None:
            self.offset_s = cand
        elif cand > self.offset_s + self.reset_s:
            if self._late_since_s is None:
                self._late_since_s = arrival_s
            elif arrival_s - self._late_since_s > self.late_persist_s:
                self.offset_s = cand  # late for good: the device's clock went back
                self._late_since_s = None
        else:
            self._late_since_s = None
            grown = self.offset_s + self.drift * max(device_s - self._last_device_s, 0.0)
            self.offset_s = min(grown, cand)
        self._last_device_s = device_s
        return device_s

    def to_clock(self, device_s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Device times (s, as :meth:`update` returned them) on the Clock (s)."""
        return device_s + (self.offset_s or 0.0)


class SweepAssembler:
    """Packets to full 360 deg sweeps, cut where the azimuth passes ``cut_azimuth_deg``.

    The default cut is behind the car (180 deg), where the car body hides the view, so a cone
    ahead is never split between two sweeps. Packets are only checked on arrival (cheap); a
    sweep's packets are decoded together, vectorised, when it completes.

    ``add(timestamp_s, payload)`` takes the packet's arrival time on the Clock, at least
    ``layout.packet_duration_s`` after its first firing (the sensor sends a packet when it is
    full); return times come from the packet's own timestamp mapped onto the Clock by a
    :class:`DeviceClock`, so arrival jitter does not reach them. It returns the sweeps
    completed by this packet (usually none, sometimes one).
    A silence longer than ``max_gap_s`` ends the current sweep too. Raises
    :class:`DecodeError` on a bad packet (which is then not used).
    """

    def __init__(self, cut_azimuth_deg: float = 180.0, max_gap_s: float = 0.05,
                 window: ReturnWindow | None = None,
                 layout: VelodyneLayout = VLP16_LAYOUT) -> None:
        self.layout = layout
        """The model whose packets these are (default VLP-16)."""
        self.cut_hundredths = int(round(cut_azimuth_deg * 100.0)) % 36000
        self.max_gap_s = max_gap_s
        self.window = window
        """Only the returns inside it are decoded (None: all); see :class:`ReturnWindow`."""
        self._payloads: list[bytes] = []
        self._stamps: list[float] = []
        self._head_from: int | None = None
        """Relative azimuth where the first kept packet was cut (its earlier returns were the
        previous sweep's); None when it was not."""
        self._last_rel: int | None = None
        self._last_stamp: float | None = None
        self.sweeps = 0
        self.clock = DeviceClock(packet_duration_s=layout.packet_duration_s)

    def add(self, timestamp_s: float, payload: bytes) -> list[LidarPoints]:
        """Add one data packet; return the sweeps it completes."""
        return self.add_checked(timestamp_s, payload, check_packet(payload))

    def add_checked(self, timestamp_s: float, payload: bytes,
                    fields: tuple[int, ...]) -> list[LidarPoints]:
        """:meth:`add` for a packet that passed :func:`check_packet`, ``fields`` what it
        returned (the 12 block azimuths and the timestamp)."""
        done: list[LidarPoints] = []
        if (self._last_stamp is not None
                and (timestamp_s - self._last_stamp > self.max_gap_s
                     or timestamp_s < self._last_stamp)):
            done.extend(self.flush())
        cut = self.cut_hundredths
        first = (fields[0] - cut) % 36000
        last = (fields[BLOCKS_PER_PACKET - 1] - cut) % 36000
        if self._last_rel is not None and first < self._last_rel:
            # the cut lies between the previous packet and this one
            done.extend(self._complete(split_from=None))
        self._payloads.append(payload)
        self._stamps.append(self.clock.update(timestamp_s, fields[BLOCKS_PER_PACKET]))
        self._last_rel = last
        self._last_stamp = timestamp_s
        if last < first:
            # the cut lies inside this packet
            done.extend(self._complete(split_from=first))
        return done

    def flush(self) -> list[LidarPoints]:
        """Emit whatever has been collected as a (partial) sweep."""
        out = self._complete(split_from=None)
        self._last_rel = None
        self._last_stamp = None
        return out

    def _complete(self, split_from: int | None) -> list[LidarPoints]:
        """Close the sweep; with ``split_from`` (the last packet's first relative azimuth),
        that packet's returns past the cut belong to the next sweep: the packet is kept and
        opens the next sweep, which drops its returns before the cut (``_head_from``)."""
        payloads, stamps = self._payloads, self._stamps
        head_from, self._head_from = self._head_from, None
        self._payloads, self._stamps = [], []
        if not payloads:
            return []
        dec = decode_packets(payloads, checked=True, window=self.window, layout=self.layout)
        t0 = self.clock.to_clock(np.asarray(stamps, dtype=np.float64))
        times = t0[dec.packet_index] + dec.time_offset_s
        points, rings = dec.points, dec.rings
        keep: slice | NDArray[np.bool_] = slice(0, points.shape[0])
        if head_from is not None or split_from is not None:
            mask = np.ones(points.shape[0], dtype=bool)
            if head_from is not None:
                # the first packet was split by the previous cut: keep its returns past it
                head = int(np.searchsorted(dec.packet_index, 1))
                mask[:head] = self._rel_of(dec.azimuth_deg[:head]) < head_from
            if split_from is not None:
                # only the last packet's returns can lie past this cut
                tail = int(np.searchsorted(dec.packet_index, len(payloads) - 1))
                mask[tail:] &= self._rel_of(dec.azimuth_deg[tail:]) >= split_from
                self._payloads, self._stamps = [payloads[-1]], [stamps[-1]]
                self._head_from = split_from
            keep = _as_slice(mask)
        points, times, rings = points[keep], times[keep], rings[keep]
        span = self._span(payloads, t0, head_from, split_from, times)
        if span is None:
            return []
        self.sweeps += 1
        return [LidarPoints(timestamp_s=span[1], points=points, times_s=times, rings=rings,
                            return_count=dec.returns, start_s=span[0])]

    def _span(self, payloads: Sequence[bytes], t0: NDArray[np.float64], head_from: int | None,
              split_from: int | None, times: NDArray[np.float64]) -> tuple[float, float] | None:
        """Times (Clock, s) of the sweep's first and last returns, windowed out or not: the
        kept ``times`` and every return of the first and the last packet in this sweep (returns
        come in time order, so these hold the extremes unless a whole end packet is empty).
        None when the sweep has no return at all."""
        if self.window is None:
            return (float(times.min()), float(times.max())) if times.size else None
        ends = [times]
        for i in {0, len(payloads) - 1}:
            d = decode_packets([payloads[i]], checked=True, layout=self.layout)
            t = t0[i] + d.time_offset_s
            rel = self._rel_of(d.azimuth_deg)
            inside = np.ones(t.size, dtype=bool)
            if i == 0 and head_from is not None:
                inside &= rel < head_from
            if i == len(payloads) - 1 and split_from is not None:
                inside &= rel >= split_from
            ends.append(t[inside])
        every = np.concatenate(ends)
        return (float(every.min()), float(every.max())) if every.size else None

    def _rel_of(self, azimuth_deg: NDArray[np.float64]) -> NDArray[np.int64]:
        """Azimuths (deg) as hundredths of a degree past the cut."""
        return (np.round(azimuth_deg * 100.0).astype(np.int64) - self.cut_hundredths) % 36000


def _as_slice(mask: NDArray[np.bool_]) -> slice | NDArray[np.bool_]:
    """``mask`` as a slice when its True entries are one run (a view instead of a copy: the
    returns of a packet come in azimuth order, so a cut leaves a prefix or a suffix)."""
    idx = np.flatnonzero(mask)
    if idx.size == 0:
        return slice(0, 0)
    lo, hi = int(idx[0]), int(idx[-1]) + 1
    return slice(lo, hi) if hi - lo == idx.size else mask
