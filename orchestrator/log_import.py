"""``import FORMAT SOURCE --out X.mcap``: a foreign log written as one of our recordings.

The format's importer (:mod:`recordings.importers`) reads the log into our readings; here they
become the bytes our receivers produce on the car, on the raw topics a replay parses:

- GNSS fixes: NMEA GGA and RMC (:func:`sensors.nmea_encode.fix_sentences`) on ``/gps/nmea``;
- IMU samples: the IMU's binary packets (:func:`sensors.imu_protocol.encode_imu_packet`, the
  sample's time as the sensor's own clock) on ``/imu/packet``;
- wheel speeds and steering: the car's CAN frames (``sensors/car.dbc``) on ``/can/frame``.

The reference poses go on ``/truth/pose`` (:class:`common.messages.GroundTruth` in the ENU frame
given in the metadata), and the car's configuration (the defaults with the importer's
overrides) into the ``fsd`` metadata as ``config_toml``, where a replay takes it from.
``drop_gnss`` (start s after the log's first reading, duration s) has the importer leave the
fixes of that window out, and out of its calibrations: a GNSS outage.
"""

from __future__ import annotations

import logging
from collections import Counter
from pathlib import Path
from typing import Any

from common.config import apply_overrides, config_to_toml
from common.errors import ConfigError, RecordingError
from common.messages import GpsFix, ImuSample, RawBytes, SteeringAngle, WheelSpeeds
from orchestrator.config import AppConfig
from recordings.importers import IMPORTERS, GnssOutage, ImportedLog
from recordings.recorder import Recorder
from recordings.topics import TRUTH_POSE
from sensors.can_codec import CanCodec
from sensors.imu_protocol import encode_imu_packet
from sensors.nmea_encode import fix_sentences

log = logging.getLogger(__name__)


def parse_outage(text: str) -> GnssOutage:
    """``START_S:DURATION_S`` (seconds, both >= 0, duration > 0)."""
    try:
        start, duration = (float(v) for v in text.split(":"))
    except ValueError:
        raise ConfigError(f"--drop-gnss {text!r}: expected START_S:DURATION_S, "
                          f"e.g. 25:10") from None
    if not (start >= 0.0 and duration > 0.0):
        raise ConfigError(f"--drop-gnss {text!r}: start must be >= 0 and duration > 0 s")
    return GnssOutage(start, duration)


def import_log(fmt: str, source: Path, out: Path,
               drop_gnss: GnssOutage | None = None) -> dict[str, Any]:
    """Import ``source`` in format ``fmt`` into the recording ``out``; returns what was written
    (counts by channel, the outage's times, the configuration's overrides)."""
    importer = IMPORTERS.get(fmt)
    if importer is None:
        raise RecordingError(f"unknown log format {fmt!r} (known: {', '.join(sorted(IMPORTERS))})")
    if not source.exists():
        raise RecordingError(f"{source}: no such file or folder")
    imported = importer(source, drop_gnss)
    return write_recording(imported, out)


def write_recording(imported: ImportedLog, out: Path) -> dict[str, Any]:
    """Write an :class:`ImportedLog` as a recording (see the module docstring)."""
    if not imported.readings:
        raise RecordingError(f"{imported.name}: nothing to import")
    config = apply_overrides(AppConfig(), imported.config, f"{imported.name} (importer)")
    t0 = imported.start_s
    window = imported.gnss_outage_s
    metadata = dict(imported.metadata)
    metadata.update({"track": "", "log": imported.name, "config_toml": config_to_toml(config),
                     "start_s": repr(t0)})
    if window is not None:
        metadata["gnss_outage_s"] = f"{window[0]!r}:{window[1]!r}"
    codec = CanCodec(config.sensors.can.dbc or None)
    counts: Counter[str] = Counter()
    if window is not None:
        counts["gnss_dropped"] = imported.gnss_dropped
    with Recorder(out, config.recording, config.car, metadata=metadata, blocking=True) as rec:
        for r in imported.readings:
            t = r.timestamp_s
            if isinstance(r, GpsFix):
                for sentence in fix_sentences(r, imported.gnss_utc_day_s):
                    rec.write_raw(RawBytes(t, "gps", sentence))
                rec.write_gps_fix(r)
                counts["gnss"] += 1
            elif isinstance(r, ImuSample):
                rec.write_raw(RawBytes(t, "imu", encode_imu_packet(r)))
                counts["imu"] += 1
            elif isinstance(r, WheelSpeeds):
                rec.write_raw(codec.encode_wheel_speeds(r))
                counts["wheels"] += 1
            elif isinstance(r, SteeringAngle):
                rec.write_raw(codec.encode_steering(r))
                counts["steering"] += 1
        for gt in imported.truth:
            rec.write(TRUTH_POSE, gt, gt.timestamp_s)
            counts["truth"] += 1
    if rec.errors or rec.dropped:
        raise RecordingError(f"{out}: {rec.errors} message(s) failed, {rec.dropped} dropped "
                             f"(first error: {rec.error})")
    log.info("imported %s into %s: %s", imported.name, out, dict(counts))
    return {"log": imported.name, "recording": str(out), "counts": dict(counts),
            "start_s": t0, "end_s": imported.readings[-1].timestamp_s,
            "gnss_outage_s": list(window) if window is not None else None,
            "config": imported.config}
