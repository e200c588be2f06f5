"""NMEA 0183 framing and parsing: bytes from a GNSS receiver to :class:`GpsFix` messages.

Two layers, usable apart:

- :class:`NmeaFramer` cuts an arbitrary byte stream (partial lines, junk, interleaved binary
  such as u-blox UBX, missing line ends) into candidate sentences. A sentence starts at ``$``
  or ``!`` and ends at CR or LF, or where the next ``$``/``!`` starts (some receivers drop the
  line end). A candidate holding a non-printable byte is abandoned at that byte (binary data),
  one longer than :data:`MAX_SENTENCE_CHARS` is dropped. :func:`split_sentences` frames one
  complete buffer.
- :class:`NmeaParser` checks each sentence's ``*HH`` checksum (a sentence with a wrong checksum
  never contributes to a fix; one without a checksum is accepted, as gpsd does, unless
  ``require_checksum``), splits its fields and groups the sentences of one receiver cycle
  into one :class:`GpsFix`.

Sentences used (any talker: GP, GN, GL, GA, GB, IN, EC, II, ...): GGA (position, quality,
satellites, HDOP, altitude above mean sea level), RMC (status, position, speed, course), GLL
(position, status), GNS (position, mode, satellites, HDOP, altitude), VTG (speed, course), GSA (HDOP
when no GGA; its fix mode) and GST (the receiver's 1-sigma latitude and longitude errors, m); GBS
only for its time stamp (a u-blox ends its cycle with it). Every other well-formed sentence (GSV,
ZDA, TXT, proprietary ``$P...`` sentences, and the instrument sentences of a boat's or car's bus:
DPT, DBT, MWV, HDG, HDT, VHW, MTW, XDR, ... from talkers SD, WI, II, HC, ...) is counted by type and
as ``unused``, never read for a fix; talkers are counted in ``NmeaParser.talkers``.

Status. The cycle's fix is valid when its latest status-bearing sentence says so: GGA quality
> 0 with satellites, RMC/GLL status ``A`` (FAA mode not ``N``), GNS mode, or a GSA fix mode
of 2 or 3, which vouches for the cycle's latest position even when that position's own sentence
said otherwise (as gpsd takes it: Garmin and Furuno receivers send a GGA counting 0 satellites,
then a GSA listing the satellites used); GSA mode 1 means no fix.

Cycles, as gpsd groups them. A receiver sends a burst of sentences per navigation cycle (e.g. RMC,
VTG, GGA, GSA, GSV, GLL at 1-10 Hz); the position sentences of one cycle (GGA, RMC, GLL, GNS) carry
the same UTC time. A sentence whose time differs from the cycle's (by more than
:data:`CYCLE_TIME_TOLERANCE_S`) starts the next cycle; sentences without a time (VTG, GSA, GSV,
instrument sentences) belong to the cycle in progress. When a cycle starts, the type of the last
time-stamped sentence of the one before is learned as a "cycle ender" (gpsd's rule: several types
may be enders, as when a receiver's order varies; an RMC saying "no fix" is not a candidate, its
time is not trusted; on a bus carrying a depth sounder's DBT, as gpsd, no ender is learned after the
first DBT: there the order of the position sentences drifts). The cycle's fix is reported, once
valid, at the sentence type that last ended a cycle among those used (usually the ender itself, or
the GSA after it, whose fix mode may still vouch for or withdraw the fix); a cycle that reached an
ender but not that sentence, or that lost a sentence to a bad checksum (perhaps its ender), is
reported when it ends; one that never reached an ender is not reported, as gpsd does not
(``incomplete_cycle``: a cycle cut short by a restart or a splice). Until an ender is known (the
first cycle), the fix is reported as soon as it is valid. One fix per cycle: later sentences of a
reported cycle are counted, not reported again. A stream without any time stamps starts a new cycle
when a position sentence type repeats. The fix carries the position of the cycle's latest valid
position sentence (as gpsd's report does), the time of its latest time-stamped sentence (sentences
of one cycle may differ by a few ms) and its ``timestamp_s`` is the receive time of the cycle's
first sentence.

``GpsFix.utc_time_s`` is the UTC time of day (s since midnight); ``course_rad`` is an ENU yaw
(counter-clockwise from east), converted from NMEA's degrees clockwise from true north.

Rejects (``NmeaParser.rejects``, by reason): ``bad_checksum``, ``garbled`` (unframeable text, an
address that is not one, bad numbers or missing fields in a sentence used), ``too_long``,
``binary`` (a candidate cut by non-printable bytes), ``junk`` (runs of bytes outside any
sentence), ``no_checksum`` (only with ``require_checksum``), ``no_fix`` (a position sentence
saying there is no fix, or with empty position fields), ``incomplete_cycle`` (a valid fix whose
cycle never reached an ender), ``parser_error`` (an unexpected exception inside the parser:
logged with its traceback; a bug). ``NmeaParser.counts`` counts accepted sentences by type
(``GGA``, ``RMC``, ``DPT``, ...), ``sentences``, ``unused``, ``fixes`` and ``late_fixes``
(fixes reported when their cycle ended).
"""

from __future__ import annotations

import collections
import logging
import math
from dataclasses import dataclass, field

from common.conventions import compass_deg_to_enu_yaw
from common.messages import GpsFix
from sensors.nmea_framing import (
    KNOT_MPS,
    NmeaFramer,
    check_sentence,
    parse_float,
    parse_int,
    parse_position,
    parse_time_of_day,
    split_address,
)

log = logging.getLogger(__name__)



_POSITION_TYPES = frozenset({"GGA", "RMC", "GLL", "GNS"})
_USED_TYPES = _POSITION_TYPES | {"VTG", "GSA", "GST", "GBS"}
_CONTINUATION_TYPES = frozenset({"DBT"})
"""Instrument sentences that, as in gpsd, mark a multiplexed bus (a depth sounder's DBT):
once one is seen, no further cycle enders are learned (the order of the position sentences
on such a bus drifts, and every type would end up an ender)."""
CYCLE_TIME_TOLERANCE_S = 0.01
"""Sentence times closer than this (s) are the same cycle's (gpsd's tolerance)."""
_FAA_QUALITY = {"A": 1, "D": 2, "P": 3, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8}
"""FAA mode indicator (RMC, GLL, VTG, GNS) to GGA quality; ``N`` means no fix."""


@dataclass(slots=True)
class _Cycle:
    """What is known about one receiver cycle so far."""

    timestamp_s: float
    utc_time_s: float = math.nan
    lat_deg: float = math.nan
    lon_deg: float = math.nan
    altitude_m: float = math.nan
    fix_quality: int = 0
    satellites: int = 0
    hdop: float = math.nan
    gsa_hdop: float = math.nan
    speed_mps: float = math.nan
    course_deg: float = math.nan
    lat_sigma_m: float = math.nan
    lon_sigma_m: float = math.nan
    valid: bool = False
    """What the cycle's latest status-bearing sentence (GGA, RMC, GLL, GNS, GSA) said."""
    seen_lat_deg: float = math.nan
    seen_lon_deg: float = math.nan
    """The latest position of the cycle whatever its sentence's status (a GSA's fix mode may
    vouch for it)."""
    seen_quality: tuple[int, int, float, float] | None = None
    """The latest GGA/GNS quality, satellites, HDOP and altitude, whatever their status."""
    types: set[str] = field(default_factory=set)
    last_timed_type: str = ""
    """The type of the cycle's latest sentence that carried a time (a cycle-ender candidate)."""
    last_used_type: str = ""
    """The type of the cycle's latest sentence used (any of GGA, RMC, GLL, GNS, VTG, GSA, GST)."""
    emitted: bool = False
    corrupted: bool = False
    """A sentence was lost inside the cycle (bad checksum, garbled): maybe its ender."""

    @property
    def has_position(self) -> bool:
        return math.isfinite(self.lat_deg) and math.isfinite(self.lon_deg)

    @property
    def reportable(self) -> bool:
        return self.valid and not self.emitted and self.has_position

    def to_fix(self) -> GpsFix:
        course = self.course_deg
        return GpsFix(
            timestamp_s=self.timestamp_s,
            lat_deg=self.lat_deg,
            lon_deg=self.lon_deg,
            altitude_m=self.altitude_m,
            fix_quality=self.fix_quality,
            satellites=self.satellites,
            hdop=self.hdop if math.isfinite(self.hdop) else self.gsa_hdop,
            speed_mps=self.speed_mps,
            course_rad=compass_deg_to_enu_yaw(course) if math.isfinite(course) else math.nan,
            utc_time_s=self.utc_time_s,
            lat_sigma_m=self.lat_sigma_m,
            lon_sigma_m=self.lon_sigma_m,
        )


def _same_time(a_s: float, b_s: float) -> bool:
    """Two UTC times of day (s) within :data:`CYCLE_TIME_TOLERANCE_S`, midnight wrap aside."""
    return abs(a_s - b_s) <= CYCLE_TIME_TOLERANCE_S


class NmeaParser:
    """NMEA bytes in any chunking to one :class:`GpsFix` per receiver cycle with a valid fix.

    ``feed`` never raises: anything it cannot use is counted in ``rejects`` by reason (see the
    module docstring) and logged at debug level. ``counts`` counts accepted sentences by type,
    ``talkers`` by talker id (``GP``, ``SD``, ``II``, ``P`` for proprietary); ``cycle_enders``
    are the sentence types learned to end a cycle.
    """

    source = "gps"

    def __init__(self, require_checksum: bool = False) -> None:
        self.require_checksum = require_checksum
        self.framer = NmeaFramer()
        self.rejects: collections.Counter[str] = self.framer.rejects
        self.counts: collections.Counter[str] = collections.Counter()
        self.talkers: collections.Counter[str] = collections.Counter()
        self.cycle_enders: set[str] = set()
        self._report_at: set[str] = set()
        """Types after which cycles ended among those used (an ender, or a GSA after it)."""
        self._continued = False
        """A depth sounder's DBT was seen: no more enders are learned."""
        self._cycle: _Cycle | None = None

    # -- public ---------------------------------------------------------------------------

    def feed(self, timestamp_s: float, data: bytes) -> list[GpsFix]:
        """Take bytes received at ``timestamp_s`` (Clock, s); return the fixes they complete."""
        out: list[GpsFix] = []
        try:
            sentences = self.framer.feed(data)
        except Exception:  # pragma: no cover - framing is total; belt and braces
            log.exception("NMEA framing failed")
            self.framer.reset()
            self.rejects["garbled"] += 1
            return out
        for sentence in sentences:
            self._sentence(timestamp_s, sentence, out)
        return out

    def flush(self) -> list[GpsFix]:
        """End of stream: parse an unterminated last sentence and end the cycle in progress
        (reported if valid and it reached an ender)."""
        out: list[GpsFix] = []
        for sentence in self.framer.flush():
            self._sentence(self._cycle.timestamp_s if self._cycle else 0.0, sentence, out)
        self._end_cycle(out)
        return out

    def reset(self) -> None:
        """A new byte stream (the port was reopened): forget partial sentences, the cycle in
        progress and the learned cycle enders."""
        self.framer.reset()
        self._cycle = None
        self.cycle_enders.clear()
        self._report_at.clear()
        self._continued = False

    # -- internals ------------------------------------------------------------------------

    def _reject(self, reason: str, sentence: bytes) -> None:
        self.rejects[reason] += 1
        if reason in ("bad_checksum", "garbled") and self._cycle is not None:
            self._cycle.corrupted = True
        log.debug("NMEA reject %s: %r", reason, sentence[:100])

    def _sentence(self, timestamp_s: float, sentence: bytes, out: list[GpsFix]) -> None:
        try:
            self._process(timestamp_s, sentence, out)
        except (ValueError, IndexError) as exc:  # a malformed or missing field
            self._reject("garbled", sentence)
            log.debug("NMEA sentence %r: %s", sentence[:100], exc)
        except Exception:  # a bug: never kill the receiver for it, but say so loudly
            self.rejects["parser_error"] += 1
            log.exception("NMEA parser failed on %r (rejected; this is a bug)", sentence[:100])

    def _process(self, timestamp_s: float, sentence: bytes, out: list[GpsFix]) -> None:
        problem = check_sentence(sentence)
        if problem == "no_checksum" and not self.require_checksum:
            self.counts["no_checksum"] += 1
        elif problem is not None:
            self._reject(problem, sentence)
            return
        star = sentence.rfind(b"*")
        body = sentence[1:star] if star >= 0 else sentence[1:]
        fields = body.decode("ascii").split(",")
        try:
            talker, kind = split_address(fields[0])
        except ValueError:
            self._reject("garbled", sentence)
            return
        self.counts["sentences"] += 1
        self.counts[kind] += 1
        self.talkers[talker] += 1
        if kind not in _USED_TYPES or talker == "P":
            self.counts["unused"] += 1
            if kind in _CONTINUATION_TYPES:
                self._continued = True
            return
        getattr(self, f"_on_{kind.lower()}")(timestamp_s, fields[1:], sentence, out)

    # Cycle bookkeeping ---------------------------------------------------------------

    def _cycle_for(self, timestamp_s: float, kind: str, utc_time_s: float,
                   out: list[GpsFix], ender_candidate: bool = True) -> _Cycle:
        """The cycle a sentence of ``kind`` carrying ``utc_time_s`` (NaN: no time) belongs
        to; a new one when its time differs from the cycle's (learning the ender), or, in a
        stream without times, when a position type repeats. ``ender_candidate`` False: the
        sentence's time groups it but does not make its type a cycle-ender candidate (an RMC
        saying "no fix", whose time gpsd does not trust: MTK and Garmin receivers send a
        stale one)."""
        cycle = self._cycle
        timed = math.isfinite(utc_time_s)
        if cycle is not None:
            if timed and math.isfinite(cycle.utc_time_s):
                new = not _same_time(utc_time_s, cycle.utc_time_s)
            else:
                new = (not timed and not math.isfinite(cycle.utc_time_s)
                       and kind in _POSITION_TYPES and kind in cycle.types)
            if new:
                self._end_cycle(out)
                if timed and cycle.last_timed_type and not self._continued:
                    if cycle.last_timed_type not in self.cycle_enders:
                        self.cycle_enders.add(cycle.last_timed_type)
                        log.debug("NMEA: %s learned as a cycle ender", cycle.last_timed_type)
                    self._report_at.add(cycle.last_used_type)
                cycle = None
        if cycle is None:
            cycle = _Cycle(timestamp_s=timestamp_s)
            self._cycle = cycle
        if timed:
            if not cycle.emitted:  # the latest time of the cycle (gpsd's report carries it)
                cycle.utc_time_s = utc_time_s
            if ender_candidate:
                cycle.last_timed_type = kind
        cycle.last_used_type = kind
        return cycle

    def _end_cycle(self, out: list[GpsFix]) -> None:
        """The cycle in progress is over (call before learning from it): a valid fix not yet
        reported is reported if the cycle reached an ender, lost a sentence to corruption, or
        no ender is known yet; else counted as ``incomplete_cycle``."""
        cycle = self._cycle
        self._cycle = None
        if cycle is None or not cycle.reportable:
            return
        if cycle.types & self.cycle_enders or cycle.corrupted:
            self.counts["late_fixes"] += 1
            self._emit(cycle, out)
        elif self.cycle_enders:
            self.rejects["incomplete_cycle"] += 1
            log.debug("NMEA: cycle at %.2f s UTC never reached its ender (%s); not reported",
                      cycle.utc_time_s, sorted(self.cycle_enders))
        else:
            self._emit(cycle, out)

    def _emit(self, cycle: _Cycle, out: list[GpsFix]) -> None:
        cycle.emitted = True
        out.append(cycle.to_fix())
        self.counts["fixes"] += 1

    def _done(self, cycle: _Cycle, kind: str, out: list[GpsFix]) -> None:
        """Record that ``kind`` arrived; report the cycle's fix when it is valid and ``kind``
        is where cycles end (or, no ender known yet, at once)."""
        cycle.types.add(kind)
        if not cycle.reportable:
            return
        if kind in self._report_at or (not self.cycle_enders
                                       and kind in _POSITION_TYPES | {"GSA"}):
            self._emit(cycle, out)

    def _set_status(self, cycle: _Cycle, valid: bool, lat_deg: float, lon_deg: float) -> None:
        """A status-bearing sentence's verdict; its position when valid. A position sent with
        a no-fix status is kept aside (``seen_*``) for a later GSA that reports a fix."""
        if cycle.emitted:
            return
        cycle.valid = valid
        if math.isfinite(lat_deg) and math.isfinite(lon_deg):
            cycle.seen_lat_deg, cycle.seen_lon_deg = lat_deg, lon_deg
        if valid:
            cycle.lat_deg, cycle.lon_deg = lat_deg, lon_deg

    # Sentence handlers (named _on_<type>; ``data``: the fields after the address) -------

    @staticmethod
    def _utc(value: str | None) -> float:
        return parse_time_of_day(value) if value else math.nan

    def _on_gga(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        utc = self._utc(data[0])
        quality = parse_int(data[5], 0)
        sats = parse_int(data[6], -1)
        # gpsd: a GGA claiming a fix from zero satellites is no fix.
        claims = quality > 0 and sats != 0
        lat, lon = parse_position(data[1], data[2], data[3], data[4], claims)
        valid = claims and math.isfinite(lat)
        sats = max(sats, 0)
        hdop = parse_float(data[7])
        alt = parse_float(data[8]) if len(data) > 8 else math.nan
        self._position_fix(timestamp_s, "GGA", utc, valid, lat, lon, (quality, sats, hdop, alt),
                           raw, out)

    def _position_fix(self, timestamp_s: float, kind: str, utc: float, valid: bool,
                      lat: float, lon: float, quality_sats_hdop_alt: tuple[int, int, float, float],
                      raw: bytes, out: list[GpsFix]) -> None:
        """The shared end of GGA and GNS: position, quality, satellites, HDOP and height into
        the cycle (a position sentence without a fix is counted as ``no_fix``)."""
        cycle = self._cycle_for(timestamp_s, kind, utc, out)
        self._set_status(cycle, valid, lat, lon)
        if not cycle.emitted:
            cycle.seen_quality = quality_sats_hdop_alt
        if valid:
            if not cycle.emitted:
                (cycle.fix_quality, cycle.satellites, cycle.hdop,
                 cycle.altitude_m) = quality_sats_hdop_alt
        else:
            self._reject("no_fix", raw)
        self._done(cycle, kind, out)

    def _on_rmc(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        utc = self._utc(data[0])
        mode = data[11] if len(data) > 11 else ""
        claims = data[1] == "A" and mode != "N"
        lat, lon = parse_position(data[2], data[3], data[4], data[5], claims)
        valid = claims and math.isfinite(lat)
        speed_kn = parse_float(data[6])
        course = parse_float(data[7])
        cycle = self._cycle_for(timestamp_s, "RMC", utc, out,
                                ender_candidate=data[1] in ("A", "D") and bool(data[8]))
        self._set_status(cycle, valid, lat, lon)
        if valid:
            if not cycle.emitted:
                # the FAA mode gives the quality unless a valid GGA/GNS already did
                if cycle.fix_quality == 0 or not ({"GGA", "GNS"} & cycle.types):
                    cycle.fix_quality = max(cycle.fix_quality, _FAA_QUALITY.get(mode, 1))
                if math.isfinite(speed_kn):
                    cycle.speed_mps = speed_kn * KNOT_MPS
                if math.isfinite(course):
                    cycle.course_deg = course
        else:
            self._reject("no_fix", raw)
        self._done(cycle, "RMC", out)

    def _on_gll(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        utc = self._utc(data[4]) if len(data) > 4 else math.nan
        status = data[5] if len(data) > 5 else ""
        mode = data[6] if len(data) > 6 else ""
        claims = status == "A" and mode != "N"
        lat, lon = parse_position(data[0], data[1], data[2], data[3], claims)
        valid = claims and math.isfinite(lat)
        cycle = self._cycle_for(timestamp_s, "GLL", utc, out)
        self._set_status(cycle, valid, lat, lon)
        if valid:
            if not cycle.emitted and cycle.fix_quality == 0:
                cycle.fix_quality = _FAA_QUALITY.get(mode, 1)
        else:
            self._reject("no_fix", raw)
        self._done(cycle, "GLL", out)

    def _on_gns(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        utc = self._utc(data[0])
        modes = data[5] if len(data) > 5 else ""
        quality = max((_FAA_QUALITY.get(m, 0) for m in modes), default=0)
        lat, lon = parse_position(data[1], data[2], data[3], data[4], quality > 0)
        valid = quality > 0 and math.isfinite(lat)
        sats = parse_int(data[6], 0) if len(data) > 6 else 0
        hdop = parse_float(data[7]) if len(data) > 7 else math.nan
        alt = parse_float(data[8]) if len(data) > 8 else math.nan
        self._position_fix(timestamp_s, "GNS", utc, valid, lat, lon, (quality, sats, hdop, alt),
                           raw, out)

    def _on_vtg(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        course = parse_float(data[0])
        speed_kn = parse_float(data[4]) if len(data) > 4 else math.nan
        speed_kmh = parse_float(data[6]) if len(data) > 6 else math.nan
        mode = data[8] if len(data) > 8 else ""
        cycle = self._cycle_for(timestamp_s, "VTG", math.nan, out)
        if mode != "N" and not cycle.emitted:
            if math.isfinite(speed_kmh):
                cycle.speed_mps = speed_kmh / 3.6
            elif math.isfinite(speed_kn):
                cycle.speed_mps = speed_kn * KNOT_MPS
            if math.isfinite(course):
                cycle.course_deg = course
        self._done(cycle, "VTG", out)

    def _on_gst(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        # GST's time is the time of the fix it qualifies, but gpsd leaves it out of cycle
        # detection; so do we: it goes into the cycle in progress when its time agrees.
        cycle = self._cycle_for(timestamp_s, "GST", math.nan, out)
        utc = self._utc(data[0])
        same = not (math.isfinite(utc) and math.isfinite(cycle.utc_time_s)) or _same_time(
            utc, cycle.utc_time_s)
        if not cycle.emitted and same:
            cycle.lat_sigma_m = parse_float(data[5]) if len(data) > 5 else math.nan
            cycle.lon_sigma_m = parse_float(data[6]) if len(data) > 6 else math.nan
        self._done(cycle, "GST", out)

    def _on_gbs(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        # Fault detection (RAIM) statistics: not used, but time-stamped, so it takes part in
        # the cycle (u-blox receivers end their cycle with it).
        cycle = self._cycle_for(timestamp_s, "GBS", self._utc(data[0]), out)
        self._done(cycle, "GBS", out)

    def _on_gsa(self, timestamp_s: float, data: list[str], raw: bytes,
                out: list[GpsFix]) -> None:
        hdop = parse_float(data[15]) if len(data) > 15 else math.nan
        mode = data[1] if len(data) > 1 else ""
        cycle = self._cycle_for(timestamp_s, "GSA", math.nan, out)
        if not cycle.emitted:
            if math.isfinite(hdop) and not math.isfinite(cycle.gsa_hdop):
                cycle.gsa_hdop = hdop
            if mode == "1":
                self._set_status(cycle, False, math.nan, math.nan)
            elif mode in ("2", "3") and not cycle.valid and math.isfinite(cycle.seen_lat_deg):
                self._gsa_fix(cycle, sum(1 for prn in data[2:14] if prn))
        self._done(cycle, "GSA", out)

    def _gsa_fix(self, cycle: _Cycle, used: int) -> None:
        """A GSA reports a 2D/3D fix while the cycle's latest position sentence said no fix:
        that position stands (as gpsd takes it: a GGA counting 0 satellites, then a GSA
        listing the ``used`` ones, as Garmin and Furuno receivers send), with the GGA's
        quality, HDOP and height when there was one."""
        self._set_status(cycle, True, cycle.seen_lat_deg, cycle.seen_lon_deg)
        quality, sats, hdop, alt = cycle.seen_quality or (0, 0, math.nan, math.nan)
        cycle.fix_quality = max(cycle.fix_quality, quality, 1)
        cycle.satellites = max(cycle.satellites, sats, used)
        if math.isfinite(hdop):
            cycle.hdop = hdop
        if math.isfinite(alt):
            cycle.altitude_m = alt
