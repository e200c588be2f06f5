"""bench load --keep refuses a folder that already holds a run's, in one line, before any run."""

from __future__ import annotations

from pathlib import Path

import pytest

import main
from bench import bench_load


def test_a_kept_run_folder_is_never_overwritten(tmp_path: Path) -> None:
    (tmp_path / "run_2").mkdir()
    args = main.build_parser().parse_args(["bench", "load", "--runs", "3", "--keep",
                                           str(tmp_path)])
    with pytest.raises(SystemExit) as exit_info:
        bench_load.run(args, None)  # type: ignore[arg-type]
    assert str(exit_info.value) == (f"bench load: --keep {tmp_path} already holds run_2: "
                                    f"give a new folder")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run_2"]  # nothing was started
