"""``info(path)``: what is in a recording, whether it had to be recovered, and its gaps."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from recordings.reader import RecordingReader

#: Inter-message gaps longer than this (s) are listed.
GAP_THRESHOLD_S = 1.0
#: At most this many long gaps are listed (the count is always given).
MAX_LISTED_GAPS = 100


def info(path: str | os.PathLike[str]) -> dict[str, Any]:
    """Summary of a recording as plain JSON-able values.

    Keys: ``path``, ``size_bytes``, ``recovered`` (the file was cut short or damaged and was
    read up to its last complete chunk), ``note`` (why), ``message_count``, ``start_time_s``,
    ``end_time_s``, ``duration_s``, ``chunk_count``, ``topics`` (per topic: ``schema``,
    ``count``, ``rate_hz``, ``first_s``, ``last_s``, ``max_gap_s``), ``gaps`` (inter-message gaps
    over 1 s: ``topic``, ``start_s``, ``end_s``, ``gap_s``), ``gap_count``, ``metadata``.
    Times are seconds on the recording's clock.

    Raises :class:`common.errors.RecordingError` when nothing can be read (not MCAP, no file).
    """
    with RecordingReader(path) as reader:
        schema_of = reader.topics
        counts: dict[str, int] = {}
        first_ns: dict[str, int] = {}
        last_ns: dict[str, int] = {}
        max_gap_ns: dict[str, int] = {}
        gaps: list[dict[str, Any]] = []
        gap_count = 0
        threshold_ns = round(GAP_THRESHOLD_S * 1e9)
        for message in reader.iter_messages():
            topic, t_ns = message.topic, message.log_time_ns
            previous = last_ns.get(topic)
            if previous is None:
                first_ns[topic] = t_ns
                counts[topic] = 0
                max_gap_ns[topic] = 0
            else:
                gap = t_ns - previous
                if gap > max_gap_ns[topic]:
                    max_gap_ns[topic] = gap
                if gap > threshold_ns:
                    gap_count += 1
                    if len(gaps) < MAX_LISTED_GAPS:
                        gaps.append({"topic": topic, "start_s": previous * 1e-9,
                                     "end_s": t_ns * 1e-9, "gap_s": gap * 1e-9})
            counts[topic] += 1
            last_ns[topic] = t_ns
        topics: dict[str, dict[str, Any]] = {}
        for topic in sorted(counts):
            n = counts[topic]
            span_s = (last_ns[topic] - first_ns[topic]) * 1e-9
            topics[topic] = {
                "schema": schema_of.get(topic, ""),
                "count": n,
                "rate_hz": (n - 1) / span_s if n > 1 and span_s > 0.0 else 0.0,
                "first_s": first_ns[topic] * 1e-9,
                "last_s": last_ns[topic] * 1e-9,
                "max_gap_s": max_gap_ns[topic] * 1e-9,
            }
        start_ns = min(first_ns.values()) if first_ns else 0
        end_ns = max(last_ns.values()) if last_ns else 0
        return {
            "path": str(Path(path)),
            "size_bytes": reader.size_bytes,
            "recovered": reader.recovered,
            "note": reader.note,
            "message_count": sum(counts.values()),
            "start_time_s": start_ns * 1e-9,
            "end_time_s": end_ns * 1e-9,
            "duration_s": (end_ns - start_ns) * 1e-9,
            "chunk_count": reader.chunk_count,
            "bad_chunks": reader.bad_chunks,
            "topics": topics,
            "gaps": gaps,
            "gap_count": gap_count,
            "metadata": reader.metadata,
        }
