"""Ouster OS1 lidar packets in the legacy format: metadata, vectorised decoding, sweeps.

The legacy lidar data format (``LEGACY``, the only one of firmware 1.x) sends each packet to
UDP port 7502 as ``columns_per_packet`` measurement columns (16 on firmware 1.x), each of
``16 + 12 h + 4`` bytes for ``h`` beams (``pixels_per_column``, 64 for an OS1-64; 12 608 bytes
a packet), all little-endian:

- column header: timestamp (uint64, ns), measurement id (uint16, the column's place in the
  frame, 0 .. w-1), frame id (uint16), encoder count (uint32, 90 112 a turn);
- ``h`` pixels of 12 bytes, beam 0 (the highest) first: range (uint32, its low 20 bits, mm;
  0 = no return), reflectivity (uint16), signal (uint16, photons), near-infrared (uint16),
  2 bytes unused;
- column status (uint32): 0xFFFFFFFF for a good column; bit 0 clear = no data in it.

The beam angles come from the sensor's metadata JSON (:func:`load_meta`): every layout Ouster
has written is read (the early one of firmware 1.x with only ``beam_altitude_angles``,
``beam_azimuth_angles`` and ``lidar_mode``; the later ones with ``data_format``,
``lidar_to_sensor_transform``, ``lidar_origin_to_beam_origin_mm`` or ``beam_intrinsics`` /
``lidar_intrinsics`` / ``config_params``). What the file does not give takes ouster-sdk's
default for an OS1: the lidar-to-sensor transform (a half turn about z and 36.18 mm up) and a
beam origin 12.163 mm from the lidar's axis.

Points: x, y, z (m) in the SENSOR frame exactly as ouster-sdk's ``XYZLut`` gives them by
default (Ouster Sensor Frame: x away from the connector, y left, z up; origin at the bottom
of the sensor's base plate), for the pixel of column ``m`` and beam ``u`` at range ``r`` (mm)::

    theta_e = 2 pi (1 - m / w)              encoder angle
    theta_a = -beam_azimuth[u]              phi = beam_altitude[u]
    d = (cos(theta_e + theta_a) cos phi, sin(theta_e + theta_a) cos phi, sin phi)
    p_lidar = (r - n) d + (b_x cos theta_e, b_x sin theta_e, b_z)
    p_sensor = R p_lidar + t                (lidar_to_sensor_transform), / 1000

with ``b_x, b_z`` the beam-to-lidar translation and ``n = |(b_x, b_z)|`` (the beam origin
offset). The 4th column is the signal (photons), as the Ouster ROS driver's ``intensity``.
Seen from above the sensor turns clockwise; with the default transform column 0 looks
backwards (azimuth 180 deg, the connector side) and column w/2 forwards, so a sweep cut at
180 deg is one frame. ``rings`` number the beams by altitude, 0 = the lowest.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from common.errors import ConfigError, DecodeError
from common.messages import LidarPoints
from sensors.velodyne import DeviceClock, ReturnWindow

DATA_PORT = 7502
"""The UDP port an Ouster sends its lidar packets to (IMU packets: 7503)."""
IMU_PORT = 7503
IMU_PACKET_SIZE = 48
"""Bytes in one legacy IMU packet."""
COLUMN_HEADER_SIZE = 16
PIXEL_SIZE = 12
COLUMN_FOOTER_SIZE = 4
LEGACY_COLUMNS_PER_PACKET = 16
"""Measurement columns in one legacy packet (firmware 1.x)."""
RANGE_MASK = 0x000FFFFF
"""The bits of the range word that hold the range (mm); the others are flags."""
STATUS_VALID = 0x1
ENCODER_TICKS_PER_TURN = 90112
DEFAULT_LIDAR_TO_SENSOR = (-1.0, 0.0, 0.0, 0.0,
                           0.0, -1.0, 0.0, 0.0,
                           0.0, 0.0, 1.0, 36.18,
                           0.0, 0.0, 0.0, 1.0)
"""ouster-sdk's lidar-to-sensor transform when the metadata has none (row-major, mm)."""
DEFAULT_BEAM_ORIGIN_MM = 12.163
"""ouster-sdk's distance from the lidar's axis to the beams' origin for an OS1 when the
metadata has none (mm)."""
OTHER_BEAM_COUNTS = (16, 32, 64, 128)
"""Beam counts of the OS1 family: a legacy packet of another count is another sensor."""


def column_size(beams: int) -> int:
    """Bytes in one legacy measurement column of ``beams`` pixels."""
    return COLUMN_HEADER_SIZE + PIXEL_SIZE * beams + COLUMN_FOOTER_SIZE


def legacy_beams_of_size(size: int) -> int | None:
    """The beam count of a legacy Ouster packet of ``size`` bytes (16 columns), None if no
    OS1 sends packets of that size."""
    for beams in OTHER_BEAM_COUNTS:
        if size == LEGACY_COLUMNS_PER_PACKET * column_size(beams):
            return beams
    return None


def _default_to_sensor() -> NDArray[np.float64]:
    return np.asarray(DEFAULT_LIDAR_TO_SENSOR, dtype=np.float64).reshape(4, 4)


def _beam_to_lidar(origin_mm: float) -> NDArray[np.float64]:
    """The beam-to-lidar transform of a beam origin ``origin_mm`` out along x (mm)."""
    out = np.eye(4)
    out[0, 3] = origin_mm
    return out


@dataclass(frozen=True, slots=True, eq=False)
class OusterMeta:
    """What decoding needs from an Ouster's metadata (angles in degrees, lengths in mm)."""

    source: str
    """Where it was read from (for messages)."""
    beam_altitude_deg: NDArray[np.float64]
    """Each beam's elevation (deg), (h,), beam 0 first (the highest)."""
    beam_azimuth_deg: NDArray[np.float64]
    """Each beam's azimuth offset (deg), (h,)."""
    columns_per_frame: int
    """Columns in one turn, w (the mode's first number: 512, 1024, 2048)."""
    rotation_hz: float
    """Turns per second (the mode's second number: 10 or 20)."""
    columns_per_packet: int = LEGACY_COLUMNS_PER_PACKET
    lidar_to_sensor: NDArray[np.float64] = field(default_factory=lambda: _default_to_sensor())
    """Lidar frame to sensor frame (4, 4), translation in mm."""
    beam_to_lidar: NDArray[np.float64] = field(default_factory=lambda: _beam_to_lidar(
        DEFAULT_BEAM_ORIGIN_MM))
    """Beam origin in the lidar frame (4, 4), translation in mm."""

    @property
    def beams(self) -> int:
        """Pixels per column, h."""
        return int(self.beam_altitude_deg.shape[0])

    @property
    def packet_size(self) -> int:
        """Bytes in one lidar packet."""
        return self.columns_per_packet * column_size(self.beams)

    @property
    def column_period_s(self) -> float:
        """Time between two columns (s)."""
        return 1.0 / (self.rotation_hz * self.columns_per_frame)


def _get(obj: dict[str, Any], *paths: str) -> Any:
    """The first of the dotted ``paths`` present in ``obj`` (None: none is)."""
    for path in paths:
        node: Any = obj
        for key in path.split("."):
            if not isinstance(node, dict) or key not in node:
                break
            node = node[key]
        else:
            return node
    return None


def _angles(obj: dict[str, Any], key: str, source: str) -> NDArray[np.float64]:
    value = _get(obj, key, f"beam_intrinsics.{key}")
    if value is None:
        raise ConfigError(f"{source}: Ouster metadata has no {key!r} (the beams' angles in "
                          "degrees, one per beam)")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ConfigError(f"{source}: Ouster metadata {key!r} is not a list of numbers") from None
    if arr.ndim != 1 or arr.size == 0 or not np.isfinite(arr).all():
        raise ConfigError(f"{source}: Ouster metadata {key!r} is not a list of finite numbers")
    return arr


def _matrix(obj: dict[str, Any], paths: tuple[str, ...], source: str
            ) -> NDArray[np.float64] | None:
    value = _get(obj, *paths)
    if value is None:
        return None
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(4, 4)
    except (TypeError, ValueError):
        raise ConfigError(f"{source}: Ouster metadata {paths[0]!r} is not 16 numbers (a 4x4 "
                          "matrix, row by row)") from None
    if not np.isfinite(arr).all():
        raise ConfigError(f"{source}: Ouster metadata {paths[0]!r} has a non-finite number")
    return arr


def parse_meta(obj: Any, source: str = "metadata") -> OusterMeta:
    """An :class:`OusterMeta` from a metadata JSON object; raises :class:`ConfigError` (one line
    naming the key) when something needed is missing or malformed."""
    if not isinstance(obj, dict):
        raise ConfigError(f"{source}: Ouster metadata is not a JSON object")
    profile = _get(obj, "data_format.udp_profile_lidar", "lidar_data_format.udp_profile_lidar",
                   "config_params.udp_profile_lidar")
    if profile not in (None, "LEGACY"):
        raise ConfigError(f"{source}: lidar data format {profile!r}: only the legacy format "
                          "(LEGACY, firmware 1.x) is decoded")
    altitude = _angles(obj, "beam_altitude_angles", source)
    azimuth = _angles(obj, "beam_azimuth_angles", source)
    if altitude.size != azimuth.size:
        raise ConfigError(f"{source}: Ouster metadata has {altitude.size} beam altitude angles "
                          f"but {azimuth.size} azimuth angles")
    mode = _get(obj, "lidar_mode", "config_params.lidar_mode")
    width = _get(obj, "data_format.columns_per_frame", "lidar_data_format.columns_per_frame")
    rate_hz = 10.0
    if isinstance(mode, str) and "x" in mode:
        try:
            cols_text, rate_text = mode.lower().split("x", 1)
            width, rate_hz = int(cols_text), float(rate_text)
        except ValueError:
            raise ConfigError(f"{source}: Ouster metadata lidar_mode {mode!r} is not like "
                              "'1024x10'") from None
    if not isinstance(width, int) or width <= 0 or not math.isfinite(rate_hz) or rate_hz <= 0:
        raise ConfigError(f"{source}: Ouster metadata has no 'lidar_mode' (like '1024x10': "
                          "columns per turn x turns per second)")
    per_packet = _get(obj, "data_format.columns_per_packet",
                      "lidar_data_format.columns_per_packet")
    per_packet = LEGACY_COLUMNS_PER_PACKET if per_packet is None else per_packet
    pixels = _get(obj, "data_format.pixels_per_column", "lidar_data_format.pixels_per_column")
    if not isinstance(per_packet, int) or per_packet <= 0 or width % per_packet:
        raise ConfigError(f"{source}: Ouster metadata columns_per_packet {per_packet!r} does "
                          f"not divide the {width} columns of a frame")
    if pixels is not None and pixels != altitude.size:
        raise ConfigError(f"{source}: Ouster metadata pixels_per_column {pixels!r} but "
                          f"{altitude.size} beam angles")
    to_sensor = _matrix(obj, ("lidar_to_sensor_transform",
                              "lidar_intrinsics.lidar_to_sensor_transform"), source)
    beam_to_lidar = _matrix(obj, ("beam_to_lidar_transform",
                                  "beam_intrinsics.beam_to_lidar_transform"), source)
    if beam_to_lidar is None:
        origin = _get(obj, "lidar_origin_to_beam_origin_mm",
                      "beam_intrinsics.lidar_origin_to_beam_origin_mm")
        if origin is None:
            origin = DEFAULT_BEAM_ORIGIN_MM
        if not isinstance(origin, (int, float)) or not math.isfinite(origin):
            raise ConfigError(f"{source}: Ouster metadata lidar_origin_to_beam_origin_mm "
                              f"{origin!r} is not a number")
        beam_to_lidar = _beam_to_lidar(float(origin))
    return OusterMeta(
        source=source, beam_altitude_deg=altitude, beam_azimuth_deg=azimuth,
        columns_per_frame=int(width), rotation_hz=float(rate_hz),
        columns_per_packet=int(per_packet),
        lidar_to_sensor=to_sensor if to_sensor is not None else _default_to_sensor(),
        beam_to_lidar=beam_to_lidar)


def load_meta(path: str | Path) -> OusterMeta:
    """Read an Ouster metadata JSON file; :class:`ConfigError` (one line) if it cannot be read
    or lacks what decoding needs."""
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the Ouster metadata file ({exc})") from None
    try:
        obj = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: the Ouster metadata file is not JSON ({exc})") from None
    return parse_meta(obj, str(path))


class OusterGeometry:
    """The unit vector and offset of every pixel (column, beam) of a frame, as ouster-sdk's
    ``XYZLut`` (see the module docstring); the sensor-frame point of a range ``r`` (mm) is
    ``r * direction + offset`` (m)."""

    def __init__(self, meta: OusterMeta) -> None:
        self.meta = meta
        w, h = meta.columns_per_frame, meta.beams
        encoder = (2.0 * np.pi - np.arange(w) * (2.0 * np.pi / w))[:, None]  # (w, 1)
        azimuth = -np.radians(meta.beam_azimuth_deg)[None, :]  # (1, h)
        altitude = np.radians(meta.beam_altitude_deg)[None, :]
        direction = np.empty((w, h, 3))
        direction[..., 0] = np.cos(encoder + azimuth) * np.cos(altitude)
        direction[..., 1] = np.sin(encoder + azimuth) * np.cos(altitude)
        direction[..., 2] = np.broadcast_to(np.sin(altitude), (w, h))
        bx, bz = float(meta.beam_to_lidar[0, 3]), float(meta.beam_to_lidar[2, 3])
        n = math.hypot(bx, bz) if bz != 0.0 else bx
        offset = np.empty((w, h, 3))
        offset[..., 0] = np.cos(encoder) * bx - direction[..., 0] * n
        offset[..., 1] = np.sin(encoder) * bx - direction[..., 1] * n
        offset[..., 2] = -direction[..., 2] * n + bz
        rot = meta.lidar_to_sensor[:3, :3]
        trans = meta.lidar_to_sensor[:3, 3]
        self.direction = (direction.reshape(-1, 3) @ rot.T) * 1e-3
        """(w h, 3), row ``column * h + beam``: metres of sensor frame per mm of range."""
        self.offset = (offset.reshape(-1, 3) @ rot.T + trans) * 1e-3
        """(w h, 3), row ``column * h + beam`` (m)."""
        self.laser_ring = np.argsort(np.argsort(meta.beam_altitude_deg, kind="stable"),
                                     kind="stable").astype(np.int64)
        """Ring (0 = the lowest beam) of each beam, (h,)."""
        # the azimuth (deg, clockwise from the sensor's x) each column looks along
        enc = encoder[:, 0]
        look = rot[:2, :2] @ np.vstack([np.cos(enc), np.sin(enc)])
        self.column_azimuth_deg = np.degrees(-np.arctan2(look[1], look[0])) % 360.0
        """(w,): clockwise from x, as the Velodyne's azimuths."""
        pixel = np.dtype([("range", "<u4"), ("reflectivity", "<u2"), ("signal", "<u2"),
                          ("near_ir", "<u2"), ("unused", "<u2")])
        self.column_dtype = np.dtype([("timestamp", "<u8"), ("measurement_id", "<u2"),
                                      ("frame_id", "<u2"), ("encoder", "<u4"),
                                      ("pixels", pixel, (h,)), ("status", "<u4")])
        assert self.column_dtype.itemsize == column_size(h)

    def first_column_from(self, cut_azimuth_deg: float) -> int:
        """The first column at or clockwise past ``cut_azimuth_deg`` (deg)."""
        rel = (self.column_azimuth_deg - cut_azimuth_deg + 1e-9) % 360.0
        return int(np.argmin(rel))

    def columns(self, payloads: Sequence[bytes]) -> NDArray[Any]:
        """The packets' columns as a structured array (P, columns_per_packet)."""
        size = self.meta.packet_size
        buf = b"".join(payloads)
        return np.frombuffer(buf, dtype=self.column_dtype).reshape(
            len(payloads), size // self.column_dtype.itemsize)


@dataclass(frozen=True, slots=True)
class OusterPacketInfo:
    """What :func:`check_packet` reads from a packet's column headers."""

    first_column: int
    """Measurement id of its first good column."""
    last_column: int
    """Measurement id of its last good column."""
    frame_id: int
    """Frame id of its first good column."""
    last_timestamp_ns: int
    """Timestamp of its last good column (ns, the sensor's clock)."""


def check_packet(payload: bytes, geometry: OusterGeometry) -> OusterPacketInfo | None:
    """Raise :class:`DecodeError` (``bad_length``, ``bad_column``) unless ``payload`` is a
    well-formed legacy lidar packet of this sensor; None when none of its columns is good
    (status bit 0 clear: nothing to decode)."""
    meta = geometry.meta
    if len(payload) != meta.packet_size:
        raise DecodeError(f"bad_length: Ouster lidar packet of {len(payload)} bytes, expected "
                          f"{meta.packet_size} ({meta.columns_per_packet} columns of "
                          f"{meta.beams} beams)")
    cols = geometry.columns([payload])[0]
    good = np.flatnonzero(cols["status"] & STATUS_VALID)
    if good.size == 0:
        return None
    ids = cols["measurement_id"][good].astype(np.int64)
    if int(ids.max()) >= meta.columns_per_frame:
        raise DecodeError(f"bad_column: measurement id {int(ids.max())} >= "
                          f"{meta.columns_per_frame} columns per frame")
    if np.any(ids - good != ids[0] - good[0]):
        raise DecodeError("bad_column: the measurement ids of a packet's columns do not follow "
                          "one another")
    return OusterPacketInfo(int(ids[0]), int(ids[-1]), int(cols["frame_id"][good[0]]),
                            int(cols["timestamp"][good[-1]]))


@dataclass(frozen=True, slots=True)
class DecodedOuster:
    """The returns (range > 0 in a good column) of one or more packets.

    ``points`` (N, 4): x, y, z (m, sensor frame), signal (photons); ``rings`` (N,) 0 = the
    lowest beam; ``timestamp_ns`` (N,) the column's time (sensor clock, ns);
    ``measurement_id`` (N,) the column; ``beam`` (N,) the pixel row (0 = highest);
    ``frame_id`` (N,); ``packet_index`` (N,) which payload; ``returns`` the count before any
    window chose some.
    """

    points: NDArray[np.float64]
    rings: NDArray[np.int64]
    timestamp_ns: NDArray[np.int64]
    measurement_id: NDArray[np.int64]
    beam: NDArray[np.int64]
    frame_id: NDArray[np.int64]
    packet_index: NDArray[np.int64]
    returns: int = 0


def decode_packets(payloads: Sequence[bytes], geometry: OusterGeometry,
                   window: ReturnWindow | None = None,
                   keep_columns: NDArray[np.bool_] | None = None) -> DecodedOuster:
    """Decode legacy lidar packets that passed :func:`check_packet`, vectorised over all of
    them; only the columns ``keep_columns`` (P, columns_per_packet) when given, and the returns
    inside ``window`` when one is given."""
    h = geometry.meta.beams
    if not payloads:
        none = np.zeros(0, np.int64)
        return DecodedOuster(np.zeros((0, 4)), none, none, none, none, none, none)
    cols = geometry.columns(payloads)  # (P, C)
    good = (cols["status"] & STATUS_VALID) != 0
    if keep_columns is not None:
        good &= keep_columns
    rng = cols["pixels"]["range"] & RANGE_MASK  # (P, C, h)
    valid = (rng > 0) & good[:, :, None]
    flat = np.flatnonzero(valid)
    column_flat = flat // h
    beam = flat - column_flat * h
    mid = cols["measurement_id"].ravel()[column_flat].astype(np.int64)
    pixel = mid * h + beam
    r_mm = rng.ravel()[flat].astype(np.float64)
    xyz = r_mm[:, None] * geometry.direction[pixel] + geometry.offset[pixel]
    returns = int(flat.size)
    if window is not None:
        inside = window.inside(np.hypot(xyz[:, 0], xyz[:, 1]), xyz[:, 2])
        flat, column_flat, beam, mid = (flat[inside], column_flat[inside], beam[inside],
                                        mid[inside])
        xyz = xyz[inside]
    points = np.empty((flat.size, 4))
    points[:, :3] = xyz
    points[:, 3] = cols["pixels"]["signal"].ravel()[flat]
    per_packet = cols.shape[1]
    return DecodedOuster(
        points=points,
        rings=geometry.laser_ring[beam],
        timestamp_ns=cols["timestamp"].ravel()[column_flat].astype(np.int64),
        measurement_id=mid,
        beam=beam,
        frame_id=cols["frame_id"].ravel()[column_flat].astype(np.int64),
        packet_index=column_flat // per_packet,
        returns=returns,
    )


class OusterSweepAssembler:
    """Packets to full turns, cut at the first column past ``cut_azimuth_deg`` (default 180 deg,
    behind the car: with the default transform, Ouster's own frame boundary).

    ``add(timestamp_s, payload)`` takes the packet's arrival time on the Clock and returns the
    sweeps it completes (:class:`~common.messages.LidarPoints`); a silence longer than
    ``max_gap_s`` ends the current sweep too. The returns' times are the columns' own
    timestamps mapped onto the Clock by a :class:`~sensors.velodyne.DeviceClock`. Packets are
    only checked on arrival; a sweep's packets are decoded together when it completes. Raises
    :class:`DecodeError` on a bad packet (which is then not used).
    """

    def __init__(self, meta: OusterMeta, cut_azimuth_deg: float = 180.0,
                 max_gap_s: float = 0.05, window: ReturnWindow | None = None) -> None:
        self.geometry = OusterGeometry(meta)
        self.cut_column = self.geometry.first_column_from(cut_azimuth_deg)
        self.max_gap_s = max_gap_s
        self.window = window
        self.clock = DeviceClock(packet_duration_s=0.0, hour_wrap=False)
        self.sweeps = 0
        self._payloads: list[bytes] = []
        self._ranges: list[tuple[int, int]] = []
        """Per kept packet, the measurement ids [lo, hi) of its columns in this sweep (relative
        to the cut)."""
        self._last_rel: int | None = None
        self._last_stamp: float | None = None

    def add(self, timestamp_s: float, payload: bytes) -> list[LidarPoints]:
        """Add one lidar packet; return the sweeps it completes."""
        info = check_packet(payload, self.geometry)
        return [] if info is None else self.add_checked(timestamp_s, payload, info)

    def add_checked(self, timestamp_s: float, payload: bytes,
                    info: OusterPacketInfo) -> list[LidarPoints]:
        """:meth:`add` for a packet that passed :func:`check_packet` (``info``, not None)."""
        done: list[LidarPoints] = []
        if (self._last_stamp is not None
                and (timestamp_s - self._last_stamp > self.max_gap_s
                     or timestamp_s < self._last_stamp)):
            done.extend(self.flush())
        w = self.geometry.meta.columns_per_frame
        first = (info.first_column - self.cut_column) % w
        last = (info.last_column - self.cut_column) % w
        if self._last_rel is not None and first <= self._last_rel:
            done.extend(self._complete())  # the cut lies between the previous packet and this
        self.clock.update(timestamp_s, info.last_timestamp_ns / 1000.0)
        self._last_rel = last
        self._last_stamp = timestamp_s
        if last < first:
            # the cut lies inside this packet: its columns before it close this sweep
            self._payloads.append(payload)
            self._ranges.append((first, w))
            done.extend(self._complete())
            self._payloads.append(payload)
            self._ranges.append((0, last + 1))
        else:
            self._payloads.append(payload)
            self._ranges.append((first, last + 1))
        return done

    def flush(self) -> list[LidarPoints]:
        """Emit whatever has been collected as a (partial) sweep."""
        out = self._complete()
        self._last_rel = None
        self._last_stamp = None
        return out

    def _complete(self) -> list[LidarPoints]:
        payloads, ranges = self._payloads, self._ranges
        self._payloads, self._ranges = [], []
        if not payloads:
            return []
        w = self.geometry.meta.columns_per_frame
        cols = self.geometry.columns(payloads)
        rel = (cols["measurement_id"].astype(np.int64) - self.cut_column) % w  # (P, C)
        bounds = np.asarray(ranges, dtype=np.int64)
        keep = (rel >= bounds[:, :1]) & (rel < bounds[:, 1:])
        dec = decode_packets(payloads, self.geometry, self.window, keep)
        every = cols["timestamp"][keep & ((cols["status"] & STATUS_VALID) != 0)]
        if every.size == 0:
            return []
        to_clock = self.clock.to_clock
        times = to_clock(dec.timestamp_ns.astype(np.float64) * 1e-9)
        start_s = float(to_clock(np.array([every.min() * 1e-9]))[0])
        end_s = float(to_clock(np.array([every.max() * 1e-9]))[0])
        self.sweeps += 1
        return [LidarPoints(timestamp_s=end_s, points=dec.points, times_s=times,
                            rings=dec.rings, return_count=dec.returns, start_s=start_s)]
