"""What an importer returns: a foreign log as our readings, its ground truth and its car.

The readings are :mod:`common.messages` types in the vehicle frame (x forward, y left, z up;
SI units), stamped in the log's own time base (s). Whoever writes the recording turns them into
our receivers' wire bytes (NMEA, the IMU's packets, the car's CAN frames), so a replay parses
them as it parses the car's.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from common.messages import GpsFix, GroundTruth, ImuSample, SteeringAngle, WheelSpeeds

ImportedReading = GpsFix | ImuSample | WheelSpeeds | SteeringAngle


@dataclass(frozen=True, slots=True)
class GnssOutage:
    """A window without GNSS: ``start_s`` after the log's first reading, ``duration_s`` long.

    An importer leaves the fixes of the window out of the readings *and* out of any calibration
    it makes from them, so that the outage is one for everything downstream."""

    start_s: float
    duration_s: float

    def window(self, t0_s: float) -> tuple[float, float]:
        """The window [start, end) in the log's time base, for a log starting at ``t0_s``."""
        return t0_s + self.start_s, t0_s + self.start_s + self.duration_s


@dataclass(slots=True)
class ImportedLog:
    """One imported log.

    ``readings``: every reading in time order (s, the log's time base). ``gnss_utc_day_s``: the
    UTC time (s since 1970) of midnight of the first fix's day (``GpsFix.utc_time_s`` is the
    time of day; the NMEA date is made from both). ``truth``: the reference poses in the local
    ENU frame about ``truth_origin`` (lat deg, lon deg, height m): x east, y north, ``yaw_rad``
    the direction of travel (CCW from east), ``vx_mps`` the horizontal speed, at the log's
    reference point. ``gnss_outage_s``, ``gnss_dropped``: the GNSS outage asked for (see
    :class:`GnssOutage`) and how many fixes it removed. ``config``: overrides of the stack's
    configuration for this car (the ``car`` and ``mapper`` sections, as TOML tables).
    ``metadata``: strings written into the recording's ``fsd`` metadata.
    """

    name: str
    readings: list[ImportedReading]
    truth: list[GroundTruth]
    truth_origin: tuple[float, float, float]
    gnss_utc_day_s: float
    config: dict[str, Any] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    gnss_outage_s: tuple[float, float] | None = None
    """The GNSS outage left out, [start, end) in the log's time base (s)."""
    gnss_dropped: int = 0
    """Fixes left out for it."""

    @property
    def start_s(self) -> float:
        """Time of the first reading (s)."""
        return self.readings[0].timestamp_s if self.readings else 0.0
