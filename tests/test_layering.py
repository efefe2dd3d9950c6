"""The house stands on floors, and every import is checked against them.

::

    floor 0  dbc/         the ground: dbc.errors (PaccError), the vehicle network, dbc.vocab
    floor 1  ecu/  sim_bus/  cloud_sync/   siblings: the ECU, the simulator, the cloud
    floor 2  pacc/        the harness (pacc.study, pacc.hil) under the commands (pacc.cli,
                          pacc.commands, every __main__ of pacc)
    floor 3  tools/  bench/  tests/

- ``dbc.errors`` imports nothing; the network only it; ``dbc.vocab`` (the DGPT and trip-log
  formats, ACC state, pedals) both.
- ``ecu``, ``sim_bus`` and ``cloud_sync`` each import the ground, never a sibling.
- The harness wires the three together (one drive, the studies, the HIL station); the
  commands may import anything shipped; nothing shipped imports ``tools``, ``bench`` or
  ``tests``.

The check reads every ``import`` statement (top-level and lazy ones inside functions) with
``ast``, so an import that only runs on some path is caught too. There are no exceptions: no
folder imports one that imports it back.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

from cloud_sync.errors import CloudSyncError
from dbc.errors import CodecError, PaccError
from dbc.vocab import FormatError
from ecu import EcuError
from sim_bus.errors import SimError

ROOT = Path(__file__).resolve().parents[1]

#: module prefix -> room; the longest matching prefix gives a module's room
ROOMS: dict[str, str] = {
    "dbc.errors": "errors",
    "dbc": "network",
    "dbc.vocab": "vocab",
    "ecu": "ecu",
    "sim_bus": "simulator",
    "cloud_sync": "cloud",
    "pacc.study": "harness",
    "pacc.hil": "harness",
    "pacc": "commands",  # pacc.cli, pacc.commands, every __main__ of pacc
    "pacc.commands": "commands",
    "tools": "tools",
    "tests": "tests",
    "bench": "bench",
}
_BASE = {"errors", "network", "vocab"}
#: room -> the rooms its modules may import (its own always)
ALLOWED: dict[str, set[str]] = {
    "errors": set(),
    "network": {"errors"},
    "vocab": {"errors", "network"},
    "ecu": _BASE,
    "simulator": _BASE,
    "cloud": _BASE,
    "harness": _BASE | {"ecu", "simulator", "cloud"},
    "commands": _BASE | {"ecu", "simulator", "cloud", "harness"},
    "tools": _BASE | {"ecu", "simulator", "cloud", "harness", "commands"},
    "tests": set(ROOMS.values()),
    "bench": set(ROOMS.values()),
}
SHIPPED = ("pacc", "dbc", "ecu", "cloud_sync", "sim_bus")


def room_of(module: str) -> str | None:
    """The room of dotted ``module`` (None: a third-party or standard-library module)."""
    best = max(
        (p for p in ROOMS if module == p or module.startswith(p + ".")), key=len, default=None
    )
    return None if best is None else ROOMS[best]


def module_name(path: Path) -> str:
    """Dotted module name of ``path`` under the repository root."""
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def imported_modules(tree: ast.AST) -> list[tuple[int, str]]:
    """(line, dotted module) of every absolute import in ``tree``; ``from a import b`` gives
    ``a.b`` so that ``from pacc import errors`` counts as ``dbc.errors``."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


@functools.cache
def imports_in(path: Path) -> list[tuple[int, str]]:
    """:func:`imported_modules` of the file ``path``, read once for every check here."""
    return imported_modules(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)))


def violations(package: str) -> list[str]:
    """Every import in ``package`` its room may not make, as 'file:line: a -> b'."""
    bad: list[str] = []
    for path in sorted((ROOT / package).rglob("*.py")):
        importer = module_name(path)
        own = room_of(importer)
        assert own is not None, importer
        for line, target in imports_in(path):
            theirs = room_of(target)
            if theirs is not None and theirs != own and theirs not in ALLOWED[own]:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {importer} -> {target}")
    return bad


@pytest.mark.parametrize("package", [*SHIPPED, "tools"])
def test_imports_follow_the_diamond(package: str) -> None:
    assert violations(package) == []


def test_the_check_catches_a_sibling_and_an_upward_import() -> None:
    tree = ast.parse("def f():\n    from sim_bus.world import World\n\nimport numpy\n")
    found = imported_modules(tree)
    assert (2, "sim_bus.world.World") in found
    assert room_of("sim_bus.world.World") == "simulator"
    assert "simulator" not in ALLOWED["ecu"]  # siblings do not import each other
    assert "harness" not in ALLOWED["cloud"]  # nor the harness above them
    assert room_of("numpy") is None
    assert room_of("dbc.errors") == "errors" and room_of("pacc.cli") == "commands"
    assert room_of("dbc.vocab.dgpt") == "vocab"
    assert room_of("ecu_other") is None  # a prefix must end at a dot
    assert room_of("pacc.study.drive") == "harness"


def test_the_project_root_error_imports_nothing() -> None:
    tree = ast.parse((ROOT / "dbc" / "errors.py").read_text(encoding="utf-8"))
    assert imported_modules(tree) == []


def test_every_package_error_root_is_a_pacc_error() -> None:
    for root in (CodecError, EcuError, CloudSyncError, SimError, FormatError):
        assert issubclass(root, PaccError), root


#: top-level folder -> its floor; a folder imports only folders on floors below its own
FLOORS: dict[str, int] = {
    "dbc": 0,
    "ecu": 1,
    "sim_bus": 1,
    "cloud_sync": 1,
    "pacc": 2,
    "tools": 3,
    "bench": 3,
    "tests": 3,
}


def module_imports(packages: tuple[str, ...]) -> dict[str, set[str]]:
    """Every module of ``packages`` -> the project modules it imports (names as written, cut
    to an existing module: ``from a.b import c`` is ``a.b.c`` when that is a module, else
    ``a.b``)."""
    files = {module_name(p): p for pkg in packages for p in (ROOT / pkg).rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in files.items():
        targets = set()
        for _, written in imports_in(path):
            target = written
            while target and target not in files:
                target = target.rpartition(".")[0]
            if target and target != name:
                targets.add(target)
        graph[name] = targets
    return graph


def test_each_folder_stands_on_one_floor() -> None:
    """No folder imports a sibling or a folder above it (none imports one that imports it)."""
    bad = [
        f"{a} -> {b}"
        for a, targets in module_imports((*SHIPPED, "tools")).items()
        for b in targets
        if (fa := a.split(".")[0]) != (fb := b.split(".")[0]) and FLOORS[fb] >= FLOORS[fa]
    ]
    assert bad == []


def test_no_import_loops_between_modules() -> None:
    """The module graph is acyclic: a concept split by size would show as a loop here.

    A package's ``__init__`` that re-exports its modules is not an import of the package by
    them, so an edge into a package's own ``__init__`` from inside it is left out."""
    graph = module_imports(SHIPPED)
    graph = {a: {b for b in targets if not a.startswith(b + ".")} for a, targets in graph.items()}
    done: set[str] = set()
    loops: list[list[str]] = []

    def visit(node: str, path: list[str]) -> None:
        if node in path:
            loops.append(path[path.index(node) :])
            return
        if node in done:
            return
        for nxt in sorted(graph.get(node, ())):
            visit(nxt, [*path, node])
        done.add(node)

    for start in sorted(graph):
        visit(start, [])
    assert loops == []
