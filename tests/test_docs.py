"""The documentation (issue 43): the configuration page lists every key, the site builds with
``mkdocs build --strict``, and the README stays short, its links and commands real."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
import tomllib
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _config_reference() -> ModuleType:
    spec = importlib.util.spec_from_file_location("config_reference",
                                                  ROOT / "tools" / "config_reference.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks itself up there
    spec.loader.exec_module(module)
    return module


def _flatten(table: dict[str, Any], prefix: str = "") -> set[str]:
    keys: set[str] = set()
    for key, value in table.items():
        if isinstance(value, dict):
            keys |= _flatten(value, f"{prefix}{key}.")
        else:
            keys.add(f"{prefix}{key}")
    return keys


def _page_keys(page: str) -> dict[str, str]:
    """``section.key`` -> its default cell, from the page's headings and table rows."""
    keys: dict[str, str] = {}
    section = None
    for line in page.splitlines():
        heading = re.match(r"^## `\[([a-z0-9_.]+)\]`$", line)
        if heading:
            section = heading.group(1)
            continue
        row = re.match(r"^\| `([a-z0-9_]+)` \|(.*)$", line)
        if row and section:
            cells = [c.strip() for c in row.group(2).split(" | ")]
            keys[f"{section}.{row.group(1)}"] = cells[2]
    return keys


def test_configuration_page_lists_every_key_config_print_shows() -> None:
    printed = subprocess.run([sys.executable, "main.py", "config", "--print"], cwd=ROOT,
                             capture_output=True, text=True, timeout=60, check=True).stdout
    shown = _flatten(tomllib.loads(printed))
    assert len(shown) > 300
    page = _page_keys(_config_reference().render())
    assert sorted(shown - set(page)) == []
    # and nothing that is not a key: the page's extra keys are those not set by default, which
    # config --print leaves out
    assert {key: default for key, default in page.items()
            if key not in shown and default != "not set"} == {}


def test_configuration_page_gives_type_unit_and_default() -> None:
    reference = _config_reference()
    page = reference.render()
    assert "| `wheelbase_m` | `float` | m | `1.53` |" in page
    assert reference.unit_of("max_brake_decel_mps2") == "m/s²"
    assert reference.unit_of("gyro_bias_walk_radps_rths") == "rad/s/√s"
    assert reference.unit_of("queue_length") == ""


def test_mkdocs_build_strict(tmp_path: Path) -> None:
    pytest.importorskip("mkdocs")
    pytest.importorskip("material")
    pytest.importorskip("mkdocstrings")
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=ROOT, capture_output=True, text=True,
                          timeout=300, check=False, env=_env())
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (tmp_path / "site" / "configuration" / "index.html").exists()


def _env() -> dict[str, str]:
    import os

    return {**os.environ, "NO_MKDOCS_2_WARNING": "1"}


README = (ROOT / "README.md").read_text()


def test_readme_is_short() -> None:
    assert len(README.splitlines()) < 150


def test_readme_links_resolve() -> None:
    links = re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", README)
    local = [link for link in links if "://" not in link]
    assert local, "the README links into the docs"
    assert [link for link in local if not (ROOT / link).exists()] == []
    for image in (link for link in local if link.endswith(".png")):
        assert (ROOT / image).stat().st_size < 200_000, image


def test_readme_install_and_test_commands_are_what_ci_runs() -> None:
    ci = (ROOT / ".ci" / "run").read_text()
    assert 'pip install -e ".[dev]"' in README
    assert '\npip install -e ".[dev]"\n' in ci
    assert "\npytest\n" in README
    assert re.search(r"^pytest \|\|", ci, flags=re.MULTILINE)
    assert "mkdocs build --strict" in ci
