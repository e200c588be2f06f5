"""Simulated Velodyne VLP-16: real 1206-byte data packets from ray-casting cones and the ground.

The sensor sits ``car.lidar_x_m`` ahead of the vehicle origin, ``car.lidar_z_m`` above a flat
ground (seed 000, 3.2: low at the front), level, turning clockwise (seen from above) at
``config.sim.lidar.rpm`` (600 rpm = 10 Hz). Timing follows the VLP-16 manual: a firing
sequence of the 16 lasers every 55.296 us (lasers 2.304 us apart), two sequences per data
block, 12 blocks per packet: a packet every 1.327104 ms (753.5 packets/s, about 75 per sweep),
0.2 deg between firing sequences at 600 rpm. Lasers have the VLP-16's elevation table and
vertical offsets (:mod:`sensors.velodyne`), so a decoder puts every return exactly on the
surface it was cast against.

Each ray hits the nearest of: the ground (lasers pointing down; a flat plane, so its range
per laser is a constant), a cone (a right circular cone: small 228 mm base x 325 mm, large
285 x 505 mm; exact ray-cone intersection), or the car body (rays pointing back over the car,
more than ``BODY_HALF_ANGLE_DEG`` off the nose, end on the car within its footprint). Cones
occlude each other because the nearest hit wins. Only cones within ``CONE_RANGE_M`` are cast;
per firing sequence only the cones whose horizontal disc the ray's vertical plane crosses.
Rays that hit nothing within ``config.sim.lidar.max_range_m`` return nothing (distance 0).

The car moves during a sweep: each firing sequence uses the car's pose at its own time,
taken back from the ground truth of the poll at which its packet completed, with that truth's
velocity and yaw rate (exact for constant speed and turn rate; polls come every physics step,
5 ms apart, so no pose is carried over more than a step and a packet). Nothing is cast ahead
of time: a packet is cast once it is complete, so its pose never rests on an extrapolation.

Range noise ``range_sigma_m`` (Gaussian per return; ``noise = False`` or sigma 0 turns it
off), distance quantisation 2 mm, per-return dropout ``dropout_prob`` and whole-packet loss
``packet_loss_prob``. ``dead = True`` (the lidar-dead fault) stops all packets.

Each :class:`RawBytes` is stamped with the packet's arrival time: its first firing plus
:data:`~sensors.velodyne.PACKET_DURATION_S` (the sensor sends a packet once it is full). The
packet's own timestamp is the first firing in microseconds past the hour of simulated time.

Sweep units (``sweep_units=True``, the closed-loop simulation's, issue 42): instead of one unit
per packet, the packets are held until the poll at which one of them completes a sweep (its
azimuths pass ``sensors.lidar.cut_azimuth_deg``, where the parser closes a sweep) and handed
out as ONE :class:`RawBytes` whose payload is those packets back to back (n x 1206 bytes),
stamped with the arrival of the last. The packets are the same bytes as one unit each would
carry (the range noise of a packet depends on its number alone), the sweep reaches the parser
at the same poll, and the whole sweep is cast, checked, handed to the recorder and parsed in
one piece instead of about 75 (:class:`sensors.lidar_parser.SweepSource` reads such a unit as
its packets, each arrived its device-time gap before the last).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from common.messages import ConeSize, GroundTruth, RawBytes
from sensors.velodyne import (
    BLOCK_DURATION_S,
    BLOCKS_PER_PACKET,
    DISTANCE_UNIT_M,
    FIRING_CYCLE_S,
    LASER_ELEVATION_DEG,
    LASER_TIME_S,
    LASER_VERTICAL_OFFSET_M,
    LASERS,
    PACKET_DURATION_S,
    PACKET_SIZE,
    PRODUCT_VLP16,
    RETURN_MODE_STRONGEST,
)
from simulator.config import WorldConfig

CONE_RANGE_M = 30.0
"""Cones farther than this (horizontally) from the sensor at a firing are not hit (m)."""
BODY_HALF_ANGLE_DEG = 110.0
"""Rays more than this off the nose (deg) point back over the car and hit its body."""
SMALL_CONE = (0.228 / 2.0, 0.325)
LARGE_CONE = (0.285 / 2.0, 0.505)
"""(base radius, height) of each cone size (m)."""
GROUND_REFLECTIVITY = 12
CONE_REFLECTIVITY = 70
BODY_REFLECTIVITY = 40

_SIN_EL = np.sin(np.radians(LASER_ELEVATION_DEG))
_COS_EL = np.cos(np.radians(LASER_ELEVATION_DEG))
_TAN_EL = np.tan(np.radians(LASER_ELEVATION_DEG))
_FIRINGS_PER_PACKET = 2 * BLOCKS_PER_PACKET
_NOISE_TABLE_SIZE = 1 << 18
EMULATOR_LOOKAHEAD_S = 0.02
"""The emulator's ``lookahead_s`` (one datagram per packet): about 19 packets a cast. No more:
at 0.05 s an accelerating car's cones were a centimetre off (FSG SLAM NEES out of its band)."""
_NOISE_HASH = 2654435761
"""Knuth's multiplicative hash: packet number to the start of its noise in the table."""


class _Motion(NamedTuple):
    """Ground truths a batch's poses are taken from, one row per firing sequence (arrays of
    the same shape): time (s), position (m), yaw (rad), body velocity (m/s), yaw rate (rad/s)."""

    t_s: NDArray[np.float64]
    x_m: NDArray[np.float64]
    y_m: NDArray[np.float64]
    yaw_rad: NDArray[np.float64]
    vx_mps: NDArray[np.float64]
    vy_mps: NDArray[np.float64]
    yaw_rate_radps: NDArray[np.float64]


def _motion(truths: list[GroundTruth], per_firing: NDArray[np.int64]) -> _Motion:
    """The truths ``truths[per_firing[i]]`` as a :class:`_Motion` (one row per firing)."""
    table = np.array([(tr.timestamp_s, tr.x_m, tr.y_m, tr.yaw_rad, tr.vx_mps, tr.vy_mps,
                       tr.yaw_rate_radps) for tr in truths], dtype=np.float64)
    rows = table[per_firing]
    return _Motion(*(rows[:, j] for j in range(7)))


class LidarModel:
    """Emits the VLP-16 data packets completed by each ``poll`` time; deterministic for a seed.

    ``sweep_units``: one :class:`RawBytes` per sweep instead of one per packet (see the module
    docstring); ``cut_azimuth_deg`` is where the parser closes its sweeps (deg, clockwise from
    the nose; ``sensors.lidar.cut_azimuth_deg``).
    """

    def __init__(self, config: WorldConfig, rng: np.random.Generator,
                 sweep_units: bool = False) -> None:
        self.cfg = config.sim.lidar
        self.rng = rng
        self.sweep_units = sweep_units
        self.lidar_x_m = config.car.lidar_x_m
        self.lidar_z_m = config.car.lidar_z_m
        self.car_length_m = config.car.length_m
        self.car_width_m = config.car.width_m
        self.rear_overhang_m = config.car.rear_overhang_m
        self.enabled = self.cfg.enabled and self.cfg.rpm > 0
        self.rate_hz = self.cfg.rpm / 60.0
        self.noise = True
        """False: no range noise (exactness tests)."""
        self.range_sigma_m = self.cfg.range_sigma_m
        self.max_range_m = min(self.cfg.max_range_m, 65535 * DISTANCE_UNIT_M)
        self.dead = False
        """Fault switch (lidar-dead): while True nothing is sent."""
        self.dropout_prob = self.cfg.dropout_prob
        self.packet_loss_prob = self.cfg.packet_loss_prob
        self.start_azimuth_deg = 180.0
        """Azimuth at t = 0 (deg, clockwise from the nose)."""
        sensors = getattr(config, "sensors", None)
        cut_deg = sensors.lidar.cut_azimuth_deg if sensors is not None else 180.0
        self.cut_hundredths = int(round(cut_deg * 100.0)) % 36000
        """Where sweep units end: the parser's cut (hundredths of a degree)."""
        self._next_k = 0
        """The first packet not yet sent nor dropped."""
        self._held: list[tuple[int, GroundTruth]] = []
        """Sweep units: (last packet completed at a poll, that poll's truth) since the first
        held packet ``_held_k0``, cast when the sweep completes."""
        self._held_k0 = 0
        self._cut_k = -1
        """Sweep units: the next packet that completes a sweep at the parser."""
        self.lookahead_s = 0.0
        """One unit per packet: packets are cast in batches reaching this far past a poll (s),
        their poses carried forward from its truth (fewer, larger casts: the emulator's
        :data:`EMULATOR_LOOKAHEAD_S`); 0: each poll casts what completed since the last."""
        self._next_gen = 0
        self._pending: deque[tuple[int, bytes]] = deque()
        # per laser: origin height above the ground and the (3-D) range to the ground
        self._laser_h = self.lidar_z_m + LASER_VERTICAL_OFFSET_M
        with np.errstate(divide="ignore"):
            ground = np.where(_SIN_EL < 0, -self._laser_h / _SIN_EL, np.inf)
        self._ground_range = ground if self.cfg.ground else np.full(LASERS, np.inf)
        # firing times inside a packet: (24,) sequence starts, (16,) laser offsets
        seq = np.arange(_FIRINGS_PER_PACKET)
        self._seq_t = (seq // 2) * BLOCK_DURATION_S + (seq % 2) * FIRING_CYCLE_S
        self._laser_t = np.arange(LASERS) * LASER_TIME_S
        self._static_raw, self._static_refl = self._static_scene()
        self._unit_noise = rng.standard_normal(_NOISE_TABLE_SIZE)
        self._noise_key = int(rng.integers(0, 1 << 31))
        """Packet k's range noise starts at a table offset hashed from k and this key, so a
        packet's noise does not depend on the batch it is cast in."""
        self._noise_sigma = math.nan
        self._noise_raw = np.zeros(0, dtype=np.int32)
        """Range noise in 2 mm units, drawn once (``_unit_noise`` scaled)."""
        self._max_raw = int(self.max_range_m / DISTANCE_UNIT_M)
        self._laser_drad = 2.0 * math.pi * self.rate_hz * self._laser_t

    def _body_ranges(self) -> NDArray[np.float64]:
        """Horizontal range (m) to the car body for each 0.1 deg of azimuth (inf: open view)."""
        rel = np.mod(np.arange(3600) * 0.1 + 180.0, 360.0) - 180.0  # clockwise from the nose
        bearing = -np.radians(rel)
        front = self.car_length_m - self.rear_overhang_m - self.lidar_x_m
        back = self.car_length_m - front
        half_w = 0.5 * self.car_width_m
        cb, sb = np.cos(bearing), np.sin(bearing)
        with np.errstate(divide="ignore"):
            to_back = np.where(cb < 0, back / np.maximum(-cb, 1e-12), np.inf)
            to_side = np.where(np.abs(sb) > 1e-9, half_w / np.maximum(np.abs(sb), 1e-12), np.inf)
        horiz = np.minimum(np.minimum(to_back, to_side), 1.0)
        return np.where(np.abs(rel) > BODY_HALF_ANGLE_DEG, horiz, np.inf)

    # -- public ---------------------------------------------------------------------------

    def poll(self, t_s: float, truth: GroundTruth, vehicle: Any = None,
             track: Any = None) -> list[RawBytes]:
        """The packets completed by ``t_s`` (s) and not yet sent, in time order: one
        :class:`RawBytes` each, or with ``sweep_units`` one for all of them once one completes a
        sweep (none before). ``truth`` is the car's state at ``t_s``; the packets completed
        since the last poll are cast from it."""
        if not self.enabled:
            return []
        k_end = int(math.floor((t_s + 1e-9) / PACKET_DURATION_S)) - 1  # last complete packet
        if k_end < self._next_k:
            return []
        if self.dead:  # nothing is cast or sent while the sensor is dead
            out = self._release(track)  # what completed before it died was sent
            self._pending.clear()
            self._next_gen = max(self._next_gen, k_end + 1)
            self._next_k = k_end + 1
            return out
        if not self.sweep_units:
            return self._single_packets(t_s, k_end, truth, track)
        if not self._held:
            self._held_k0 = self._next_k
        self._held.append((k_end, truth))
        if self._cut_k < self._next_k:
            self._cut_k = self._next_cut(self._next_k)
        self._next_k = k_end + 1
        return self._release(track) if k_end >= self._cut_k else []

    def packets(self, ks: NDArray[np.int64], motion: _Motion, track: Any) -> NDArray[np.uint8]:
        """The payloads of packets number ``ks`` (consecutive; first firing at
        k * PACKET_DURATION_S), (n, 1206) bytes; each firing sequence's pose from its row of
        ``motion`` (24 rows per packet)."""
        if ks.size and int(ks[-1] - ks[0]) != ks.size - 1:
            raise ValueError("LidarModel.packets: packet numbers must be consecutive")
        t_seq: NDArray[np.float64] = np.ravel(
            ks[:, None] * PACKET_DURATION_S + self._seq_t[None, :]).astype(np.float64)  # (F,)
        az_seq = self._azimuth_deg(t_seq)
        # ground and car body: tabulated per 0.1 deg of azimuth, in raw 2 mm units
        bins = (az_seq * 10.0).astype(np.int64)
        bins[bins >= 3600] -= 3600
        raw = self._static_raw[bins]  # (F, 16) int32
        refl = self._static_refl[bins]
        noisy = self.noise and self.range_sigma_m > 0
        if noisy:
            if self._noise_sigma != self.range_sigma_m:
                self._noise_sigma = self.range_sigma_m
                self._noise_raw = np.floor(
                    self._unit_noise * (self.range_sigma_m / DISTANCE_UNIT_M) + 0.5
                ).astype(np.int32)
            rays = _FIRINGS_PER_PACKET * LASERS
            start = (ks.astype(np.uint64) * np.uint64(_NOISE_HASH) + np.uint64(self._noise_key)
                     ) % np.uint64(_NOISE_TABLE_SIZE - rays)
            noise_at = (start.astype(np.int64)[:, None] + np.arange(rays)[None, :]).reshape(
                raw.shape)
            raw = np.where(raw > 0, raw + self._noise_raw[noise_at], 0)
        # cones: exact ray-cone intersections where they are nearer than ground or body
        hits = self._cast_cones(t_seq, az_seq, motion, track)
        if hits is not None:
            f_idx, l_idx, d = hits
            cone_raw = np.floor(d * (1.0 / DISTANCE_UNIT_M) + 0.5).astype(np.int32)
            if noisy:
                cone_raw += self._noise_raw[noise_at[f_idx, l_idx]]
            static = raw[f_idx, l_idx]
            nearer = (static == 0) | (cone_raw < static)
            raw[f_idx[nearer], l_idx[nearer]] = cone_raw[nearer]
            refl[f_idx[nearer], l_idx[nearer]] = CONE_REFLECTIVITY
        if self.dropout_prob > 0:
            raw = np.where(self.rng.random(raw.shape) < self.dropout_prob, 0, raw)
        raw = np.where((raw > 0) & (raw <= self._max_raw), raw, 0)
        refl = np.where(raw > 0, refl, 0).astype(np.uint8)
        return self._encode(ks, az_seq, raw.astype(np.uint16), refl)

    # -- one unit per packet ------------------------------------------------------------------

    def _single_packets(self, t_s: float, k_end: int, truth: GroundTruth,
                        track: Any) -> list[RawBytes]:
        """One unit per packet completed by packet ``k_end``; cast in batches reaching
        ``lookahead_s`` past ``t_s`` (0: the packets completed since the last poll)."""
        if k_end >= self._next_gen:
            k_gen = max(k_end, int(math.floor((t_s + self.lookahead_s) / PACKET_DURATION_S)))
            ks = np.arange(max(self._next_gen, self._next_k), k_gen + 1)
            self._next_gen = k_gen + 1
            motion = _motion([truth], np.zeros(ks.size * _FIRINGS_PER_PACKET, dtype=np.int64))
            buf = self.packets(ks, motion, track)
            kept = self._kept(ks.size)
            self._pending.extend((k, buf[i].tobytes())
                                 for i, k in zip(kept.tolist(), ks[kept].tolist(), strict=True))
        out: list[RawBytes] = []
        while self._pending and self._pending[0][0] <= k_end:
            k, payload = self._pending.popleft()
            out.append(RawBytes(float((k + 1) * PACKET_DURATION_S), "lidar", payload))
        self._next_k = k_end + 1
        return out

    # -- sweep units ------------------------------------------------------------------------

    def _kept(self, n: int) -> NDArray[np.int64]:
        """Indices of the ``n`` packets of a batch that are not lost (``packet_loss_prob``)."""
        if self.packet_loss_prob > 0:
            return np.flatnonzero(self.rng.random(n) >= self.packet_loss_prob)
        return np.arange(n)

    def _release(self, track: Any) -> list[RawBytes]:
        """Cast the held packets and hand them out as one unit (none held: nothing)."""
        if not self._held:
            return []
        held, self._held = self._held, []
        k0, k1 = self._held_k0, held[-1][0]
        ks = np.arange(k0, k1 + 1)
        counts = np.diff(np.array([k0 - 1] + [k for k, _ in held]))
        per_packet = np.repeat(np.arange(len(held)), counts)
        motion = _motion([tr for _, tr in held], np.repeat(per_packet, _FIRINGS_PER_PACKET))
        buf = self.packets(ks, motion, track)
        kept = self._kept(ks.size)
        if kept.size == 0:
            return []
        if kept.size < ks.size:
            buf = buf[kept]
        last = int(ks[kept[-1]])
        return [RawBytes(float((last + 1) * PACKET_DURATION_S), "lidar", buf.tobytes())]

    def _block_rel(self, k: int, block: int) -> int:
        """The azimuth packet ``k`` carries for ``block`` past the cut (hundredths of a
        degree), computed as :meth:`_encode` writes it."""
        t = k * PACKET_DURATION_S + float(self._seq_t[2 * block])
        az = (self.start_azimuth_deg + 360.0 * self.rate_hz * t) % 360.0
        return (int(round(az * 100.0)) % 36000 - self.cut_hundredths) % 36000

    def _next_cut(self, k_from: int) -> int:
        """The first packet from ``k_from`` on that closes a sweep at the parser: its block
        azimuths pass the cut, or the cut lies between it and the packet before."""
        last_block = BLOCKS_PER_PACKET - 1
        # the first turn past the cut after a little before k_from: the scan starts a couple
        # of packets before the packet it falls in (rounding to 0.01 deg moves it a packet
        # at most), never before k_from
        deg_per_s = 360.0 * self.rate_hz
        t0 = (k_from - 2) * PACKET_DURATION_S
        turns = (self.start_azimuth_deg + deg_per_s * t0 - self.cut_hundredths / 100.0) / 360.0
        t_cross = t0 + (math.floor(turns) + 1.0 - turns) * 360.0 / deg_per_s
        k = max(k_from, int(t_cross / PACKET_DURATION_S) - 2)
        prev = self._block_rel(k - 1, last_block)
        while True:
            first = self._block_rel(k, 0)
            last = self._block_rel(k, last_block)
            if first < prev or last < first:
                return k
            prev = last
            k += 1

    # -- internals ------------------------------------------------------------------------

    def _static_scene(self) -> tuple[NDArray[np.int32], NDArray[np.uint8]]:
        """Raw distance (2 mm units, 0 = none) and reflectivity of ground and car body for
        each 0.1 deg of azimuth and each laser id, both (3600, 16)."""
        body_h = self._body_ranges()
        body = np.isfinite(body_h)[:, None]
        dist = np.where(body, body_h[:, None] / _COS_EL[None, :], self._ground_range[None, :])
        refl = np.where(body, BODY_REFLECTIVITY,
                        np.where(np.isfinite(self._ground_range), GROUND_REFLECTIVITY, 0))
        raw = np.where(np.isfinite(dist), np.floor(dist / DISTANCE_UNIT_M + 0.5), 0)
        refl = np.broadcast_to(refl, raw.shape)
        return raw.astype(np.int32), refl.astype(np.uint8)

    def _azimuth_deg(self, t_s: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.mod(self.start_azimuth_deg + 360.0 * self.rate_hz * t_s, 360.0)

    def _poses(self, t_s: NDArray[np.float64], motion: _Motion, rows: NDArray[np.int64]
               ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Sensor x, y (world, m) and yaw (rad) at times ``t_s``, each from the truth in row
        ``rows[i]`` of ``motion`` carried along its constant-rate turn (back in time: a packet
        is cast from the truth of the poll that completed it)."""
        t0 = motion.t_s[rows]
        r = motion.yaw_rate_radps[rows]
        yaw0 = motion.yaw_rad[rows]
        vx, vy = motion.vx_mps[rows], motion.vy_mps[rows]
        dt = t_s - t0
        yaw = yaw0 + r * dt
        # body-frame velocity integrated along a constant-rate turn (a straight line at r = 0)
        turning = np.abs(r) > 1e-6
        r_safe = np.where(turning, r, 1.0)
        sin0, cos0 = np.sin(yaw0), np.cos(yaw0)
        s = np.where(turning, (np.sin(yaw) - sin0) / r_safe, cos0 * dt)
        c = np.where(turning, (cos0 - np.cos(yaw)) / r_safe, sin0 * dt)
        x = motion.x_m[rows] + vx * s - vy * c + self.lidar_x_m * np.cos(yaw)
        y = motion.y_m[rows] + vx * c + vy * s + self.lidar_x_m * np.sin(yaw)
        return x, y, yaw

    def _cast_cones(self, t_seq: NDArray[np.float64], az_seq: NDArray[np.float64],
                    motion: _Motion, track: Any
                    ) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]] | None:
        """Rays that hit a cone within ``CONE_RANGE_M`` of the sensor at their firing: (sequence
        index, laser id, 3-D range in m) of the nearest cone hit of each, or None. The result
        of a ray does not depend on the batch it is cast in (the candidates below are a
        superset, the test is per ray)."""
        if track is None or len(track.cones_xy_m) == 0:
            return None
        n_seq = t_seq.size
        # sample poses, at most about 10 ms apart, bound the cones and sequences to try
        samples = np.unique(np.linspace(0, n_seq - 1, 2 + n_seq // 200).round().astype(np.int64))
        sx, sy, syaw = self._poses(t_seq[samples], motion, samples)
        cones = np.asarray(track.cones_xy_m, dtype=np.float64)
        dist = np.hypot(cones[:, 0, None] - sx[None, :], cones[:, 1, None] - sy[None, :])
        near = dist.min(axis=1) < CONE_RANGE_M + 1.0
        if not near.any():
            return None
        cidx = np.flatnonzero(near)
        cxy = cones[cidx]
        dist = dist[cidx]
        big = np.asarray(track.sizes)[cidx] == int(ConeSize.LARGE)
        rad = np.where(big, LARGE_CONE[0], SMALL_CONE[0])
        height = np.where(big, LARGE_CONE[1], SMALL_CONE[1])
        # candidate (sequence, cone) pairs: sequences whose azimuth is within the cone's angular
        # half-width of its bearing from some sample pose (unwrapped from the first sample's),
        # once per turn the batch spans
        step_deg = 360.0 * self.rate_hz * FIRING_CYCLE_S
        qx_k, qy_k = cxy[:, 0, None] - sx[None, :], cxy[:, 1, None] - sy[None, :]
        az_c = np.degrees(syaw[None, :] - np.arctan2(qy_k, qx_k))  # clockwise from the nose
        rel = np.mod(az_c - az_seq[samples][None, :] + 180.0, 360.0) - 180.0
        centres = samples[None, :] + rel / step_deg  # (C, S) sequence index of the bearing
        per_turn = 360.0 / step_deg
        centres -= np.round((centres - centres[:, :1]) / per_turn) * per_turn
        d_min, d_max = dist.min(axis=1), dist.max(axis=1)
        half = np.degrees(np.arcsin(np.minimum(1.0, (rad + 0.05) / np.maximum(d_min, 1e-6))))
        half = half / step_deg + 1.0
        lo_c = np.ceil(centres.min(axis=1) - half)
        hi_c = np.floor(centres.max(axis=1) + half)
        turns = np.arange(-1, 2 + int(n_seq / per_turn))[:, None] * per_turn  # (T, 1)
        lo = np.maximum(lo_c[None, :] + turns, 0).astype(np.int64).ravel()
        hi = np.minimum(hi_c[None, :] + turns, n_seq - 1).astype(np.int64).ravel()
        counts = np.maximum(hi - lo + 1, 0)
        total = int(counts.sum())
        if total == 0:
            return None
        cand_c = np.repeat(np.tile(np.arange(cidx.size), turns.shape[0]), counts)
        first = np.cumsum(counts) - counts
        cand_f = np.repeat(lo - first, counts) + np.arange(total)
        # lasers that can meet each cone at all: the ray's height across the cone's depth
        # overlaps the cone (the others pass over it or hit the ground before it)
        near_d = np.maximum(d_min - rad - 1.0, 0.05)[:, None]
        far_d = (d_max + rad + 1.0)[:, None]
        z_near = self._laser_h[None, :] + _TAN_EL[None, :] * near_d
        z_far = self._laser_h[None, :] + _TAN_EL[None, :] * far_d
        can = (np.maximum(z_near, z_far) >= 0.0) & (np.minimum(z_near, z_far) <= height[:, None])
        pair, laser = np.nonzero(can[cand_c])
        if pair.size == 0:
            return None
        f = cand_f[pair]
        c = cand_c[pair]
        # each ray's own sensor pose and azimuth (poses per sequence, where a cone may be hit)
        seqs, f_at = np.unique(f, return_inverse=True)
        sx_f, sy_f, head_f = self._poses(t_seq[seqs], motion, seqs)
        head_f -= np.radians(az_seq[seqs])
        px, py = sx_f[f_at], sy_f[f_at]
        hd = head_f[f_at] - self._laser_drad[laser]
        ux, uy = np.cos(hd), np.sin(hd)
        qx = cxy[c, 0] - px
        qy = cxy[c, 1] - py
        # exact ray-cone intersection: horizontal distance s along the ray where the ray meets
        # the cone's surface, radius a0 + a1 s at the ray's height there
        b = qx * ux + qy * uy
        q2 = qx * qx + qy * qy
        r0, hh = rad[c], height[c]
        lh, tan = self._laser_h[laser], _TAN_EL[laser]
        a0 = r0 * (1.0 - lh / hh)
        a1 = -r0 * tan / hh
        qa = 1.0 - a1 * a1
        qb = b + a0 * a1
        qc = q2 - a0 * a0
        disc = qb * qb - qa * qc
        ok = (disc >= 0.0) & (q2 < CONE_RANGE_M * CONE_RANGE_M)
        if not ok.any():
            return None
        f, c, laser = f[ok], c[ok], laser[ok]
        qa, qb, a0, a1, lh, tan, hh = qa[ok], qb[ok], a0[ok], a1[ok], lh[ok], tan[ok], hh[ok]
        root = np.sqrt(disc[ok])
        hit_s = np.full(root.shape, np.inf)
        for sign in (-1.0, 1.0):  # the larger root first, so the smaller one wins
            s_h = (qb - sign * root) / qa
            z = lh + tan * s_h
            valid = (s_h > 0.0) & (a0 + a1 * s_h >= 0.0) & (z >= 0.0) & (z <= hh)
            hit_s = np.where(valid, s_h, hit_s)
        hit = np.isfinite(hit_s)
        if not hit.any():
            return None
        laser = laser[hit]
        d = hit_s[hit] / _COS_EL[laser]
        # nearest cone per ray: sort by ray, then by range, keep the first of each ray
        ray = f[hit] * LASERS + laser
        order = np.lexsort((d, ray))
        ray, d = ray[order], d[order]
        keep = np.ones(ray.size, dtype=bool)
        keep[1:] = ray[1:] != ray[:-1]
        ray, d = ray[keep], d[keep]
        return ray // LASERS, ray % LASERS, d

    def _encode(self, ks: NDArray[np.int64], az_seq: NDArray[np.float64],
                raw: NDArray[np.uint16], refl: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Packets (n, 1206) from per-ray raw distances and reflectivities, both (F, 16)."""
        n = ks.size
        buf = np.zeros((n, PACKET_SIZE), dtype=np.uint8)
        blocks = buf[:, :1200].reshape(n, BLOCKS_PER_PACKET, 100)
        blocks[:, :, 0] = 0xFF
        blocks[:, :, 1] = 0xEE
        az_block = az_seq.reshape(n, BLOCKS_PER_PACKET, 2)[:, :, 0]
        az = np.round(az_block * 100.0).astype(np.int64) % 36000
        blocks[:, :, 2] = az & 0xFF
        blocks[:, :, 3] = az >> 8
        rets = np.empty((n, BLOCKS_PER_PACKET, 32), dtype=[("d", "<u2"), ("r", "u1")])
        rets["d"] = raw.reshape(n, BLOCKS_PER_PACKET, 32)
        rets["r"] = refl.reshape(n, BLOCKS_PER_PACKET, 32)
        blocks[:, :, 4:] = rets.view(np.uint8).reshape(n, BLOCKS_PER_PACKET, 96)
        stamp_us = np.round(ks * PACKET_DURATION_S * 1e6).astype(np.int64) % 3_600_000_000
        buf[:, 1200:1204] = stamp_us.astype("<u4").view(np.uint8).reshape(n, 4)
        buf[:, 1204] = RETURN_MODE_STRONGEST
        buf[:, 1205] = PRODUCT_VLP16
        return buf
