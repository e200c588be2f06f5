"""Decode a CAN log (candump ``-L``, ASC, BLF: whatever ``can.LogReader`` reads) with a DBC.

Used by ``python main.py decode can FILE --dbc D.dbc``: one JSON-ready dict per decoded frame,
then one dict of counts. Unknown ids, frames of the wrong length and frames cantools refuses are
counted, never raised.
"""

from __future__ import annotations

import collections
import logging
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import can

from common.errors import DecodeError
from common.messages import CanFrame
from sensors.can_codec import CanCodec

logger = logging.getLogger(__name__)


def _plain(value: Any) -> Any:
    """A signal value as JSON: numbers stay numbers (NaN/inf as strings), choices as names."""
    if isinstance(value, bool):
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else str(value)
    return str(value)


def decode_log(path: str | Path, dbc_path: str | Path | None = None) -> Iterator[dict[str, Any]]:
    """Yield ``{"time_s", "id", "name", "signals"}`` per decoded frame, then
    ``{"counts": {"frames", "decoded", "unknown_id", "bad_length", "errors", "error_frames"}}``.

    ``time_s`` is the log's own timestamp (s), ``id`` the arbitration id (int), ``signals`` the
    physical values by signal name (value-table entries by their name). ``dbc_path`` None
    uses the car's DBC. A missing or unreadable log raises :class:`DecodeError`.
    """
    p = Path(path)
    if not p.is_file():
        raise DecodeError(f"{p}: no such CAN log")
    codec = CanCodec(dbc_path)
    counts: collections.Counter[str] = collections.Counter()
    for key in ("frames", "decoded", "unknown_id", "bad_length", "errors", "error_frames"):
        counts[key] = 0
    try:
        reader = can.LogReader(str(p))
    except Exception as exc:  # noqa: BLE001 (python-can's readers raise anything on junk)
        raise DecodeError(f"{p}: not a CAN log python-can reads "
                          f"({type(exc).__name__}: {exc})") from exc
    frames = iter(reader)
    try:
        while True:
            try:
                msg = next(frames)
            except StopIteration:
                break
            except Exception as exc:  # noqa: BLE001 (a corrupt log: python-can's error)
                counts["errors"] += 1
                logger.error("%s: stopped reading after %d frames: %s: %s", p,
                             counts["frames"], type(exc).__name__, exc)
                break
            counts["frames"] += 1
            if msg.is_error_frame:
                counts["error_frames"] += 1
                continue
            if msg.is_remote_frame:
                counts["remote_frames"] += 1
                continue
            before = sum(codec.rejects.values())
            frame = CanFrame(float(msg.timestamp), msg.arbitration_id, bytes(msg.data),
                             msg.is_extended_id)
            decoded = codec.decode_signals(frame, decode_choices=True)
            if decoded is None:
                if sum(codec.rejects.values()) == before:
                    counts["errors"] += 1
                continue
            message, signals = decoded
            counts["decoded"] += 1
            yield {
                "time_s": frame.timestamp_s,
                "id": frame.arbitration_id,
                "name": message.name,
                "signals": {k: _plain(v) for k, v in signals.items()},
            }
    finally:
        stop = getattr(reader, "stop", None)
        if callable(stop):
            stop()
    counts["unknown_id"] += codec.rejects["unknown_id"]
    counts["bad_length"] += codec.rejects["bad_length"]
    counts["errors"] += codec.rejects["decode_error"]
    yield {"counts": dict(counts)}
