"""Simulated GNSS receiver: NMEA 0183 GGA, RMC, VTG and GSA sentences at 10 Hz.

The car's true world-frame position is taken to WGS84 about the fixed geodetic origin of the
run (``config.sim.origin_*``; world x points along ``config.sim.start_heading_enu_rad`` in the
local east-north-up frame, see :class:`common.conventions.WorldFrame`), with the noise of seed
001's receiver (2.5 m standard deviation):

- a slowly wandering bias per horizontal axis: a first-order Gauss-Markov process with
  stationary standard deviation ``bias_sigma_m`` and correlation time ``bias_tau_s``
  (``b[k+1] = phi b[k] + sqrt(1 - phi^2) bias_sigma w``, ``phi = exp(-dt / tau)``);
- white noise ``sigma_m`` per horizontal axis and ``altitude_sigma_m`` in height;
- speed over ground from the true velocity plus ``speed_sigma_mps``; course over ground from
  the true velocity direction plus ``course_sigma_rad`` (growing as 1/speed below 1 m/s; the
  course field is empty below :data:`GpsNoise.min_course_speed_mps`, as receivers do).

Each epoch sends GGA, RMC, VTG, GSA (talker ``GN`` by default), one :class:`RawBytes` per
sentence, CR LF included, all stamped with the epoch time. Latitude and longitude carry 7
decimals of arc minutes (about 0.2 mm), time 2 decimals of a second, speed 3 decimals of a
knot and of km/h, course 2 decimals of a degree.

Faults: ``dropout`` (attribute; True sends nothing while the model keeps running),
``dropout_prob`` (a whole epoch lost), ``corrupt_fraction`` (each sentence, with this
probability, gets a flipped body byte or a wrong checksum: always caught by the checksum).
With ``noise = False`` the sentences carry the true values (up to quantisation).
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from common.conventions import LocalTangentFrame, WorldFrame, enu_yaw_to_compass_deg
from common.messages import GroundTruth, RawBytes
from sensors.nmea_framing import KNOT_MPS, with_checksum
from simulator.config import WorldConfig


@dataclass(frozen=True, slots=True)
class GpsNoise:
    """Settings of the simulated receiver that the simulator config does not carry."""

    talker: str = "GN"
    utc_start_s: float = 1_717_243_200.0
    """UTC time (POSIX s) at simulated time 0: 2024-06-01 12:00:00."""
    geoid_separation_m: float = 47.9
    """Height of the geoid above the WGS84 ellipsoid at the origin (GGA field 11)."""
    antenna_x_m: float = 0.0
    """Antenna position ahead of the vehicle origin (m)."""
    min_course_speed_mps: float = 0.1
    """Below this speed the course field is left empty."""
    course_full_speed_mps: float = 1.0
    """Below this speed the course noise grows as full_speed / speed (capped at pi)."""
    pdop: float = 1.8
    vdop: float = 1.5


class GpsModel:
    """A GNSS receiver on the simulated car; deterministic for a given ``rng`` seed."""

    def __init__(self, config: WorldConfig, rng: np.random.Generator,
                 noise: GpsNoise | None = None) -> None:
        sim = config.sim
        self.cfg = sim.gps
        self.settings = noise or GpsNoise()
        self.rng = rng
        self.frame = WorldFrame(
            enu=LocalTangentFrame(sim.origin_lat_deg, sim.origin_lon_deg, sim.origin_alt_m),
            start_yaw_enu_rad=sim.start_heading_enu_rad,
        )
        self.origin_alt_m = sim.origin_alt_m
        self._geodetic = _EnuToGeodetic(sim.origin_lat_deg, sim.origin_lon_deg, sim.origin_alt_m)
        self.period_s = 1.0 / self.cfg.rate_hz if self.cfg.rate_hz > 0 else math.inf
        self.enabled = self.cfg.enabled and self.cfg.rate_hz > 0
        self.noise = True
        """False: no position, speed or course noise (for decoding tests)."""
        self.dropout = False
        """Fault switch: while True nothing is sent."""
        self.dropout_prob = self.cfg.dropout_prob
        self.corrupt_fraction = self.cfg.corrupt_prob
        self._next_epoch = 0
        self._bias_m = rng.normal(0.0, self.cfg.bias_sigma_m, 2) if self.cfg.bias_sigma_m > 0 \
            else np.zeros(2)
        self._prn = [int(p) for p in rng.choice(np.arange(1, 33), size=12, replace=False)]

    # -- public ---------------------------------------------------------------------------

    def poll(self, t_s: float, truth: GroundTruth, vehicle: Any = None,
             track: Any = None) -> list[RawBytes]:
        """Every sentence due up to ``t_s`` (s), in time order (an epoch every 1/rate_hz)."""
        out: list[RawBytes] = []
        if not self.enabled:
            return out
        while self._next_epoch * self.period_s <= t_s + 1e-9:
            epoch_t = self._next_epoch * self.period_s
            self._next_epoch += 1
            self._step_bias()
            sentences = self.epoch_sentences(epoch_t, truth)
            if self.dropout or (self.dropout_prob > 0 and self.rng.random() < self.dropout_prob):
                continue
            for sentence in sentences:
                if self.corrupt_fraction > 0 and self.rng.random() < self.corrupt_fraction:
                    sentence = self._corrupt(sentence)
                out.append(RawBytes(epoch_t, "gps", sentence))
        return out

    def epoch_sentences(self, t_s: float, truth: GroundTruth) -> list[bytes]:
        """GGA, RMC, VTG and GSA for an epoch at ``t_s`` with the car at ``truth``."""
        cfg, s = self.cfg, self.settings
        c, sn = math.cos(truth.yaw_rad), math.sin(truth.yaw_rad)
        wx = truth.x_m + s.antenna_x_m * c
        wy = truth.y_m + s.antenna_x_m * sn
        h = self.frame.start_yaw_enu_rad
        east = wx * math.cos(h) - wy * math.sin(h) + self.frame.start_east_m
        north = wx * math.sin(h) + wy * math.cos(h) + self.frame.start_north_m
        alt = self.origin_alt_m
        speed, course_yaw_world = self._true_velocity(truth)
        if self.noise:
            z = self.rng.standard_normal(5).tolist()
            east += float(self._bias_m[0]) + cfg.sigma_m * z[0]
            north += float(self._bias_m[1]) + cfg.sigma_m * z[1]
            alt += cfg.altitude_sigma_m * z[2]
            if speed > 0.0:
                sigma = cfg.course_sigma_rad * max(1.0, s.course_full_speed_mps / speed)
                course_yaw_world += min(sigma, math.pi) * z[3]
            speed = abs(speed + cfg.speed_sigma_mps * z[4])
        lat, lon = self._geodetic.to_geodetic(east, north)
        course_deg = enu_yaw_to_compass_deg(self.frame.world_yaw_to_enu_yaw(course_yaw_world))
        return self.format_epoch(t_s, lat, lon, alt, speed, course_deg)

    def format_epoch(self, t_s: float, lat_deg: float, lon_deg: float, alt_m: float,
                     speed_mps: float, course_deg: float) -> list[bytes]:
        """The four sentences for given values (degrees, m above MSL, m/s, deg from north)."""
        cfg, s = self.cfg, self.settings
        talker = s.talker
        stamp = dt.datetime.fromtimestamp(round(s.utc_start_s + t_s, 2), tz=dt.UTC)
        hms = f"{stamp:%H%M%S}.{stamp.microsecond // 10000:02d}"
        date = f"{stamp:%d%m%y}"
        lat_text, ns = _format_coord(lat_deg, 2, "N", "S")
        lon_text, ew = _format_coord(lon_deg, 3, "E", "W")
        knots = speed_mps / KNOT_MPS
        kmh = speed_mps * 3.6
        course = f"{course_deg:.2f}" if speed_mps >= s.min_course_speed_mps else ""
        prns = ",".join(f"{p:02d}" for p in self._prn[: min(cfg.satellites, 12)])
        prns += "," * (12 - min(cfg.satellites, 12))
        gga = (f"{talker}GGA,{hms},{lat_text},{ns},{lon_text},{ew},1,{cfg.satellites:02d},"
               f"{cfg.hdop:.2f},{alt_m:.2f},M,{s.geoid_separation_m:.2f},M,,")
        rmc = (f"{talker}RMC,{hms},A,{lat_text},{ns},{lon_text},{ew},{knots:.3f},{course},"
               f"{date},,,A")
        vtg = f"{talker}VTG,{course},T,,M,{knots:.3f},N,{kmh:.3f},K,A"
        gsa = f"{talker}GSA,A,3,{prns},{s.pdop:.2f},{cfg.hdop:.2f},{s.vdop:.2f}"
        return [with_checksum(x) for x in (gga, rmc, vtg, gsa)]

    def utc_time_of_day_s(self, t_s: float) -> float:
        """UTC time of day (s since midnight) that an epoch at simulated ``t_s`` carries."""
        return round(self.settings.utc_start_s + t_s, 2) % 86400.0

    # -- internals ------------------------------------------------------------------------

    def _true_velocity(self, truth: GroundTruth) -> tuple[float, float]:
        """Speed (m/s) and direction (world yaw, rad) of the antenna's velocity."""
        c, s = math.cos(truth.yaw_rad), math.sin(truth.yaw_rad)
        vx = truth.vx_mps
        vy = truth.vy_mps + truth.yaw_rate_radps * self.settings.antenna_x_m
        vwx, vwy = vx * c - vy * s, vx * s + vy * c
        return math.hypot(vwx, vwy), math.atan2(vwy, vwx)

    def _step_bias(self) -> None:
        cfg = self.cfg
        if not self.noise or cfg.bias_sigma_m <= 0 or cfg.bias_tau_s <= 0:
            return
        phi = math.exp(-self.period_s / cfg.bias_tau_s)
        self._bias_m = phi * self._bias_m + math.sqrt(1.0 - phi * phi) * self.rng.normal(
            0.0, cfg.bias_sigma_m, 2)

    def _corrupt(self, sentence: bytes) -> bytes:
        """A flipped printable body byte or a wrong checksum (either fails the checksum)."""
        star = sentence.rfind(b"*")
        data = bytearray(sentence)
        if self.rng.random() < 0.5 and star > 2:
            i = int(self.rng.integers(1, star))
            choices = [c for c in b"0123456789ABCDEFGHNSEW.," if c != data[i]]
            data[i] = choices[int(self.rng.integers(len(choices)))]
        else:
            wrong = (int(sentence[star + 1:star + 3], 16) + int(self.rng.integers(1, 256))) % 256
            data[star + 1:star + 3] = b"%02X" % wrong
        return bytes(data)


def _format_coord(value_deg: float, degree_digits: int, pos: str, neg: str) -> tuple[str, str]:
    """Degrees to NMEA ``ddmm.mmmmmmm`` (or ``dddmm...``) and its hemisphere letter."""
    total_min = round(abs(value_deg) * 60.0, 7)
    degrees = int(total_min // 60.0)
    minutes = total_min - degrees * 60.0
    if minutes >= 59.99999995:  # rounding carried into the next degree
        degrees, minutes = degrees + 1, 0.0
    return f"{degrees:0{degree_digits}d}{minutes:010.7f}", (pos if value_deg >= 0 else neg)


_WGS84_A_M = 6378137.0
_WGS84_F = 1.0 / 298.257223563
_WGS84_E2 = _WGS84_F * (2.0 - _WGS84_F)


class _EnuToGeodetic:
    """East, north (m, at the origin's height) to WGS84 latitude, longitude (deg).

    The same transformation as pymap3d.enu2geodetic (ENU -> ECEF -> geodetic, WGS84), written
    with ``math`` for speed (a GPS epoch every 0.1 s of a simulation running many times faster
    than real time); agrees with pymap3d to well below a millimetre.
    """

    def __init__(self, lat0_deg: float, lon0_deg: float, alt0_m: float) -> None:
        lat0, lon0 = math.radians(lat0_deg), math.radians(lon0_deg)
        self.sin_lat0, self.cos_lat0 = math.sin(lat0), math.cos(lat0)
        self.sin_lon0, self.cos_lon0 = math.sin(lon0), math.cos(lon0)
        n0 = _WGS84_A_M / math.sqrt(1.0 - _WGS84_E2 * self.sin_lat0 ** 2)
        self.x0 = (n0 + alt0_m) * self.cos_lat0 * self.cos_lon0
        self.y0 = (n0 + alt0_m) * self.cos_lat0 * self.sin_lon0
        self.z0 = (n0 * (1.0 - _WGS84_E2) + alt0_m) * self.sin_lat0

    def to_geodetic(self, east_m: float, north_m: float, up_m: float = 0.0) -> tuple[float, float]:
        """Latitude and longitude (deg) of a point east/north/up of the origin (m)."""
        sl, cl, so, co = self.sin_lat0, self.cos_lat0, self.sin_lon0, self.cos_lon0
        t = cl * up_m - sl * north_m
        x = self.x0 + co * t - so * east_m
        y = self.y0 + so * t + co * east_m
        z = self.z0 + sl * up_m + cl * north_m
        lon = math.atan2(y, x)
        p = math.hypot(x, y)
        lat = math.atan2(z, p * (1.0 - _WGS84_E2))
        for _ in range(5):
            sin_lat = math.sin(lat)
            n = _WGS84_A_M / math.sqrt(1.0 - _WGS84_E2 * sin_lat * sin_lat)
            h = p / math.cos(lat) - n
            lat = math.atan2(z, p * (1.0 - _WGS84_E2 * n / (n + h)))
        return math.degrees(lat), math.degrees(lon)
