# SPDX-License-Identifier: MIT
"""The package's imports keep the layer order of docs/architecture.md.

The layer picture of the package ("The Python package" in
docs/architecture.md) is read from the document itself, so the picture and
this test cannot disagree: one line per layer, top to bottom, each naming the
top-level modules and folders of ``mstc`` on it (``mstc.plant · mstc.firmware``:
two on one layer). Every import of every module of sim/mstc is read with
:mod:`ast`, wherever it stands (module level, inside a function, under
``if TYPE_CHECKING``), and the test fails on:

- an import from a lower layer up to a higher one;
- an import between two different folders of the same layer (siblings do not
  know each other);
- a cycle of imports between modules, whatever their layers;
- a top-level module or folder the picture does not place;
- the ground floor importing anything of the package, or ``mstc.errors``
  anything but the standard library.

Imports inside one folder go any way but round (the cycle check). The
package's ``__init__`` holds the version and imports nothing; ``__main__`` is
the command and may import anything.

The checker itself is shown to fail on a copy of the package with a planted
upward import, a sibling import and a cycle.
"""

from __future__ import annotations

import ast
import re
import shutil
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

from conftest import ROOT

PACKAGE = ROOT / "sim" / "mstc"
ARCHITECTURE = ROOT / "docs" / "architecture.md"
PICTURE_MARK = "<!-- the layers of mstc: tests/python/test_layers.py reads this picture -->"
GROUND = ("mstc.model", "mstc.errors")
"""The ground floor: importing nothing else of the package."""


def layers(doc: Path = ARCHITECTURE) -> dict[str, int]:
    """The layer of each top-level unit (``mstc.plant``), 0 at the bottom,
    from the picture that follows :data:`PICTURE_MARK` in @p doc."""
    text = doc.read_text(encoding="utf-8")
    at = text.find(PICTURE_MARK)
    assert at >= 0, f"{doc}: no layer picture (the line {PICTURE_MARK!r} and a ``` block after it)"
    block = re.search(r"```\n(.*?)```", text[at:], re.S)
    assert block is not None, f"{doc}: no ``` block after {PICTURE_MARK!r}"
    rows = []
    for line in block[1].splitlines():
        names = re.match(r"\s*(mstc[\w.]*(?:\s*·\s*mstc[\w.]*)*)", line)
        if names:
            rows.append([n.strip() for n in names[1].split("·")])
    assert rows, f"{doc}: the layer picture names no module"
    order = {}
    for level, row in enumerate(reversed(rows)):
        for name in row:
            assert name not in order, f"{doc}: {name} is on two layers"
            order[name] = level
    return order


def module_name(path: Path, root: Path) -> str:
    """``mstc.plant.scenario`` of ``<root>/plant/scenario.py`` (root: the package)."""
    parts = [root.name, *path.relative_to(root).with_suffix("").parts]
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def modules(root: Path) -> dict[str, Path]:
    """Every module of the package at @p root, by name."""
    return {module_name(p, root): p for p in sorted(root.rglob("*.py"))}


@dataclass(frozen=True)
class Import:
    """One import of a module of the package by another."""

    source: str
    target: str
    line: int

    def __str__(self) -> str:
        return f"{self.source}:{self.line} imports {self.target}"


def imports(name: str, path: Path, known: Mapping[str, Path]) -> Iterator[Import | str]:
    """The imports of module @p name (file @p path) of the package's modules
    (@p known) and, as plain names, every other module it imports."""
    tree = ast.parse(path.read_text(encoding="utf-8"), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield _target(name, alias.name, node.lineno, known)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package up
                up = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*up, base] if base else up)
            for alias in node.names:
                full = f"{base}.{alias.name}"
                yield _target(name, full if full in known else base, node.lineno, known)


def _target(source: str, target: str, line: int, known: Mapping[str, Path]) -> Import | str:
    if target.split(".")[0] != "mstc":
        return target
    while target not in known and "." in target:  # `import mstc.can.dbc.x`: its module
        target = target.rpartition(".")[0]
    return Import(source, target, line)


def unit(module: str) -> str:
    """The top-level unit a module belongs to: ``mstc.plant`` of ``mstc.plant.scenario``."""
    return ".".join(module.split(".")[:2])


def problems(root: Path, order: Mapping[str, int]) -> list[str]:
    """Every import of the package at @p root that breaks the rules of the
    module's description, against the layers @p order."""
    known = modules(root)
    found: list[str] = []
    edges: dict[str, set[str]] = {name: set() for name in known}
    top = max(order.values(), default=0) + 1
    rank = {"mstc": -1, "mstc.__main__": top}  # __init__: the version; __main__: the command
    for u in sorted({unit(m) for m in known} - set(rank)):
        if u not in order:
            found.append(f"{u} is not in the layer picture of docs/architecture.md: place it")
    rank.update(order)
    stdlib = sys.stdlib_module_names
    for name, path in known.items():
        for imp in imports(name, path, known):
            if isinstance(imp, str):
                if name == "mstc.errors" and imp.split(".")[0] not in stdlib:
                    found.append(f"mstc.errors imports {imp}: the standard library only")
                continue
            edges[name].add(imp.target)
            a, b = unit(imp.source), unit(imp.target)
            if a == b or a not in rank or b not in rank:
                continue
            if a in GROUND or a == "mstc":
                found.append(f"{imp}: the ground floor imports nothing else of the package")
            elif rank[b] > rank[a]:
                found.append(f"{imp}: upward, from {a} (layer {rank[a]}) to {b} (layer {rank[b]})")
            elif rank[b] == rank[a]:
                found.append(
                    f"{imp}: sideways, {a} and {b} share a layer: they do not know each other"
                )
    found += [f"import cycle: {' -> '.join([*c, c[0]])}" for c in cycles(edges)]
    return found


def cycles(edges: Mapping[str, set[str]]) -> list[list[str]]:
    """The import cycles of @p edges: each strongly connected set of modules
    of more than one (or importing itself), in a readable order (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
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
            if len(group) > 1 or v in edges.get(v, ()):
                found.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


# ------------------------------------------------------------------ the tests


def test_the_package_keeps_the_layer_order_of_the_architecture() -> None:
    order = layers()
    assert problems(PACKAGE, order) == []


def test_the_picture_places_the_ground_floor_at_the_bottom_and_the_command_on_top() -> None:
    order = layers()
    assert {order[name] for name in GROUND} == {0}
    assert order["mstc.cli"] == max(order.values())
    # The plant does not know the wire, the loops do not know the firmware.
    assert order["mstc.plant"] == order["mstc.can"] > order["mstc.limits"]
    assert order["mstc.loop"] == order["mstc.firmware"] < order["mstc.logs"]
    # ROS 2 at the edge: right under the command, so nothing but the command imports it.
    assert order["mstc.ros"] == order["mstc.cli"] - 1


@pytest.fixture
def copy(tmp_path: Path) -> Path:
    """A copy of the package to plant bad imports in."""
    target = tmp_path / "mstc"
    # Without the links to the DBC and the limits table: the check reads Python only.
    skip = shutil.ignore_patterns("__pycache__", "*.dbc", "*.toml")
    shutil.copytree(PACKAGE, target, ignore=skip)
    return target


def _plant(path: Path, line: str) -> None:
    path.write_text(path.read_text(encoding="utf-8") + f"\n{line}\n", encoding="utf-8")


def test_the_check_fails_on_a_planted_upward_import(copy: Path) -> None:
    assert problems(copy, layers()) == []
    _plant(copy / "plant" / "sensor.py", "from mstc.loop.result import RunResult")
    _plant(copy / "can" / "dbc.py", "    from mstc.loop import timing  # inside a function")
    found = problems(copy, layers())
    assert any(
        p.startswith("mstc.plant.sensor:") and "imports mstc.loop.result: upward" in p
        for p in found
    ), found
    assert any("mstc.can.dbc:" in p and "imports mstc.loop.timing: upward" in p for p in found)


def test_the_check_fails_on_siblings_the_ground_floor_and_a_cycle(copy: Path) -> None:
    _plant(copy / "plant" / "scenario.py", "from mstc.can.protocol import wire_limits")
    _plant(copy / "model.py", "from mstc.errors import MstcError")
    _plant(copy / "errors.py", "import numpy")
    _plant(copy / "loop" / "timing.py", "from mstc.loop.realtime import RealtimeLink")
    found = problems(copy, layers())
    assert any("mstc.plant.scenario:" in p and "sideways" in p for p in found), found
    assert any("mstc.model:" in p and "ground floor" in p for p in found), found
    assert "mstc.errors imports numpy: the standard library only" in found
    assert any(p.startswith("import cycle:") and "mstc.loop.timing" in p for p in found), found


def test_the_check_fails_on_a_folder_the_picture_does_not_place(copy: Path) -> None:
    (copy / "web").mkdir()
    (copy / "web" / "__init__.py").write_text('"""A web front end."""\n')
    found = problems(copy, layers())
    assert found == ["mstc.web is not in the layer picture of docs/architecture.md: place it"]
