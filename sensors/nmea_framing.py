"""NMEA 0183 framing and fields: bytes to candidate sentences, checksums, and the fields of a
sentence (coordinates, times, numbers) to SI values. :mod:`sensors.nmea` groups the sentences
into fixes; its docstring gives the framing rules.
"""

from __future__ import annotations

import collections
import math
import re

KNOT_MPS = 1852.0 / 3600.0
"""One knot in m/s."""

MAX_SENTENCE_CHARS = 200
"""Longest candidate kept (NMEA allows 82; real receivers send up to ~100, proprietary more)."""

_START = frozenset(b"$!")
_END = frozenset(b"\r\n")
_ADDRESS = re.compile(r"[A-Z][A-Z0-9]{2,9}")
"""A sentence's address: talker and type (``GPGGA``), or ``P`` and a proprietary name."""


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


_COORD = re.compile(r"[0-9]{3,}(\.[0-9]*)?")
"""A coordinate field: unsigned ``[d]ddmm[.mmmm]`` (the hemisphere letter carries the sign)."""


def parse_coord(value: str, hemisphere: str, degree_digits: int) -> float:
    """``ddmm.mmmm`` / ``dddmm.mmmm`` and N/S/E/W to signed degrees; ValueError if malformed.

    As gpsd reads it, the degrees are what stands before the minutes' two integer digits, so a
    longitude without its leading zero (``1131.000``) is still 11 deg 31'. A sign, an exponent
    or anything but digits and one point is malformed: ``-0214.4,W`` is no longitude."""
    value = value.strip()
    if _COORD.fullmatch(value) is None or hemisphere not in ("N", "S", "E", "W"):
        raise ValueError(f"bad coordinate {value!r} {hemisphere!r}")
    whole = value.split(".", 1)[0]
    degrees = int(whole[:-2])
    minutes = float(value[len(whole) - 2:])
    if not 0.0 <= minutes < 60.0:
        raise ValueError(f"bad minutes in {value!r}")
    result = degrees + minutes / 60.0
    limit = 90.0 if degree_digits == 2 else 180.0
    if result > limit:
        raise ValueError(f"coordinate {value!r} out of range")
    return -result if hemisphere in ("S", "W") else result


def parse_position(lat: str, lat_hemisphere: str, lon: str, lon_hemisphere: str, strict: bool
              ) -> tuple[float, float]:
    """Signed degrees of a sentence's position fields; NaN, NaN when they are empty, or when
    they are malformed and not ``strict`` (a sentence saying it has no fix may carry anything
    there); malformed and ``strict`` (the sentence claims a fix): ValueError."""
    if not lat or not lon:
        return math.nan, math.nan
    try:
        return parse_coord(lat, lat_hemisphere, 2), parse_coord(lon, lon_hemisphere, 3)
    except ValueError:
        if strict:
            raise
        return math.nan, math.nan


def parse_time_of_day(value: str) -> float:
    """``hhmmss[.ss]`` to seconds since midnight; ValueError if malformed."""
    if len(value) < 6 or not value[:6].isdigit():
        raise ValueError(f"bad time {value!r}")
    hours, minutes = int(value[0:2]), int(value[2:4])
    seconds = float(value[4:])
    if hours > 23 or minutes > 59 or not (math.isfinite(seconds) and 0.0 <= seconds < 61.0):
        raise ValueError(f"bad time {value!r}")
    return hours * 3600.0 + minutes * 60.0 + seconds


def parse_float(value: str | None) -> float:
    """A numeric field, NaN when empty; ValueError when not a finite number."""
    if value is None or value == "":
        return math.nan
    result = float(value)
    if not math.isfinite(result):
        raise ValueError(f"non-finite number {value!r}")
    return result


def parse_int(value: str | None, default: int) -> int:
    if value is None or value == "":
        return default
    return int(value)


def split_address(address: str) -> tuple[str, str]:
    """Talker and sentence type of an address: ``GPGGA`` -> ``("GP", "GGA")``; a proprietary
    sentence (``PGRME``, ``PUBX``) -> ``("P", address)``; ValueError when it is not one."""
    if not _ADDRESS.fullmatch(address):
        raise ValueError(f"bad address {address!r}")
    if address[0] == "P" or len(address) != 5:
        return "P" if address[0] == "P" else "", address
    return address[:2], address[2:]
