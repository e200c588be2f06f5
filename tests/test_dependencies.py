"""Every package the code imports directly is declared in pyproject.toml (a package that only
arrives as another one's dependency can disappear with that one's next release)."""

from __future__ import annotations

import ast
import importlib.metadata
import re
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OURS = {"common", "orchestrator", "sensors", "mapper", "planner", "controller", "visualiser",
        "recordings", "simulator", "bench", "scale", "main", "support",
        "planner_closed_loop_helpers", "safety_helpers"}


def _normalise(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _declared(extra: str | None = None) -> set[str]:
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    requirements = (project["dependencies"] if extra is None
                    else project["optional-dependencies"][extra])
    return {_normalise(re.match(r"[A-Za-z0-9_.-]+", r).group(0))  # type: ignore[union-attr]
            for r in requirements}


def _imported(paths: list[Path]) -> dict[str, set[str]]:
    """Top-level names of third-party modules imported (or ``importorskip``-ed) -> files."""
    found: dict[str, set[str]] = {}
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names: list[str] = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
                names = [node.module]
            elif (isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "importorskip"
                  and node.args and isinstance(node.args[0], ast.Constant)):
                names = [str(node.args[0].value)]
            for name in names:
                top = name.split(".")[0]
                if top not in OURS and top not in sys.stdlib_module_names and top != "__future__":
                    found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def _undeclared(imported: dict[str, set[str]], declared: set[str]) -> dict[str, set[str]]:
    distributions = importlib.metadata.packages_distributions()
    missing = {}
    for top, files in imported.items():
        names = {_normalise(d) for d in distributions.get(top, [])}
        if not names & declared:
            source = ", ".join(sorted(names)) or "no installed distribution"
            missing[f"{top} (from {source})"] = files
    return missing


def _product_files() -> list[Path]:
    files = [ROOT / "main.py"]
    for package in sorted(OURS - {"main", "support", "planner_closed_loop_helpers",
                                  "safety_helpers"}):
        files += [p for p in (ROOT / package).rglob("*.py") if not p.name.endswith("_pb2.py")]
    return files


def test_product_imports_are_declared_dependencies() -> None:
    files = _product_files()
    core = [p for p in files if not p.is_relative_to(ROOT / "scale")]
    imported = _imported(core)
    assert {"numpy", "scipy", "lz4"} <= set(imported)
    assert _undeclared(imported, _declared()) == {}
    # campaigns and tuning (scale/) may also use the optional extra 'scale'
    scale = _imported([p for p in files if p.is_relative_to(ROOT / "scale")])
    assert {"ray", "optuna"} <= set(scale)
    assert _undeclared(scale, _declared() | _declared("scale")) == {}


def test_scale_extra_is_in_dev() -> None:
    """CI installs the dev extra: it must bring what the scale tests need."""
    assert _declared("scale") <= _declared("dev")


def test_test_imports_are_declared_dependencies_or_dev_extras() -> None:
    imported = _imported(sorted((ROOT / "tests").rglob("*.py")))
    assert "pytest" in imported
    assert _undeclared(imported, _declared() | _declared("dev")) == {}
