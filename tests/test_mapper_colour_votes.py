"""A cone's colour from confidence-weighted camera votes."""

from __future__ import annotations

import numpy as np

from common.messages import ConeColour
from mapper.colour_votes import voted_colours

U, B, Y, O, BIG = (int(c) for c in (ConeColour.UNKNOWN, ConeColour.BLUE, ConeColour.YELLOW,
                                    ConeColour.ORANGE, ConeColour.BIG_ORANGE))


def _votes(*rows: dict[int, float]) -> np.ndarray:
    out = np.zeros((len(rows), len(ConeColour)))
    for i, row in enumerate(rows):
        for colour, weight in row.items():
            out[i, colour] = weight
    return out


def test_one_doubtful_vote_leaves_the_colour_unknown() -> None:
    """A cone seen once, its colour swapped by the camera (a yellow cone of Jellybean voted
    blue put the cone on the wrong side and the car found no path): a vote of confidence 0.8
    is no lead of a full vote; two votes are."""
    colours = voted_colours(_votes({B: 0.8}, {B: 0.8, Y: 0.0}, {Y: 0.9, B: 0.1}, {Y: 0.8 + 0.9}))
    assert colours.tolist() == [U, U, U, Y]


def test_the_leading_colour_wins_by_a_full_vote() -> None:
    colours = voted_colours(_votes({Y: 5.0, B: 3.9}, {Y: 5.0, B: 4.2}, {BIG: 3.0}, {O: 1.0},
                                   {U: 9.0, B: 1.5}, {}))
    assert colours.tolist() == [Y, U, BIG, O, B, U]


def test_no_cones_no_colours() -> None:
    assert voted_colours(np.zeros((0, len(ConeColour)))).shape == (0,)
