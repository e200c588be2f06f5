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
  ``require_checksum``), parses it with pynmea2 and merges the sentences of one epoch (same UTC
  time) into one :class:`GpsFix`.

Sentences used (any talker: GP, GN, GL, GA, GB, ...): GGA (position, quality, satellites, HDOP,
altitude above mean sea level), RMC (status, position, speed, course), GLL (position, status),
GNS (position, mode, satellites, HDOP, altitude), VTG (speed, course), GSA (HDOP when no GGA;
its fix mode) and GST (the receiver's 1-sigma latitude and longitude errors, m). Others are
counted by type and otherwise ignored.

Status. The epoch's fix is valid when its latest status-bearing sentence says so: GGA quality
> 0 with satellites, RMC/GLL status ``A`` (FAA mode not ``N``), GNS mode, or a GSA fix mode
of 2 or 3, which vouches for the epoch's latest position even when that position's own sentence
said otherwise (as gpsd takes it: Garmin and Furuno receivers send a GGA counting 0 satellites,
then a GSA listing the satellites used); GSA mode 1 means no fix.

Epochs. Receivers send a burst of sentences per navigation epoch (e.g. RMC, VTG, GGA, GSA, GSV,
GLL at 1-10 Hz). Like gpsd, the parser learns the "cycle ender" (the sentence type that last
arrived before the UTC time changed) and emits the epoch's fix as soon as that type arrives,
so a fix is not held back until the next epoch; before the ender is known, a fix is emitted
when a sentence of a new time arrives (or on :meth:`NmeaParser.flush`). One fix per epoch:
sentences of an epoch that arrive after its fix was emitted are counted, not re-emitted.
The fix carries the position of the epoch's latest valid position sentence (as gpsd's report
does) and its ``timestamp_s`` is the receive time of the epoch's first sentence.

``GpsFix.utc_time_s`` is the UTC time of day (s since midnight); ``course_rad`` is an ENU yaw
(counter-clockwise from east), converted from NMEA's degrees clockwise from true north.

Rejects (``NmeaParser.rejects``, by reason): ``bad_checksum``, ``garbled`` (unframeable or
unparsable text, bad numbers), ``too_long``, ``binary`` (a candidate cut by non-printable
bytes), ``junk`` (runs of bytes outside any sentence), ``unsupported`` (a sentence type
pynmea2 does not know), ``no_checksum`` (only with ``require_checksum``), ``no_fix``
(a position sentence saying there is no fix, or with empty position fields), ``parser_error``
(an unexpected exception inside the parser: logged with its traceback; a bug).
``NmeaParser.counts`` counts accepted sentences by type (``GGA``, ``RMC``, ...), ``sentences``
and ``fixes``.
"""

from __future__ import annotations

import collections
import logging
import math
from dataclasses import dataclass, field

import pynmea2

from common.conventions import compass_deg_to_enu_yaw
from common.messages import GpsFix

log = logging.getLogger(__name__)

MAX_SENTENCE_CHARS = 200
"""Longest candidate kept (NMEA allows 82; real receivers send up to ~100, proprietary more)."""

KNOT_MPS = 1852.0 / 3600.0
"""One knot in m/s."""

_START = frozenset(b"$!")
_END = frozenset(b"\r\n")
_POSITION_TYPES = frozenset({"GGA", "RMC", "GLL", "GNS"})
_EPOCH_TYPES = _POSITION_TYPES | {"VTG"}
"""Types that appear once per epoch: a second one means a new epoch began."""
_FAA_QUALITY = {"A": 1, "D": 2, "P": 3, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8}
"""FAA mode indicator (RMC, GLL, VTG, GNS) to GGA quality; ``N`` means no fix."""


def nmea_checksum(body: bytes) -> int:
    """XOR of the bytes between ``$`` and ``*`` (``body`` excludes both)."""
    value = 0
    for byte in body:
        value ^= byte
    return value


def with_checksum(body: str) -> bytes:
    """A complete sentence ``$<body>*HH\\r\\n`` as bytes (``body`` without ``$`` and ``*``)."""
    raw = body.encode("ascii")
    return b"$" + raw + b"*%02X\r\n" % nmea_checksum(raw)


class NmeaFramer:
    """Cuts a byte stream fed in arbitrary chunks into candidate sentences (bytes, no CR LF).

    ``rejects`` counts what framing threw away: ``junk`` (one per run of bytes outside a
    sentence), ``binary`` (a candidate cut by a non-printable byte), ``too_long``.
    """

    def __init__(self, max_chars: int = MAX_SENTENCE_CHARS) -> None:
        self.max_chars = max_chars
        self.rejects: collections.Counter[str] = collections.Counter()
        self._current = bytearray()
        self._in_sentence = False
        self._in_junk = False
        self._overflow = False

    def feed(self, data: bytes) -> list[bytes]:
        """Frame ``data``; return the sentences completed by it (start char kept, end stripped)."""
        out: list[bytes] = []
        current = self._current
        for byte in bytes(data):
            if byte in _START:
                if self._in_sentence:
                    self._finish(out)
                self._in_sentence = True
                self._in_junk = False
                self._overflow = False
                current.append(byte)
            elif not self._in_sentence:
                if byte not in _END and not self._in_junk:
                    self._in_junk = True
                    self.rejects["junk"] += 1
            elif byte in _END:
                self._finish(out)
            elif 0x20 <= byte < 0x7F:
                if self._overflow:
                    continue
                if len(current) >= self.max_chars:
                    self.rejects["too_long"] += 1
                    current.clear()
                    self._overflow = True
                    continue
                current.append(byte)
            else:
                # Non-printable: binary data (UBX, noise) inside what looked like a sentence.
                self.rejects["binary"] += 1
                current.clear()
                self._in_sentence = False
                self._overflow = False
                self._in_junk = True
        return out

    def _finish(self, out: list[bytes]) -> None:
        if not self._overflow and len(self._current) > 1:
            out.append(bytes(self._current))
        elif not self._overflow:
            self.rejects["garbled"] += 1
        self._current.clear()
        self._in_sentence = False
        self._overflow = False

    def flush(self) -> list[bytes]:
        """End of stream: return the unterminated last candidate, if any."""
        out: list[bytes] = []
        if self._in_sentence:
            self._finish(out)
        return out

    def reset(self) -> None:
        """Forget any partial sentence (e.g. after a reconnection)."""
        self._current.clear()
        self._in_sentence = False
        self._in_junk = False
        self._overflow = False


def split_sentences(data: bytes) -> list[bytes]:
    """All sentences framed in one complete buffer (the last one may lack its line end)."""
    framer = NmeaFramer()
    return framer.feed(data) + framer.flush()


def check_sentence(sentence: bytes) -> str | None:
    """``None`` when ``sentence`` (``$...*HH``) has a correct checksum; else a reject reason.

    Reasons: ``bad_checksum``, ``garbled`` (``*`` not followed by exactly two hex digits),
    ``no_checksum``.
    """
    star = sentence.rfind(b"*")
    if star < 0:
        return "no_checksum"
    digits = sentence[star + 1 :]
    if len(digits) != 2:
        return "garbled"
    try:
        expected = int(digits, 16)
    except ValueError:
        return "garbled"
    if nmea_checksum(sentence[1:star]) != expected:
        return "bad_checksum"
    return None


def _coord(value: str, hemisphere: str, degree_digits: int) -> float:
    """``ddmm.mmmm`` / ``dddmm.mmmm`` and N/S/E/W to signed degrees; ValueError if malformed."""
    if len(value) < degree_digits + 2 or hemisphere not in ("N", "S", "E", "W"):
        raise ValueError(f"bad coordinate {value!r} {hemisphere!r}")
    degrees = int(value[:degree_digits])
    minutes = float(value[degree_digits:])
    if not (math.isfinite(minutes) and 0.0 <= minutes < 60.0):
        raise ValueError(f"bad minutes in {value!r}")
    result = degrees + minutes / 60.0
    limit = 90.0 if degree_digits == 2 else 180.0
    if result > limit:
        raise ValueError(f"coordinate {value!r} out of range")
    return -result if hemisphere in ("S", "W") else result


def _position(lat: str, lat_hemisphere: str, lon: str, lon_hemisphere: str, strict: bool
              ) -> tuple[float, float]:
    """Signed degrees of a sentence's position fields; NaN, NaN when they are empty, or when
    they are malformed and not ``strict`` (a sentence saying it has no fix may carry anything
    there); malformed and ``strict`` (the sentence claims a fix): ValueError."""
    if not lat or not lon:
        return math.nan, math.nan
    try:
        return _coord(lat, lat_hemisphere, 2), _coord(lon, lon_hemisphere, 3)
    except ValueError:
        if strict:
            raise
        return math.nan, math.nan


def _time_of_day(value: str) -> float:
    """``hhmmss[.ss]`` to seconds since midnight; ValueError if malformed."""
    if len(value) < 6 or not value[:6].isdigit():
        raise ValueError(f"bad time {value!r}")
    hours, minutes = int(value[0:2]), int(value[2:4])
    seconds = float(value[4:])
    if hours > 23 or minutes > 59 or not (math.isfinite(seconds) and 0.0 <= seconds < 61.0):
        raise ValueError(f"bad time {value!r}")
    return hours * 3600.0 + minutes * 60.0 + seconds


def _float(value: str | None) -> float:
    """A numeric field, NaN when empty; ValueError when not a finite number."""
    if value is None or value == "":
        return math.nan
    result = float(value)
    if not math.isfinite(result):
        raise ValueError(f"non-finite number {value!r}")
    return result


def _int(value: str | None, default: int) -> int:
    if value is None or value == "":
        return default
    return int(value)


@dataclass(slots=True)
class _Epoch:
    """What is known about one navigation epoch so far."""

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
    """What the epoch's latest status-bearing sentence (GGA, RMC, GLL, GNS, GSA) said."""
    seen_lat_deg: float = math.nan
    seen_lon_deg: float = math.nan
    """The latest position of the epoch whatever its sentence's status (a GSA's fix mode may
    vouch for it)."""
    seen_quality: tuple[int, int, float, float] | None = None
    """The latest GGA/GNS quality, satellites, HDOP and altitude, whatever their status."""
    types: set[str] = field(default_factory=set)
    last_type: str = ""
    emitted: bool = False

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


class NmeaParser:
    """NMEA bytes in any chunking to one :class:`GpsFix` per epoch with a valid position.

    ``feed`` never raises: anything it cannot use is counted in ``rejects`` by reason (see the
    module docstring) and logged at debug level.
    """

    source = "gps"

    def __init__(self, require_checksum: bool = False) -> None:
        self.require_checksum = require_checksum
        self.framer = NmeaFramer()
        self.rejects: collections.Counter[str] = self.framer.rejects
        self.counts: collections.Counter[str] = collections.Counter()
        self._epoch: _Epoch | None = None
        self._ender: str = ""

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
        """End of stream: emit the pending epoch's fix, if it has not been emitted."""
        out: list[GpsFix] = []
        for sentence in self.framer.flush():
            self._sentence(self._epoch.timestamp_s if self._epoch else 0.0, sentence, out)
        self._close_epoch(out)
        return out

    # -- internals ------------------------------------------------------------------------

    def _reject(self, reason: str, sentence: bytes) -> None:
        self.rejects[reason] += 1
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
        text = sentence.decode("ascii")
        try:
            msg = pynmea2.parse(text)
        except pynmea2.SentenceTypeError:
            self._reject("unsupported", sentence)
            return
        except (pynmea2.ParseError, ValueError, TypeError, AttributeError, KeyError,
                IndexError):
            self._reject("garbled", sentence)
            return
        kind = str(getattr(msg, "sentence_type", "") or type(msg).__name__)
        self.counts["sentences"] += 1
        self.counts[kind] += 1
        handler = getattr(self, f"_on_{kind.lower()}", None)
        if handler is None:
            return
        handler(timestamp_s, msg, sentence, out)

    # Epoch bookkeeping ---------------------------------------------------------------

    def _epoch_for(self, timestamp_s: float, kind: str, utc_time_s: float,
                   out: list[GpsFix]) -> _Epoch:
        """The epoch a sentence of ``kind`` at ``utc_time_s`` (NaN if it has none) belongs to."""
        epoch = self._epoch
        if epoch is not None:
            new_time = (math.isfinite(utc_time_s) and math.isfinite(epoch.utc_time_s)
                        and abs(utc_time_s - epoch.utc_time_s) > 1e-6)
            repeated = kind in _EPOCH_TYPES and kind in epoch.types
            if new_time or repeated:
                if new_time and epoch.last_type:
                    self._ender = epoch.last_type
                self._close_epoch(out)
                epoch = None
        if epoch is None:
            epoch = _Epoch(timestamp_s=timestamp_s)
            self._epoch = epoch
        if math.isfinite(utc_time_s) and not math.isfinite(epoch.utc_time_s):
            epoch.utc_time_s = utc_time_s
        return epoch

    def _close_epoch(self, out: list[GpsFix]) -> None:
        epoch = self._epoch
        self._epoch = None
        if epoch is not None and epoch.reportable:
            self._emit(epoch, out)

    def _emit(self, epoch: _Epoch, out: list[GpsFix]) -> None:
        epoch.emitted = True
        out.append(epoch.to_fix())
        self.counts["fixes"] += 1

    def _done(self, epoch: _Epoch, kind: str, out: list[GpsFix]) -> None:
        """Record that ``kind`` arrived; emit when the epoch is complete.

        Complete means: ``kind`` is the learned cycle ender, or (no ender learned yet) it
        carried a valid position.
        """
        epoch.types.add(kind)
        epoch.last_type = kind
        if not epoch.reportable:
            return
        if kind == self._ender or (not self._ender and kind in _POSITION_TYPES):
            self._emit(epoch, out)

    def _set_status(self, epoch: _Epoch, valid: bool, lat_deg: float, lon_deg: float) -> None:
        """A status-bearing sentence's verdict; its position when valid. A position sent with
        a no-fix status is kept aside (``seen_*``) for a later GSA that reports a fix."""
        if epoch.emitted:
            return
        epoch.valid = valid
        if math.isfinite(lat_deg) and math.isfinite(lon_deg):
            epoch.seen_lat_deg, epoch.seen_lon_deg = lat_deg, lon_deg
        if valid:
            epoch.lat_deg, epoch.lon_deg = lat_deg, lon_deg

    # Sentence handlers (named _on_<type>) --------------------------------------------

    def _utc(self, value: str | None) -> float:
        return _time_of_day(value) if value else math.nan

    def _on_gga(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        utc = self._utc(msg.data[0])
        quality = _int(msg.data[5], 0)
        sats = _int(msg.data[6], -1)
        # gpsd: a GGA claiming a fix from zero satellites is no fix.
        claims = quality > 0 and sats != 0
        lat, lon = _position(msg.data[1], msg.data[2], msg.data[3], msg.data[4], claims)
        valid = claims and math.isfinite(lat)
        sats = max(sats, 0)
        hdop = _float(msg.data[7])
        alt = _float(msg.data[8]) if len(msg.data) > 8 else math.nan
        self._position_fix(timestamp_s, "GGA", utc, valid, lat, lon, (quality, sats, hdop, alt),
                           raw, out)

    def _position_fix(self, timestamp_s: float, kind: str, utc: float, valid: bool,
                      lat: float, lon: float, quality_sats_hdop_alt: tuple[int, int, float, float],
                      raw: bytes, out: list[GpsFix]) -> None:
        """The shared end of GGA and GNS: position, quality, satellites, HDOP and height into
        the epoch (a position sentence without a fix is counted as ``no_fix``)."""
        epoch = self._epoch_for(timestamp_s, kind, utc, out)
        self._set_status(epoch, valid, lat, lon)
        if not epoch.emitted:
            epoch.seen_quality = quality_sats_hdop_alt
        if valid:
            if not epoch.emitted:
                (epoch.fix_quality, epoch.satellites, epoch.hdop,
                 epoch.altitude_m) = quality_sats_hdop_alt
        else:
            self._reject("no_fix", raw)
        self._done(epoch, kind, out)

    def _on_rmc(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        utc = self._utc(data[0])
        mode = data[11] if len(data) > 11 else ""
        claims = data[1] == "A" and mode != "N"
        lat, lon = _position(data[2], data[3], data[4], data[5], claims)
        valid = claims and math.isfinite(lat)
        speed_kn = _float(data[6])
        course = _float(data[7])
        epoch = self._epoch_for(timestamp_s, "RMC", utc, out)
        self._set_status(epoch, valid, lat, lon)
        if valid:
            if not epoch.emitted:
                # the FAA mode gives the quality unless a valid GGA/GNS already did
                if epoch.fix_quality == 0 or not ({"GGA", "GNS"} & epoch.types):
                    epoch.fix_quality = max(epoch.fix_quality, _FAA_QUALITY.get(mode, 1))
                if math.isfinite(speed_kn):
                    epoch.speed_mps = speed_kn * KNOT_MPS
                if math.isfinite(course):
                    epoch.course_deg = course
        else:
            self._reject("no_fix", raw)
        self._done(epoch, "RMC", out)

    def _on_gll(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        utc = self._utc(data[4]) if len(data) > 4 else math.nan
        status = data[5] if len(data) > 5 else ""
        mode = data[6] if len(data) > 6 else ""
        claims = status == "A" and mode != "N"
        lat, lon = _position(data[0], data[1], data[2], data[3], claims)
        valid = claims and math.isfinite(lat)
        epoch = self._epoch_for(timestamp_s, "GLL", utc, out)
        self._set_status(epoch, valid, lat, lon)
        if valid:
            if not epoch.emitted and epoch.fix_quality == 0:
                epoch.fix_quality = _FAA_QUALITY.get(mode, 1)
        else:
            self._reject("no_fix", raw)
        self._done(epoch, "GLL", out)

    def _on_gns(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        utc = self._utc(data[0])
        modes = data[5] if len(data) > 5 else ""
        quality = max((_FAA_QUALITY.get(m, 0) for m in modes), default=0)
        lat, lon = _position(data[1], data[2], data[3], data[4], quality > 0)
        valid = quality > 0 and math.isfinite(lat)
        sats = _int(data[6], 0) if len(data) > 6 else 0
        hdop = _float(data[7]) if len(data) > 7 else math.nan
        alt = _float(data[8]) if len(data) > 8 else math.nan
        self._position_fix(timestamp_s, "GNS", utc, valid, lat, lon, (quality, sats, hdop, alt),
                           raw, out)

    def _on_vtg(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        course = _float(data[0])
        speed_kn = _float(data[4]) if len(data) > 4 else math.nan
        speed_kmh = _float(data[6]) if len(data) > 6 else math.nan
        mode = data[8] if len(data) > 8 else ""
        epoch = self._epoch_for(timestamp_s, "VTG", math.nan, out)
        if mode != "N" and not epoch.emitted:
            if math.isfinite(speed_kmh):
                epoch.speed_mps = speed_kmh / 3.6
            elif math.isfinite(speed_kn):
                epoch.speed_mps = speed_kn * KNOT_MPS
            if math.isfinite(course):
                epoch.course_deg = course
        self._done(epoch, "VTG", out)

    def _on_gst(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        epoch = self._epoch_for(timestamp_s, "GST", self._utc(data[0]), out)
        if not epoch.emitted:
            epoch.lat_sigma_m = _float(data[5]) if len(data) > 5 else math.nan
            epoch.lon_sigma_m = _float(data[6]) if len(data) > 6 else math.nan
        self._done(epoch, "GST", out)

    def _on_gsa(self, timestamp_s: float, msg: pynmea2.NMEASentence, raw: bytes,
                out: list[GpsFix]) -> None:
        data = msg.data
        hdop = _float(data[15]) if len(data) > 15 else math.nan
        mode = data[1] if len(data) > 1 else ""
        epoch = self._epoch_for(timestamp_s, "GSA", math.nan, out)
        if not epoch.emitted:
            if math.isfinite(hdop) and not math.isfinite(epoch.gsa_hdop):
                epoch.gsa_hdop = hdop
            if mode == "1":
                self._set_status(epoch, False, math.nan, math.nan)
            elif mode in ("2", "3") and not epoch.valid and math.isfinite(epoch.seen_lat_deg):
                self._gsa_fix(epoch, sum(1 for prn in data[2:14] if prn))
        self._done(epoch, "GSA", out)

    def _gsa_fix(self, epoch: _Epoch, used: int) -> None:
        """A GSA reports a 2D/3D fix while the epoch's latest position sentence said no fix:
        that position stands (as gpsd takes it: a GGA counting 0 satellites, then a GSA
        listing the ``used`` ones, as Garmin and Furuno receivers send), with the GGA's
        quality, HDOP and height when there was one."""
        self._set_status(epoch, True, epoch.seen_lat_deg, epoch.seen_lon_deg)
        quality, sats, hdop, alt = epoch.seen_quality or (0, 0, math.nan, math.nan)
        epoch.fix_quality = max(epoch.fix_quality, quality, 1)
        epoch.satellites = max(epoch.satellites, sats, used)
        if math.isfinite(hdop):
            epoch.hdop = hdop
        if math.isfinite(alt):
            epoch.altitude_m = alt
