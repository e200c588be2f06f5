"""The spinning LiDARs a Formula Student car carries: beam elevations, range and rate.

One table, from the manufacturers' manuals, chosen by name with ``lidar.model`` in the config
or ``--lidar MODEL`` on the command line:

| name | sensor | beams | vertical field (deg) | range (m) | rate (Hz) |
| --- | --- | --- | --- | --- | --- |
| ``vlp16`` | Velodyne VLP-16 (Puck) | 16 | -15 .. +15 | 100 | 5-20 |
| ``vlp32c`` | Velodyne VLP-32C (Ultra Puck) | 32 | -25 .. +15 | 200 | 5-20 |
| ``hdl32e`` | Velodyne HDL-32E | 32 | -30.67 .. +10.67 | 100 | 5-20 |
| ``pandar40p`` | Hesai Pandar40P | 40 | -25 .. +15 | 200 | 10, 20 |
| ``os1-64`` | Ouster OS1-64 (gen 1) | 64 | -16.6 .. +16.6 | 120 | 10, 20 |

``beam_elevation_deg`` is given per laser id, in the order the sensor's packets carry the
returns; ``ring_elevation_deg`` sorts it (ring 0 = lowest beam). The Ouster's beam angles differ
a little from unit to unit: its metadata file (``beam_altitude_angles``) overrides the nominal
table when one is given.

A point cloud saved without ring numbers (a KITTI ``.bin``, a ``.npy``) gets its rings back from
each point's elevation: :func:`rings_from_elevation`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray


@dataclass(frozen=True, slots=True)
class LidarModel:
    """A spinning LiDAR's geometry (angles in degrees, ranges in metres, rates in hertz)."""

    name: str
    """The name used in the config and on the command line (``pandar40p``)."""
    title: str
    """The manufacturer's name of the sensor."""
    beam_elevation_deg: tuple[float, ...]
    """Each laser's elevation above the horizontal (deg), by laser id (packet order)."""
    min_range_m: float
    max_range_m: float
    rotation_hz: float
    """Default spin rate (Hz)."""
    azimuth_resolution_deg: float
    """Horizontal angle between two firings of one laser at ``rotation_hz`` (deg)."""
    manual: str
    """Where the figures come from."""

    @property
    def beams(self) -> int:
        return len(self.beam_elevation_deg)

    @property
    def ring_elevation_deg(self) -> NDArray[np.float64]:
        """The beams' elevations sorted upwards (deg), (beams,): ring 0 is the lowest beam."""
        return np.sort(np.asarray(self.beam_elevation_deg, dtype=np.float64))

    @property
    def laser_ring(self) -> NDArray[np.int64]:
        """Ring number (0 = lowest) of each laser id, (beams,)."""
        elevation = np.asarray(self.beam_elevation_deg, dtype=np.float64)
        return np.argsort(np.argsort(elevation, kind="stable"), kind="stable").astype(np.int64)

    def with_elevations(self, beam_elevation_deg: tuple[float, ...]) -> LidarModel:
        """The same sensor with this unit's measured beam elevations (an Ouster's metadata)."""
        return LidarModel(self.name, self.title, tuple(float(e) for e in beam_elevation_deg),
                          self.min_range_m, self.max_range_m, self.rotation_hz,
                          self.azimuth_resolution_deg, self.manual)


_VLP16 = LidarModel(
    "vlp16", "Velodyne VLP-16",
    (-15.0, 1.0, -13.0, 3.0, -11.0, 5.0, -9.0, 7.0, -7.0, 9.0, -5.0, 11.0, -3.0, 13.0, -1.0, 15.0),
    0.5, 100.0, 10.0, 0.2, "VLP-16 user manual 63-9243 rev E, table 9-1")

_VLP32C = LidarModel(
    "vlp32c", "Velodyne VLP-32C",
    (-25.0, -1.0, -1.667, -15.639, -11.31, 0.0, -0.667, -8.843,
     -7.254, 0.333, -0.333, -6.148, -5.333, 1.333, 0.667, -4.0,
     -4.667, 1.667, 1.0, -3.667, -3.333, 3.333, 2.333, -2.667,
     -3.0, 7.0, 4.667, -2.333, -2.0, 15.0, 10.333, -1.333),
    0.5, 200.0, 10.0, 0.2, "VLP-32C user manual 63-9325 rev B, table 9-2")

_HDL32E = LidarModel(
    "hdl32e", "Velodyne HDL-32E",
    (-30.67, -9.33, -29.33, -8.0, -28.0, -6.67, -26.67, -5.33,
     -25.33, -4.0, -24.0, -2.67, -22.67, -1.33, -21.33, 0.0,
     -20.0, 1.33, -18.67, 2.67, -17.33, 4.0, -16.0, 5.33,
     -14.67, 6.67, -13.33, 8.0, -12.0, 9.33, -10.67, 10.67),
    1.0, 100.0, 10.0, 0.16, "HDL-32E user manual 63-9113 rev M, appendix A")

_PANDAR40P = LidarModel(
    "pandar40p", "Hesai Pandar40P",
    (15.0, 11.0, 8.0, 5.0, 3.0, 2.0, 1.67, 1.33, 1.0, 0.67, 0.33, 0.0, -0.33, -0.67, -1.0,
     -1.33, -1.67, -2.0, -2.33, -2.67, -3.0, -3.33, -3.67, -4.0, -4.33, -4.67, -5.0, -5.33,
     -5.67, -6.0, -7.0, -8.0, -9.0, -10.0, -11.0, -12.0, -13.0, -14.0, -19.0, -25.0),
    0.3, 200.0, 10.0, 0.2, "Pandar40P user manual, appendix I (angle correction)")

_OS1_64 = LidarModel(
    "os1-64", "Ouster OS1-64 (gen 1)",
    tuple(float(round(e, 3)) for e in np.linspace(16.611, -16.611, 64)),
    0.8, 120.0, 10.0, 0.35, "OS1 hardware user guide (v1.13), 64 beams over 33.2 deg")

LIDAR_MODELS: dict[str, LidarModel] = {
    m.name: m for m in (_VLP16, _VLP32C, _HDL32E, _PANDAR40P, _OS1_64)
}
"""Every supported sensor by its config name."""


def lidar_model(name: str) -> LidarModel:
    """The sensor called ``name`` (case-insensitive); raises ValueError naming the choices."""
    key = name.strip().lower().replace("_", "-")
    key = {"vlp-16": "vlp16", "vlp-32c": "vlp32c", "hdl-32e": "hdl32e", "pandar-40p": "pandar40p",
           "os1": "os1-64", "os164": "os1-64"}.get(key, key)
    if key not in LIDAR_MODELS:
        raise ValueError(f"unknown LiDAR model {name!r}; choose one of "
                         f"{', '.join(sorted(LIDAR_MODELS))}")
    return LIDAR_MODELS[key]


def rings_from_elevation(xyz: NDArray[np.floating], model: LidarModel) -> NDArray[np.int64]:
    """Each point's ring (0 = lowest beam), from its elevation seen from the sensor, (N,).

    ``xyz`` (N, >=3) in the sensor frame (m). The nearest beam in elevation wins; points
    between two beams (a unit whose angles differ from the nominal table) go to the nearer.
    """
    pts = np.asarray(xyz)
    elevation = np.degrees(np.arctan2(pts[:, 2], np.hypot(pts[:, 0], pts[:, 1])))
    rings = model.ring_elevation_deg
    mid = 0.5 * (rings[1:] + rings[:-1])
    return np.searchsorted(mid, elevation).astype(np.int64)
