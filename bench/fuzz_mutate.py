"""Byte mutations of real inputs for ``bench fuzz``: what a bad cable, a noisy radio link, a
buggy sensor firmware or a cut file does to the bytes a parser receives.

:class:`Mutator` applies one to four operators, chosen at random from a seeded
:class:`numpy.random.Generator`, to a seed input: flip bits, overwrite bytes with random or
"interesting" values (delimiters of the text protocols, 0x00, 0xFF, 0x7F, 0x80), insert random
bytes, delete or duplicate a span, truncate, splice in a span of another seed input, replace a
text number with an extreme one (``-``, ``nan``, ``1e308``, ``99999999999``), or return
garbage of the same length. The same seed gives the same inputs.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

import numpy as np

INTERESTING_BYTES = b"\x00\xff\x7f\x80$!*,\r\n.-0123456789AVNE"
"""Bytes that mean something to the text protocols, and the edges of a byte."""
EXTREME_NUMBERS = (b"", b"-", b"nan", b"inf", b"-0", b"1e308", b"99999999999", b"0.000000001",
                   b"4294967296", b"-2147483649", b"00", b"1.2.3", b"+")
"""Replacements for a run of digits in a text protocol."""
_NUMBER = re.compile(rb"[0-9][0-9.]*")


class Mutator:
    """Seeded byte mutations (see the module docstring)."""

    def __init__(self, seed: int, seeds: Sequence[bytes], in_place_share: float = 0.0) -> None:
        if not seeds:
            raise ValueError("no seed inputs to mutate")
        self.rng = np.random.default_rng(seed)
        self.seeds = list(seeds)
        self.in_place_share = in_place_share
        """Share of inputs mutated in place only (bit flips, overwrites: the length is kept),
        for formats whose length is checked first (a VLP-16 packet is 1206 bytes)."""
        self._operators: tuple[Callable[[bytearray], None], ...] = (
            self._flip_bits, self._flip_bits, self._overwrite, self._overwrite,
            self._insert, self._delete, self._duplicate, self._truncate, self._splice,
            self._number,
        )

    def pick(self) -> bytes:
        """One of the seed inputs, unchanged."""
        return self.seeds[int(self.rng.integers(len(self.seeds)))]

    def mutate(self, data: bytes) -> bytes:
        """``data`` with one to four mutations (or, rarely, replaced by garbage)."""
        rng = self.rng
        if rng.random() < 0.02:
            return rng.integers(0, 256, size=len(data), dtype=np.uint8).tobytes()
        out = bytearray(data)
        operators = self._operators
        if rng.random() < self.in_place_share:
            operators = (self._flip_bits, self._overwrite)
        for _ in range(int(rng.integers(1, 5))):
            operators[int(rng.integers(len(operators)))](out)
        return bytes(out)

    def next(self) -> bytes:
        """A mutated seed input."""
        return self.mutate(self.pick())

    # -- operators (each changes ``buf`` in place) ------------------------------------------

    def _span(self, buf: bytearray, longest: int = 64) -> tuple[int, int]:
        if not buf:
            return 0, 0
        start = int(self.rng.integers(len(buf)))
        return start, min(len(buf), start + int(self.rng.integers(1, longest + 1)))

    def _flip_bits(self, buf: bytearray) -> None:
        for _ in range(int(self.rng.integers(1, 9))):
            if buf:
                i = int(self.rng.integers(len(buf)))
                buf[i] ^= 1 << int(self.rng.integers(8))

    def _overwrite(self, buf: bytearray) -> None:
        for _ in range(int(self.rng.integers(1, 5))):
            if buf:
                i = int(self.rng.integers(len(buf)))
                if self.rng.random() < 0.5:
                    buf[i] = INTERESTING_BYTES[int(self.rng.integers(len(INTERESTING_BYTES)))]
                else:
                    buf[i] = int(self.rng.integers(256))

    def _insert(self, buf: bytearray) -> None:
        at = int(self.rng.integers(len(buf) + 1))
        buf[at:at] = self.rng.integers(0, 256, int(self.rng.integers(1, 17)),
                                       dtype=np.uint8).tobytes()

    def _delete(self, buf: bytearray) -> None:
        start, end = self._span(buf)
        del buf[start:end]

    def _duplicate(self, buf: bytearray) -> None:
        start, end = self._span(buf, 256)
        buf[end:end] = buf[start:end]

    def _truncate(self, buf: bytearray) -> None:
        if buf:
            del buf[int(self.rng.integers(len(buf))):]

    def _splice(self, buf: bytearray) -> None:
        other = self.pick()
        if not other:
            return
        start = int(self.rng.integers(len(other)))
        piece = other[start:start + int(self.rng.integers(1, 513))]
        at = int(self.rng.integers(len(buf) + 1))
        buf[at:at] = piece

    def _number(self, buf: bytearray) -> None:
        """Replace a run of ASCII digits (a field of a text protocol) by an extreme value."""
        runs = [m.span() for m in _NUMBER.finditer(buf)]
        if not runs:
            self._overwrite(buf)
            return
        start, end = runs[int(self.rng.integers(len(runs)))]
        buf[start:end] = EXTREME_NUMBERS[int(self.rng.integers(len(EXTREME_NUMBERS)))]
