"""Scoring detected cones against labelled ones, frame by frame.

Cones are scored inside a window (ahead of the car's own body, ``x > min_x_m``, and within
``max_range_m`` horizontally). Labels and detections are matched one to one within ``match_m``
by the assignment that minimises the summed distance
(:func:`scipy.optimize.linear_sum_assignment`). A matched label in the window is a true
positive, an unmatched label in the window a miss, an unmatched detection in the window a false
positive. :func:`score_frame` says how pairs on the window's edge are counted. Counts are summed
over frames; the position errors of the true positives are pooled.

Labels made from a map of the cones and the car's odometry carry the odometry's error at the
frame's time: every label of a frame is off by about the same vector, while the car drives
(0.05-0.2 m on the shared fskitti Estoril run, about 0.01 m where the car stands).
:class:`ScoreTotals` therefore also reports each frame's common offset and the error left when
it is taken out (leave-one-out: a hit's own error never enters the offset it is corrected by),
which tells the detector's error from the labels'. The headline figures stay the plain ones.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True, slots=True)
class ScoringWindow:
    """Where cones are scored (m, LiDAR frame)."""

    min_x_m: float = 2.5
    """Only cones ahead of this (m): nearer is the car's own body."""
    max_range_m: float = 12.0
    """Only cones nearer than this horizontally (m)."""
    match_m: float = 0.5
    """A detection farther than this from every label matches none (m)."""

    def inside(self, xy: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Which rows of ``xy`` (N, 2) lie in the window, (N,)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return (xy[:, 0] > self.min_x_m) & (np.hypot(xy[:, 0], xy[:, 1]) < self.max_range_m)


@dataclass(slots=True)
class FrameScore:
    """One frame's matching: counts and the matched pairs' horizontal errors (m)."""

    true_positives: int
    false_positives: int
    misses: int
    errors_m: NDArray[np.float64]
    offsets_m: NDArray[np.float64]
    """Each hit's detection minus its label, (true_positives, 2) (m)."""
    matched_labels: NDArray[np.int64]
    """Index (into the frame's labels inside the window) of each hit's label."""
    matched_detections: NDArray[np.int64]
    """Index (into the frame's detections inside the window) of each hit's detection; -1 for
    a detection just outside the window."""


def score_frame(labels_xy: NDArray[np.float64], detections_xy: NDArray[np.float64],
                window: ScoringWindow = ScoringWindow(), strict: bool = False) -> FrameScore:
    """Match one frame's detections (K, 2) to its labels (M, 2), both in metres.

    ``strict``: both are cut to ``window`` first, then matched, as the window's plain
    definition reads; a cone on the window's edge then counts as a miss when its detection
    falls just outside and as a false positive when its label does. Otherwise (the default)
    both are matched within the window grown by ``match_m``, and each side is counted where
    it lies: a label inside the window is a hit or a miss, a detection inside it is a hit or
    a false positive, so a pair straddling the edge counts against neither. Indices in the
    result refer to the labels and detections inside the window.
    """
    labels = np.asarray(labels_xy, dtype=np.float64).reshape(-1, 2)
    dets = np.asarray(detections_xy, dtype=np.float64).reshape(-1, 2)
    if strict:
        labels, dets = labels[window.inside(labels)], dets[window.inside(dets)]
    else:
        grown = ScoringWindow(window.min_x_m - window.match_m,
                              window.max_range_m + window.match_m, window.match_m)
        labels, dets = labels[grown.inside(labels)], dets[grown.inside(dets)]
    label_in, det_in = window.inside(labels), window.inside(dets)
    rows = cols = np.zeros(0, dtype=np.int64)
    dist = np.zeros((labels.shape[0], dets.shape[0]))
    if labels.shape[0] and dets.shape[0]:
        dist = np.hypot(labels[:, None, 0] - dets[None, :, 0],
                        labels[:, None, 1] - dets[None, :, 1])
        # pairs beyond the gate cost more than any admissible set of pairs, so they are never
        # preferred to leaving both unmatched; they are dropped after the assignment
        big = window.match_m * (labels.shape[0] + dets.shape[0] + 1)
        rows, cols = linear_sum_assignment(np.where(dist <= window.match_m, dist, big))
        ok = dist[rows, cols] <= window.match_m
        rows, cols = rows[ok], cols[ok]
    matched_label = np.zeros(labels.shape[0], dtype=bool)
    matched_label[rows] = True
    matched_det = np.zeros(dets.shape[0], dtype=bool)
    matched_det[cols] = True
    # a pair is a hit when its label is in the window; its detection then is not a false
    # positive wherever it lies, and a detection in the window matched to a label outside it
    # is neither
    hit = label_in[rows]
    label_index = np.cumsum(label_in) - 1
    det_index = np.cumsum(det_in) - 1
    keep_det = det_in[cols[hit]]
    return FrameScore(
        true_positives=int(hit.sum()),
        false_positives=int((det_in & ~matched_det).sum()),
        misses=int((label_in & ~matched_label).sum()),
        errors_m=dist[rows[hit], cols[hit]],
        offsets_m=(dets[cols[hit]] - labels[rows[hit]]).reshape(-1, 2),
        matched_labels=label_index[rows[hit]].astype(np.int64),
        matched_detections=np.where(keep_det, det_index[cols[hit]], -1).astype(np.int64),
    )


@dataclass(slots=True)
class ScoreTotals:
    """Counts and errors pooled over frames."""

    true_positives: int = 0
    false_positives: int = 0
    misses: int = 0
    errors_m: list[float] = field(default_factory=list)
    frame_offsets_m: list[float] = field(default_factory=list)
    """The length of each frame's mean offset (detections minus labels), frames with at least
    ``MIN_OFFSET_HITS`` hits (m)."""
    errors_without_offset_m: list[float] = field(default_factory=list)
    """Each hit's error after its frame's mean offset over the other hits is taken out (m)."""

    MIN_OFFSET_HITS = 3
    """Fewer hits in a frame tell too little of its common offset."""

    def add(self, frame: FrameScore) -> None:
        self.true_positives += frame.true_positives
        self.false_positives += frame.false_positives
        self.misses += frame.misses
        self.errors_m.extend(float(e) for e in frame.errors_m)
        offsets = frame.offsets_m
        n = offsets.shape[0]
        if n >= self.MIN_OFFSET_HITS:
            self.frame_offsets_m.append(float(np.hypot(*offsets.mean(axis=0))))
            others_mean = (offsets.sum(axis=0) - offsets) / (n - 1)
            self.errors_without_offset_m.extend(
                float(e) for e in np.hypot(*(offsets - others_mean).T))

    @property
    def recall(self) -> float:
        labels = self.true_positives + self.misses
        return self.true_positives / labels if labels else float("nan")

    @property
    def precision(self) -> float:
        dets = self.true_positives + self.false_positives
        return self.true_positives / dets if dets else float("nan")

    @property
    def median_error_m(self) -> float:
        return float(np.median(self.errors_m)) if self.errors_m else float("nan")

    def as_dict(self) -> dict[str, float | int]:
        """The summary's fields: recall, precision, median position error and the counts."""
        return {
            "recall": round(self.recall, 4),
            "precision": round(self.precision, 4),
            "median_position_error_m": round(self.median_error_m, 4),
            "true_positives": self.true_positives,
            "false_positives": self.false_positives,
            "misses": self.misses,
        }

    def frame_offset_dict(self) -> dict[str, float | int]:
        """The labels' per-frame common offset: its median length over frames, and the median
        position error once it is taken out (leave-one-out), both in metres."""
        def median(values: list[float]) -> float:
            return round(float(np.median(values)), 4) if values else float("nan")
        return {
            "frames": len(self.frame_offsets_m),
            "median_frame_offset_m": median(self.frame_offsets_m),
            "median_position_error_without_frame_offset_m": median(
                self.errors_without_offset_m),
        }
