"""A parsed GNSS fix back to the NMEA sentences a receiver sends for it (RMC, GGA, and GST
when the fix carries the receiver's accuracy).

For importing foreign logs whose receiver was recorded as parsed fixes: the recording then holds
the bytes our :class:`sensors.nmea.NmeaParser` reads on the car. Fields the fix does not carry
(satellites, HDOP, altitude, speed, course) are left empty; coordinates keep 7 decimals of a
minute (0.2 mm), the time 2 decimals of a second.
"""

from __future__ import annotations

import datetime as dt
import math

from common.conventions import enu_yaw_to_compass_deg
from common.messages import GpsFix
from sensors.nmea_framing import KNOT_MPS, with_checksum


def _coord(value_deg: float, degree_digits: int, pos: str, neg: str) -> tuple[str, str]:
    """Degrees to NMEA ``ddmm.mmmmmmm`` (``dddmm...`` for longitude) and its hemisphere."""
    total_min = round(abs(value_deg) * 60.0, 7)
    degrees = int(total_min // 60.0)
    minutes = total_min - degrees * 60.0
    if minutes >= 59.99999995:
        degrees, minutes = degrees + 1, 0.0
    return f"{degrees:0{degree_digits}d}{minutes:010.7f}", (pos if value_deg >= 0 else neg)


def fix_sentences(fix: GpsFix, utc_day_s: float, talker: str = "GN") -> list[bytes]:
    """RMC, GGA (u-blox order), and GST when ``fix`` has ``lat_sigma_m`` and ``lon_sigma_m``;
    ``utc_day_s`` is the UTC time (s since 1970) of midnight of the fix's day
    (``fix.utc_time_s`` is the time of day), for the RMC date."""
    if not math.isfinite(fix.utc_time_s):
        raise ValueError("a fix without its UTC time cannot be written as NMEA")
    stamp = dt.datetime.fromtimestamp(round(utc_day_s + fix.utc_time_s, 2), tz=dt.UTC)
    hms = f"{stamp:%H%M%S}.{stamp.microsecond // 10000:02d}"
    lat, ns = _coord(fix.lat_deg, 2, "N", "S")
    lon, ew = _coord(fix.lon_deg, 3, "E", "W")
    sats = f"{fix.satellites:02d}" if fix.satellites > 0 else ""
    hdop = f"{fix.hdop:.2f}" if math.isfinite(fix.hdop) else ""
    alt = f"{fix.altitude_m:.3f},M" if math.isfinite(fix.altitude_m) else ",M"
    knots = f"{fix.speed_mps / KNOT_MPS:.4f}" if math.isfinite(fix.speed_mps) else ""
    course = (f"{enu_yaw_to_compass_deg(fix.course_rad):.3f}"
              if math.isfinite(fix.course_rad) else "")
    quality = max(0, fix.fix_quality)
    gga = f"{talker}GGA,{hms},{lat},{ns},{lon},{ew},{quality},{sats},{hdop},{alt},,M,,"
    status = "A" if quality > 0 else "V"
    mode = "A" if quality > 0 else "N"
    rmc = (f"{talker}RMC,{hms},{status},{lat},{ns},{lon},{ew},{knots},{course},"
           f"{stamp:%d%m%y},,,{mode}")
    out = [with_checksum(rmc), with_checksum(gga)]
    if math.isfinite(fix.lat_sigma_m) and math.isfinite(fix.lon_sigma_m):
        major = max(fix.lat_sigma_m, fix.lon_sigma_m)
        minor = min(fix.lat_sigma_m, fix.lon_sigma_m)
        out.append(with_checksum(f"{talker}GST,{hms},,{major:.3f},{minor:.3f},0.0,"
                                 f"{fix.lat_sigma_m:.3f},{fix.lon_sigma_m:.3f},"))
    return out
