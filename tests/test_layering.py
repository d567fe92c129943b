"""The rooms of src/truthbench import only downwards: no cycle, no upward import.

Every import is read from the source's syntax tree, function-level imports included, and
resolved to its room (the first package under ``truthbench``, or a top-level module). A
room may import a room of a strictly lower layer only. The layers are the architecture's
picture (README, "How it works"): change them there and here together.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "truthbench"

LAYERS = (
    ("_version", "errors", "_validation", "quantities"),
    ("settings", "presentation"),
    ("fe", "model", "measure", "simulate"),
    ("plants", "io"),
    ("identify", "effects"),
    ("update", "uncertainty", "placement"),
    ("diagnose", "studies"),
    ("campaign",),
    ("report",),
    ("__init__",),
    ("cli",),
    ("__main__",),
)
RANK = {room: k for k, rooms in enumerate(LAYERS) for room in rooms}


def _room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def imports(root: Path = SRC) -> list[tuple[str, str, str, int]]:
    """(importing room, imported room, file, line) of every cross-room import."""
    out = []
    for f in sorted(root.rglob("*.py")):
        rel = f.relative_to(root.parent).with_suffix("")
        mod = ".".join(rel.parts)
        if mod.endswith(".__init__"):
            mod = mod[: -len(".__init__")]
        pkg = mod if f.name == "__init__.py" else mod.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg.split(".")[: len(pkg.split(".")) - node.level + 1]
                    targets = [".".join(base + ([node.module] if node.module else []))]
                else:
                    targets = [node.module or ""]
            else:
                continue
            for target in targets:
                if target == "truthbench" or target.startswith("truthbench."):
                    a, b = _room(mod), _room(target)
                    if a != b:
                        out.append((a, b, str(f.relative_to(root)), node.lineno))
    return out


def test_every_room_has_a_layer():
    rooms = {p.stem if p.is_file() else p.name for p in SRC.iterdir()
             if (p.suffix == ".py" or (p / "__init__.py").exists())}
    assert rooms - set(RANK) == set(), "rooms missing from LAYERS"
    assert set(RANK) - rooms == set(), "LAYERS names rooms that do not exist"


def test_no_upward_or_sideways_import():
    bad = [f"{f}:{line}: {a} (layer {RANK[a]}) imports {b} (layer {RANK[b]})"
           for a, b, f, line in imports() if RANK[b] >= RANK[a]]
    assert not bad, "\n".join(bad)


def test_no_cycle_between_rooms():
    graph: dict[str, set[str]] = {}
    for a, b, _, _ in imports():
        graph.setdefault(a, set()).add(b)

    def reaches(a, b, seen=frozenset()):
        return any(n == b or (n not in seen and reaches(n, b, seen | {n}))
                   for n in graph.get(a, ()))

    cycles = sorted({tuple(sorted((a, b))) for a in graph for b in graph[a] if reaches(b, a)})
    assert not cycles


@pytest.mark.parametrize("source", ["import truthbench.campaign\n",
                                    "from ..campaign import runner\n"])
def test_the_checker_sees_upward_imports(tmp_path, source):
    """A module of a low room importing a high one (module- or function-level) is found."""
    pkg = tmp_path / "truthbench"
    (pkg / "fe").mkdir(parents=True)
    (pkg / "campaign").mkdir()
    for d in (pkg, pkg / "fe", pkg / "campaign"):
        (d / "__init__.py").write_text("")
    (pkg / "fe" / "beam.py").write_text("def f():\n    " + source.replace("\n", "\n    "))
    found = imports(pkg)
    assert ("fe", "campaign", "fe/beam.py", 2) in found
