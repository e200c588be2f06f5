"""The track list of ``bench trackdrive``: counts, ranges, files and folders; its table rows."""

from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from bench.bench_trackdrive import track_list


def test_a_count_is_the_first_generated_tracks() -> None:
    assert track_list("3") == ["gen:1", "gen:2", "gen:3"]


def test_ranges_mix_with_names_and_files(tmp_path: Path) -> None:
    (tmp_path / "b.csv").write_text("tag,x,y\n")
    (tmp_path / "a.yaml").write_text("cones_left: []\n")
    (tmp_path / "notes.txt").write_text("not a track\n")
    got = track_list(f"FSG.yaml,gen:4..6,{tmp_path},hard:hairpins")
    assert got == ["FSG.yaml", "gen:4", "gen:5", "gen:6", str(tmp_path / "a.yaml"),
                   str(tmp_path / "b.csv"), "hard:hairpins"]


@pytest.mark.parametrize("text", ["gen:5..2", "gen:0..3", "0", " , "])
def test_an_empty_or_backward_list_is_refused(text: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError):
        track_list(text)


def _summary(landmarks: int, true_cones: int) -> dict[str, object]:
    return {"track": "gen:1", "seed": 2, "laps_completed": 1, "cones_hit": 0, "off_track": 0,
            "pose_rmse_m": 0.03, "best_lap_time_s": 20.0, "min_lap_time_s": 15.0,
            "lap_ratio": 1.333, "explored_ratio": 1.333, "wall_s": 5.0,
            "stop_reason": "finished: 1 laps", "mission_result": {},
            "map": {"landmarks": landmarks, "true_cones": true_cones}}


def test_a_row_shows_the_map_size_over_the_cones_on_the_track() -> None:
    from bench.bench_trackdrive import _row

    line, clean = _row(_summary(199, 57), laps=1)
    assert clean and " 3.49 " in line
    assert " 1.00 " in _row(_summary(57, 57), laps=1)[0]
    no_map = _summary(0, 0)
    no_map.pop("map")
    assert " nan " in _row(no_map, laps=1)[0]
