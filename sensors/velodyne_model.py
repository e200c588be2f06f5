"""Which Velodyne sends these packets: the factory bytes and the packet timing, per packet.

The decoder (:mod:`sensors.velodyne`) turns returns into points with the configured model's
laser angles and firing times (``lidar.model``: the VLP-16 or the HDL-32E). Another sensor's
packets have the same 1206-byte layout but other angles and timing, so decoding them as the
configured model would give plausible-looking but wrong points. This module decides, packet by
packet, whether a (well-formed) data packet comes from the configured model (the rules below
are written for the default, the VLP-16; for the HDL-32E the same evidence is read the other
way: 0x21 is accepted unless the timing says another model, 0x22 only with HDL-32E timing).

Evidence (Velodyne user manuals):

- The factory bytes (the packet's last two): return mode (0x37 strongest, 0x38 last, 0x39
  dual) and product id (:data:`PRODUCT_IDS`: 0x21 HDL-32E, 0x22 VLP-16, 0x24 Puck Hi-Res, 0x28
  VLP-32C, 0x31 Velarray, 0xA1 VLS-128).
- The packet timing: the difference between the device timestamps (us past the hour, bytes
  1200..1203) of successive packets. A VLP-16 fills a packet in 12 blocks x 2 firing sequences
  x 55.296 us = 1327.104 us (dual return: 663.552 us); an HDL-32E in 12 x 46.08 = 552.96 us
  (dual 276.48), a VLP-32C in 12 x 55.296 = 663.552 us (dual 331.776). The Puck Hi-Res has the
  VLP-16's timing and layout but other elevations (+-10 deg): only its id tells it apart.

Rules (:class:`ModelGuard`):

- an id other than 0x21 or 0x22, or an unknown return mode: refused (that model, or unknown);
- an interval of 1..4 VLP-16 packet periods (within :data:`TIMING_TOLERANCE_US`) is VLP-16
  timing; an interval matching another model's period (or its multiples) is that model's; any
  other interval (the first packet, a long gap, a jump) tells nothing, and the stream's last
  verdict stands;
- 0x22 (VLP-16) is accepted unless the timing says another model;
- 0x21 is the HDL-32E's id, but early VLP-16 firmware sends it too (the shared capture
  ``velodyne_vlp16.pcap``: 0x21 with 1327 us between packets): it is accepted only when the
  timing says VLP-16.
- The first packet of a stream is held back until the next one tells its timing (one packet of
  delay, once), so not even one packet of another model is decoded. Should the next one not
  tell (a long gap, the end of the stream), the held packet goes by its id alone.

A refused packet is counted by model (``ModelGuard.refused``) and logged as one warning line
naming the model and why, the first time and every 1000th.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass
from typing import Generic, TypeVar

from sensors.velodyne import (
    PACKET_SIZE,
    PRODUCT_VLP16,
    RETURN_MODE_DUAL,
    RETURN_MODE_LAST,
    RETURN_MODE_STRONGEST,
)

log = logging.getLogger(__name__)

PRODUCT_HDL32E = 0x21
PRODUCT_IDS = {0x21: "HDL-32E", 0x22: "VLP-16", 0x24: "Puck Hi-Res", 0x28: "VLP-32C",
               0x31: "Velarray", 0xA1: "VLS-128"}
"""Velodyne product ids (the packet's last byte) and the sensor they name."""
RETURN_MODES = (RETURN_MODE_STRONGEST, RETURN_MODE_LAST, RETURN_MODE_DUAL)

VLP16 = "VLP-16"
HDL32E = "HDL-32E"
ID_MODEL = {PRODUCT_VLP16: VLP16, PRODUCT_HDL32E: HDL32E}
"""The product ids whose packets can be told apart by their timing, and the model each names
when the timing is not known."""
PACKET_PERIOD_US = {
    VLP16: 1327.104,
    "HDL-32E": 552.96,
    "VLP-32C": 663.552,
}
"""Device time between two single-return data packets of each model (us); dual return halves
it."""
TIMING_TOLERANCE_US = 5.0
"""How far an interval may be from a multiple of a period (us): device timestamps are whole
microseconds of the sensor's own clock, so a VLP-16's read 1327 or 1328."""
MAX_PERIODS = 4
"""Intervals up to this many periods (a few lost packets) are classified; longer ones tell
nothing (4 VLP-16 periods cannot be mistaken for a multiple of the HDL-32E's: 5 could)."""
_HOUR_US = 3_600_000_000
T = TypeVar("T")
LOG_EVERY = 1000


@dataclass(frozen=True, slots=True)
class Verdict:
    """What one packet is: ``model`` (``"VLP-16"``, ``"HDL-32E"``, ...) and ``why``."""

    model: str
    why: str

    @property
    def accepted(self) -> bool:
        """Whether it is a VLP-16's (:meth:`ModelGuard.accepts` for another expected model)."""
        return self.model == VLP16


def _period_us(model: str, mode: int) -> float:
    period = PACKET_PERIOD_US[model]
    return period / 2.0 if mode == RETURN_MODE_DUAL else period


def _periods(mode: int) -> tuple[tuple[str, float, float], ...]:
    """(model, period (us), longest interval classified (us)) for return ``mode``, VLP-16
    first (it wins a tie: a lost VLP-32C packet)."""
    return tuple((model, _period_us(model, mode), (MAX_PERIODS + 0.5) * _period_us(model, mode))
                 for model in PACKET_PERIOD_US)


_PERIODS = {mode: _periods(mode) for mode in (RETURN_MODE_STRONGEST, RETURN_MODE_LAST,
                                              RETURN_MODE_DUAL)}
""":func:`_periods` of each return mode, worked out once (timing_model runs per packet)."""


def timing_model(interval_us: int, mode: int) -> str | None:
    """The model whose packet timing ``interval_us`` (device time between successive packets)
    shows for return ``mode``, or None when it shows none (too long, zero, negative)."""
    if interval_us <= 0:
        return None
    periods = _PERIODS.get(mode)
    if periods is None:
        periods = _periods(mode)
    for model, period, longest in periods:
        if interval_us > longest:
            continue
        k = max(1, round(interval_us / period))
        if abs(interval_us - k * period) <= TIMING_TOLERANCE_US:
            return model
    return None


class ModelGuard(Generic[T]):
    """Per packet stream: which packets are the ``expected`` model's (default ``"VLP-16"``, or
    ``"HDL-32E"``; see the module docstring).

    :meth:`admit` takes a well-formed data packet (``check_packet`` passed) with any item that
    travels with it (its arrival time, ...) and returns the items now known to be packets of
    the expected model, in arrival order; the rest are counted in :attr:`refused` by model.
    """

    def __init__(self, source: str = "lidar", expected: str = VLP16) -> None:
        if expected not in ID_MODEL.values():
            raise ValueError(f"ModelGuard: cannot tell {expected!r} packets; only "
                             f"{', '.join(sorted(ID_MODEL.values()))}")
        self.source = source
        self.expected = expected
        """The model whose packets are decoded."""
        self.refused: Counter[str] = Counter()
        """Packets refused, by model (``"HDL-32E"``, ``"unknown id 0x00"``, ...)."""
        self.refused_count = 0
        """Packets refused in all (the sum of :attr:`refused`)."""
        self.verdict: Verdict | None = None
        """The stream's last verdict from the timing (None: none yet)."""
        self._last_us: int | None = None
        self._held: tuple[T, bytes] | None = None
        self._verdicts: dict[tuple[str, int, int], Verdict] = {}
        """Verdicts from the timing by (model, product id, interval): the same few recur for
        every packet of a stream, so each is made once."""

    def reset(self) -> None:
        """Forget the stream (a new sensor, a reconnection); a held packet is dropped."""
        self.verdict = None
        self._last_us = None
        self._held = None

    def admit(self, item: T, payload: bytes) -> list[T]:
        """The items of the packets known to be a VLP-16's after ``payload`` arrived."""
        if len(payload) != PACKET_SIZE:
            raise ValueError(f"not a data packet ({len(payload)} bytes)")
        mode, product = payload[1204], payload[1205]
        stamp_us = int.from_bytes(payload[1200:1204], "little")
        interval = None if self._last_us is None else (stamp_us - self._last_us) % _HOUR_US
        self._last_us = stamp_us
        if mode not in RETURN_MODES:
            self._refuse(Verdict(f"unknown (return mode byte 0x{mode:02X})",
                                 "its factory bytes are not a VLP-16's"))
            return self._release(None)
        if product not in (PRODUCT_VLP16, PRODUCT_HDL32E):
            name = PRODUCT_IDS.get(product, f"unknown (product id 0x{product:02X})")
            self._refuse(Verdict(name, f"its product id is 0x{product:02X}"))
            return self._release(None)
        timed = timing_model(interval, mode) if interval is not None else None
        if timed is not None:
            assert interval is not None
            self.verdict = self._timed_verdict(timed, product, interval)
        out = self._release(self.verdict) if self._held is not None else []
        verdict = self.verdict
        if verdict is None:
            self._held = (item, payload)  # no timing yet: wait for the next packet
            return out
        if self.accepts(verdict):
            return [*out, item]
        self._refuse(verdict)
        return out

    def admit_all(self, stamps_us: list[int], mode: int, product: int) -> bool:
        """Admit a run of packets at once (a sweep unit's: their timestamps in order, one
        return mode and product id for all) when :meth:`admit` would admit every one of them:
        then the stream's state is left as those calls would leave it and True is returned;
        otherwise nothing changes and False is returned (admit them one by one)."""
        if (self._held is not None or self._last_us is None or mode not in RETURN_MODES
                or product not in (PRODUCT_VLP16, PRODUCT_HDL32E)):
            return False
        model = None if self.verdict is None else self.verdict.model
        last_timed: tuple[str, int] | None = None
        timed_of: dict[int, str | None] = {}
        previous = self._last_us
        for stamp in stamps_us:
            interval = (stamp - previous) % _HOUR_US
            previous = stamp
            if interval not in timed_of:
                timed_of[interval] = timing_model(interval, mode)
            timed = timed_of[interval]
            if timed is not None:
                model, last_timed = timed, (timed, interval)
            if model != self.expected:
                return False
        if last_timed is not None:
            self.verdict = self._timed_verdict(last_timed[0], product, last_timed[1])
        self._last_us = stamps_us[-1]
        return True

    def _timed_verdict(self, timed: str, product: int, interval: int) -> Verdict:
        """The verdict of the timing (the model ``timed`` told by ``interval`` us between
        packets of ``product``), made once per key."""
        key = (timed, product, interval)
        verdict = self._verdicts.get(key)
        if verdict is None:
            verdict = Verdict(timed, f"product id 0x{product:02X} and {interval} us "
                                     "between packets")
            if len(self._verdicts) < 1024:
                self._verdicts[key] = verdict
        return verdict

    def accepts(self, verdict: Verdict) -> bool:
        """Whether ``verdict`` names the expected model."""
        return verdict.model == self.expected

    def flush(self) -> list[T]:
        """End of the stream: the held packet, decided by the stream's verdict or its id."""
        return self._release(self.verdict)

    def _release(self, verdict: Verdict | None) -> list[T]:
        """Decide the held packet with ``verdict``; None (its timing was never told): by its id
        (0x22 a VLP-16's, 0x21 an HDL-32E's), accepted when that is the expected model."""
        held, self._held = self._held, None
        if held is None:
            return []
        if verdict is None:
            product = held[1][1205]
            verdict = Verdict(ID_MODEL[product], f"its product id is 0x{product:02X} and its "
                                                 "packet timing could not be measured")
        if self.accepts(verdict):
            return [held[0]]
        self._refuse(verdict)
        return []

    def _refuse(self, verdict: Verdict) -> None:
        self.refused[verdict.model] += 1
        self.refused_count += 1
        n = self.refused[verdict.model]
        if n == 1 or n % LOG_EVERY == 0:
            log.warning("%s: refusing packets from a Velodyne %s (%s): only a %s is decoded "
                        "(lidar.model), another sensor's data is never turned into points with "
                        "%s angles (%d refused so far)", self.source, verdict.model, verdict.why,
                        self.expected, self.expected, n)
