"""velodyne-decoder's decoding of Velodyne data packets: the answer key of the LiDAR tests."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np


def velodyne_decoder_points(packets: Iterable[tuple[float, bytes]], model: str,
                            product_id: int | None = None) -> np.ndarray:
    """Every return of ``packets`` (capture time, payload) as velodyne-decoder decodes them with
    its ``model`` (``"VLP16"``, ``"HDL32E"``) and that model's calibration, (N, 8) float64:
    x, y, z (m), intensity, time, column, ring, return type. ``product_id`` rewrites each
    packet's product id byte first (velodyne-decoder refuses a model another id names)."""
    import velodyne_decoder as vd
    decoder = vd.StreamDecoder(vd.Config(model=getattr(vd.Model, model), min_range=0.0,
                                         max_range=1000.0))
    clouds = []
    for stamp, payload in packets:
        if product_id is not None:
            patched = bytearray(payload)
            patched[1205] = product_id
            payload = bytes(patched)
        result = decoder.decode(stamp, payload)
        if result is not None:
            clouds.append(result[1])
    result = decoder.finish()
    if result is not None:
        clouds.append(result[1])
    return np.concatenate(clouds).astype(np.float64)
