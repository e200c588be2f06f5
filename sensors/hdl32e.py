"""The Velodyne HDL-32E: its data packets' layout for :mod:`sensors.velodyne`.

The HDL-32E sends the same 1206-byte data packets as the VLP-16 (12 blocks of 100 bytes,
timestamp, factory bytes ``0x37``/``0x38``/``0x39`` and product id ``0x21``), but each block
holds ONE firing sequence of its 32 lasers (returns 0..31 are lasers 0..31):

- lasers fire 1.152 us apart; a sequence of 32 firings and the recharge takes 46.08 us, so a
  packet spans 12 x 46.08 = 552.96 us (HDL-32E user manual 63-9113 rev M, appendix A; packet
  structure application note 63-9277 rev D);
- elevations by laser id interleave low and high beams, -30.67 .. +10.67 deg in steps of
  4/3 deg (:data:`sensors.lidar_models.LIDAR_MODELS` ``["hdl32e"]``);
- each laser's origin sits above or below the optical centre by :data:`VERTICAL_OFFSET_M`
  (envelope drawing 86-0106 rev B, as velodyne-decoder's calibration has it), added to z;
- distances in 2 mm units.

Decoded points are in the sensor frame of velodyne-decoder (x forward = azimuth 0, y left,
z up); rings number the lasers by elevation, 0 = lowest (-30.67 deg) to 31 (+10.67 deg).
"""

from __future__ import annotations

from sensors.lidar_models import LIDAR_MODELS
from sensors.velodyne import VelodyneLayout

FIRING_CYCLE_S = 46.08e-6
"""One firing sequence of all 32 lasers, recharge included (s)."""
LASER_TIME_S = 1.152e-6
"""Time between two successive lasers' firings in a sequence (s)."""
PACKET_DURATION_S = 12 * FIRING_CYCLE_S
"""Time spanned by one single-return packet: 552.96 us (s)."""
VERTICAL_OFFSET_M = tuple(1e-3 * v for v in (
    17.17, 4.76, 16.27, 4.07, 15.4, 3.38, 14.54, 2.7,
    13.71, 2.02, 12.89, 1.35, 12.09, 0.67, 11.31, 0.0,
    10.54, -0.67, 9.78, -1.35, 9.04, -2.02, 8.3, -2.7,
    7.58, -3.38, 6.86, -4.07, 6.15, -4.76, 5.45, -5.45))
"""Vertical offset of each laser id's origin from the optical centre (m)."""

HDL32E_LAYOUT = VelodyneLayout("HDL-32E", LIDAR_MODELS["hdl32e"].beam_elevation_deg,
                               VERTICAL_OFFSET_M, FIRING_CYCLE_S, LASER_TIME_S)
"""The HDL-32E's packets for :func:`sensors.velodyne.decode_packets` and the sweep assembler."""
