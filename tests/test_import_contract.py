"""The import contract (ARCHITECTURE.md, "Tiers"), checked on the source by walking its imports.

- ``common`` is the ground floor: it imports no package of ours.
- A Tier 2 package (a manager and its workers) imports only ``common`` and itself: never another
  Tier 2 package, never Tier 1. Main moves all data between them.
- The simulator is the world outside the car: it speaks the sensors' wire formats (``sensors``)
  and nothing else of the stack; no package of the stack imports it.
- Tier 1 (``main.py``, ``orchestrator``) assembles everything; the benchmarks sit on top of it.
  Nothing below imports them.
- No import circles between modules.

Every import counts, also those inside functions; imports under ``if TYPE_CHECKING:`` count for
the tiers (a type is a dependency too) but not for circles (they never run).
"""

from __future__ import annotations

import ast
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

COMMON = {"common"}
TIER2 = {"sensors", "mapper", "planner", "controller", "visualiser", "recordings"}
WORLD = {"simulator"}
TIER1 = {"main", "orchestrator"}
TOOLS = {"bench", "scale"}
OURS = COMMON | TIER2 | WORLD | TIER1 | TOOLS

ALLOWED: dict[str, set[str]] = {
    "common": set(),
    **{package: {"common"} for package in TIER2},
    "simulator": {"common", "sensors"},
    "orchestrator": COMMON | TIER2 | WORLD,
    "main": COMMON | TIER2 | WORLD | {"orchestrator"},
    "bench": COMMON | TIER2 | WORLD | TIER1 | {"scale"},
    "scale": COMMON | TIER2 | WORLD | TIER1 | {"bench"},
}
"""The packages each package may import besides itself."""


@dataclass
class Module:
    name: str
    path: Path
    imports: set[str] = field(default_factory=set)
    """Modules of ours it imports anywhere."""
    runtime_imports: set[str] = field(default_factory=set)
    """The same less those under ``if TYPE_CHECKING:``."""


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(inner) for inner in ast.walk(node))
    return skip


def find_modules(root: Path, packages: set[str]) -> dict[str, Module]:
    """Every module of ``packages`` (folders, or ``name.py`` files) under ``root``."""
    modules: dict[str, Module] = {}
    for package in sorted(packages):
        single = root / f"{package}.py"
        paths = [single] if single.is_file() else sorted((root / package).rglob("*.py"))
        for path in paths:
            parts = path.relative_to(root).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            modules[name] = Module(name, path)
    for module in modules.values():
        tree = ast.parse(module.path.read_text(), str(module.path))
        skip = _type_checking_nodes(tree)
        package_parts = module.name.split(".")
        if module.path.name != "__init__.py":
            package_parts = package_parts[:-1]
        for node in ast.walk(tree):
            targets: list[str] = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package_parts[:len(package_parts) - node.level + 1]
                    base = ".".join([*up, base] if base else up)
                for alias in node.names:
                    full = f"{base}.{alias.name}"
                    targets.append(full if full in modules else base)
            for target in targets:
                if target.split(".")[0] not in packages:
                    continue
                # ``import a.b.c`` names a.b.c; a name of a module that is not ours (an
                # attribute) counts as its package
                while target not in modules and "." in target:
                    target = target.rsplit(".", 1)[0]
                if target == module.name:
                    continue
                module.imports.add(target)
                if id(node) not in skip:
                    module.runtime_imports.add(target)
    return modules


def tier_violations(modules: dict[str, Module], allowed: dict[str, set[str]]) -> list[str]:
    """``"a.b imports c.d"`` for each import the contract forbids."""
    found = []
    for module in modules.values():
        own = module.name.split(".")[0]
        for target in sorted(module.imports):
            other = target.split(".")[0]
            if other != own and other not in allowed[own]:
                found.append(f"{module.name} imports {target}")
    return found


def import_circles(modules: dict[str, Module]) -> list[list[str]]:
    """The strongly connected groups (more than one module) of the runtime import graph."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    counter = 0

    def visit(v: str) -> None:
        nonlocal counter
        index[v] = low[v] = counter
        counter += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(modules[v].runtime_imports):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                circles.append(sorted(group))

    for v in sorted(modules):
        if v not in index:
            visit(v)
    return circles


@pytest.fixture(scope="module")
def modules() -> dict[str, Module]:
    return find_modules(ROOT, OURS)


def test_every_package_has_a_place_in_the_contract() -> None:
    packages = {p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file()}
    packages.discard("build")
    assert packages | {"main"} == OURS, "a new package needs its row in ALLOWED"


def test_no_package_imports_upward_or_sideways(modules: dict[str, Module]) -> None:
    assert len(modules) > 100
    assert tier_violations(modules, ALLOWED) == []


def test_no_import_circles(modules: dict[str, Module]) -> None:
    assert import_circles(modules) == []


def test_the_checks_catch_what_they_are_for(tmp_path: Path) -> None:
    """A made-up tree with one of each offence: every one is reported."""
    files = {
        "common/__init__.py": "",
        "common/clock.py": "from mapper import filter\n",                       # upward
        "mapper/__init__.py": "",
        "mapper/filter.py": "def f():\n    from planner.plan import p\n",      # sideways
        "mapper/a.py": "from mapper import b\n",
        "mapper/b.py": "from . import a\n",                                      # a circle
        "planner/__init__.py": "",
        "planner/plan.py": "from typing import TYPE_CHECKING\n"
                           "if TYPE_CHECKING:\n    from orchestrator.x import X\n",  # to Tier 1
        "orchestrator/__init__.py": "",
        "orchestrator/x.py": "import mapper.filter\nimport planner.plan\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    found = find_modules(tmp_path, {"common", "mapper", "planner", "orchestrator"})
    allowed = {"common": set(), "mapper": {"common"}, "planner": {"common"},
               "orchestrator": {"common", "mapper", "planner"}}
    assert tier_violations(found, allowed) == [
        "common.clock imports mapper.filter",
        "mapper.filter imports planner.plan",
        "planner.plan imports orchestrator.x",
    ]
    assert import_circles(found) == [["mapper.a", "mapper.b"]]
