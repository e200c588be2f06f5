"""The configuration reference, generated from the configuration dataclasses.

``orchestrator/config.py`` gathers every package's ``config.py`` into ``AppConfig``; this walks
that tree and writes one table per section: each key, its type, its unit (from the name's
suffix: ``_m``, ``_s``, ``_mps`` ...), its default and its meaning (the docstring under the
field). The documentation site builds ``configuration.md`` from it at build time (``hooks:`` in
``mkdocs.yml`` names this file), so the page cannot drift from the code.

    python tools/config_reference.py            # the page as Markdown on stdout
    python tools/config_reference.py --check    # exit 1 if a key has no meaning
"""

from __future__ import annotations

import ast
import dataclasses
import inspect
import math
import re
import sys
import textwrap
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

PAGE = "configuration.md"

#: Unit of a name's last part (``speed_mps`` -> m/s).
UNITS = {
    "m": "m", "mm": "mm", "s": "s", "ms": "ms", "mps": "m/s", "mps2": "m/s²", "rad": "rad",
    "radps": "rad/s", "radps2": "rad/s²", "deg": "deg", "degps": "deg/s", "hz": "Hz", "kg": "kg",
    "kgm2": "kg m²", "px": "px", "fps": "frames/s", "prob": "0-1", "probability": "0-1",
    "fraction": "0-1", "sigma": "σ", "bytes": "bytes",
}
#: A noise density's last part after its unit (``gyro_bias_walk_radps_rths``).
DENSITIES = {"rths": "/√s", "rthz": "/√Hz"}


@dataclasses.dataclass(frozen=True)
class Key:
    """One configuration key as the page lists it."""

    section: str
    name: str
    type: str
    unit: str
    default: str
    meaning: str
    documented: bool


def unit_of(name: str) -> str:
    """The unit a key's name carries in its suffix, or ``""``."""
    parts = name.lower().split("_")
    if len(parts) >= 3 and parts[-1] in DENSITIES and parts[-2] in UNITS:
        return UNITS[parts[-2]] + DENSITIES[parts[-1]]
    if len(parts) >= 2 and parts[-1] in UNITS:
        return UNITS[parts[-1]]
    return ""


def _field_docs(cls: type) -> dict[str, str]:
    """The string literal under each field of a dataclass's body (its meaning)."""
    try:
        source = textwrap.dedent(inspect.getsource(cls))
    except (OSError, TypeError):
        return {}
    body = ast.parse(source).body[0]
    assert isinstance(body, ast.ClassDef)
    docs: dict[str, str] = {}
    for node, after in zip(body.body, [*body.body[1:], None], strict=True):
        if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name)
                and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)
                and isinstance(after.value.value, str)):
            docs[node.target.id] = inspect.cleandoc(after.value.value)
    return docs


def _markdown(text: str) -> str:
    """A docstring as one Markdown table cell: reST roles and literals to code, one line."""
    text = re.sub(r":[a-z]+:`~?([^`]+)`", r"`\1`", text)
    text = text.replace("``", "`")
    text = " ".join(text.split())
    return text.replace("|", "\\|")


def _bare(name: str) -> str:
    """A key with no docstring: its name in words, less its unit, in italics."""
    words = name.split("_")
    if unit_of(name):
        words = words[:-2] if words[-1] in DENSITIES else words[:-1]
    return "*" + " ".join(words) + "*"


def _default(value: Any) -> str:
    if value is None:
        return "not set"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, float):
        return f"`{value!r}`" if math.isfinite(value) else f'`"{value}"`'
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, (list, tuple)):
        return "`[" + ", ".join(_default(v).strip("`") for v in value) + "]`"
    return f"`{value!r}`"


def _type(annotation: Any) -> str:
    text = annotation if isinstance(annotation, str) else getattr(annotation, "__name__",
                                                                  str(annotation))
    literal = re.fullmatch(r"Literal\[(.*)\]", text)
    if literal:
        text = " or ".join(part.strip() for part in literal.group(1).split(","))
    return f"`{text.replace(' | ', ' or ')}`"


def sections(config: Any | None = None) -> Iterator[tuple[str, str, list[Key]]]:
    """Every section of the configuration, depth first: (dotted name, its doc, its keys)."""
    if config is None:
        from orchestrator.config import AppConfig
        config = AppConfig()
    yield from _walk(config, "")


def _walk(obj: Any, prefix: str) -> Iterator[tuple[str, str, list[Key]]]:
    cls = type(obj)
    docs = _field_docs(cls)
    keys: list[Key] = []
    nested: list[tuple[str, Any]] = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            nested.append((f.name, value))
            continue
        meaning = docs.get(f.name)
        keys.append(Key(prefix.rstrip("."), f.name, _type(f.type), unit_of(f.name),
                        _default(value), _markdown(meaning) if meaning else _bare(f.name),
                        meaning is not None))
    if prefix:
        yield prefix.rstrip("."), _markdown(inspect.cleandoc(cls.__doc__ or "")), keys
    for name, value in nested:
        yield from _walk(value, f"{prefix}{name}.")


def render() -> str:
    """The configuration reference page, Markdown."""
    lines = [
        "# Configuration reference",
        "",
        "<!-- Generated by tools/config_reference.py from the configuration dataclasses at "
        "build time; edit the docstrings in each package's config.py, not this page. -->",
        "",
        "Every key of the configuration: its type, its unit (from the suffix of its name), its "
        "default and its meaning (the docstring under the field in the package's `config.py`; "
        "a key with none shows its name in words, in italics). The page is generated from the "
        "code when the site is built, so it lists every key `python main.py config --print` "
        "shows, and those not set by default (`not set`), which `config --print` leaves out.",
        "",
        "Every command takes `--config FILE`, a TOML file of overrides: only the keys to change, "
        "in their sections. Several `[section]` tables can be in one file. A section or key that "
        "does not exist, or a value of the wrong type, stops the program before anything starts, "
        "with one line naming the file, the key and what was expected. `config/sim.toml` (the "
        "default simulation) and `config/car.toml` (the real car) are examples.",
        "",
        "```toml",
        "[mission]",
        "laps = 3",
        "",
        "[planner]",
        "racing_margin_m = 0.3",
        "```",
        "",
        "```bash",
        "python main.py config --print --config my.toml   # the merged configuration",
        "```",
        "",
    ]
    total = undocumented = 0
    for name, doc, keys in sections():
        if not keys:
            continue
        lines += [f"## `[{name}]`", ""]
        if doc:
            lines += [doc, ""]
        lines += ["| key | type | unit | default | meaning |", "| --- | --- | --- | --- | --- |"]
        for key in keys:
            lines.append(f"| `{key.name}` | {key.type} | {key.unit} | {key.default} | "
                         f"{key.meaning} |")
            total += 1
            undocumented += not key.documented
        lines.append("")
    lines += [f"{total} keys, {total - undocumented} with a docstring.", ""]
    return "\n".join(lines)


def on_files(files: Any, config: Any) -> Any:
    """MkDocs hook: add the generated page to the site's files."""
    from mkdocs.structure.files import File

    files.append(File.generated(config, PAGE, content=render()))
    return files


def main(argv: list[str]) -> int:
    if "--check" in argv:
        missing = [f"{k.section}.{k.name}" for _, _, keys in sections() for k in keys
                   if not k.documented]
        for name in missing:
            sys.stdout.write(f"no docstring: {name}\n")
        return 1 if missing else 0
    sys.stdout.write(render())
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
