"""The track list of ``bench trackdrive``: counts, ranges, files and folders."""

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
