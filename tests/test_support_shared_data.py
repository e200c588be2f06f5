"""Missing shared data fails a test in CI and skips it elsewhere."""

from __future__ import annotations

import pytest

from support.shared_data import shared_data


def test_missing_shared_data_fails_in_ci(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="no_such_file.csv"):
        shared_data("tracks", "no_such_file.csv")


@pytest.mark.parametrize("value", ["", "0", "false"])
def test_missing_shared_data_skips_outside_ci(monkeypatch: pytest.MonkeyPatch,
                                              value: str) -> None:
    monkeypatch.setenv("CI", value)
    with pytest.raises(pytest.skip.Exception, match="no_such_file.csv"):
        shared_data("tracks", "no_such_file.csv")
