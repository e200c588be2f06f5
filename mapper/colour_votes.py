"""A cone's colour from the camera's votes for it.

Each camera cone votes for the colour of the map cone it falls on, weighted by its confidence
(0..1). The camera swaps blue and yellow now and then (a few per cent of detections), so a map
cone seen once or twice may carry one wrong vote and nothing else; a planner that trusts that
vote puts the cone on the wrong side of the track. A colour is therefore taken only with a lead
of a full vote over the next colour; until then the cone is of unknown colour, which the
planners place by where it lies.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from common.messages import ConeColour, ConeMap

MIN_COLOUR_LEAD = 1.0
"""Confidence-weighted votes the leading colour needs over the next one."""


def voted_colours(votes: NDArray[np.float64], min_lead: float = MIN_COLOUR_LEAD
                  ) -> NDArray[np.int64]:
    """Each cone's colour (n,) from its votes (n, len(ConeColour)), indexed by
    :class:`ConeColour` (votes for UNKNOWN are ignored): the colour with the most, when it
    leads the next by ``min_lead``; UNKNOWN otherwise."""
    v = np.asarray(votes, np.float64)[:, 1:]
    if len(v) == 0:
        return np.zeros(0, np.int64)
    order = np.sort(v, axis=1)
    top, runner_up = order[:, -1], order[:, -2]
    out = np.argmax(v, axis=1) + 1
    out[(top <= 0.0) | (top - runner_up < min_lead)] = int(ConeColour.UNKNOWN)
    return out.astype(np.int64)


def without_colours(cones: ConeMap) -> ConeMap:
    """``cones`` with every colour unknown (the camera that voted them has died: what it saw
    before no longer tells the cones ahead apart)."""
    if not np.any(cones.colour != int(ConeColour.UNKNOWN)):
        return cones
    return replace(cones, colour=np.full(len(cones), int(ConeColour.UNKNOWN), np.int64))
