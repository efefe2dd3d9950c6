"""The packages' shape is a diamond, and every import is checked against it.

::

    pacc.errors <- dbc <- pacc.vocab <- ecu, sim_bus, cloud_sync <- sim_bus.study <- commands

- ``pacc.errors`` imports nothing; ``dbc`` (the vehicle network) only it; ``pacc.vocab`` (the
  DGPT and trip-log formats, ACC state, pedals) both.
- ``ecu``, ``sim_bus`` (the simulator) and ``cloud_sync`` are siblings: each imports the
  vocabulary and the network, never another sibling.
- ``sim_bus.study`` is the harness: it wires the three together (one drive, the studies).
- The commands (``pacc.commands``, ``pacc.cli``, every ``__main__``) may import anything shipped;
  ``tools`` too; ``tests`` and ``bench`` sit above everything and nothing shipped imports them.

The check reads every ``import`` statement (top-level and lazy ones inside functions) with
``ast``, so an import that only runs on some path is caught too. There are no exceptions.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from cloud_sync.errors import CloudSyncError
from dbc.errors import CodecError
from ecu import EcuError
from pacc.errors import PaccError
from pacc.vocab import FormatError
from sim_bus.errors import SimError

ROOT = Path(__file__).resolve().parents[1]

#: module prefix -> room; the longest matching prefix gives a module's room
ROOMS: dict[str, str] = {
    "pacc.errors": "errors",
    "dbc": "network",
    "pacc.vocab": "vocab",
    "ecu": "ecu",
    "sim_bus": "simulator",
    "cloud_sync": "cloud",
    "sim_bus.study": "harness",
    "sim_bus.hil": "harness",
    "pacc": "commands",  # pacc.cli, pacc.commands, pacc.__main__, pacc.__init__
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
    """The room of dotted ``module`` (None: a third-party or standard-library module).

    Every package's ``__main__`` is a command, whatever package it sits in."""
    if module.endswith(".__main__"):
        return "commands"
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
    ``a.b`` so that ``from pacc import errors`` counts as ``pacc.errors``."""
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found += [(node.lineno, f"{node.module}.{alias.name}") for alias in node.names]
    return found


def violations(package: str) -> list[str]:
    """Every import in ``package`` its room may not make, as 'file:line: a -> b'."""
    bad: list[str] = []
    for path in sorted((ROOT / package).rglob("*.py")):
        importer = module_name(path)
        own = room_of(importer)
        assert own is not None, importer
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for line, target in imported_modules(tree):
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
    assert room_of("pacc.errors") == "errors" and room_of("pacc.cli") == "commands"
    assert room_of("pacc.vocab.dgpt") == "vocab"
    assert room_of("ecu_other") is None  # a prefix must end at a dot
    assert room_of("sim_bus.study.drive") == "harness"
    assert room_of("ecu.__main__") == "commands"


def test_the_project_root_error_imports_nothing() -> None:
    tree = ast.parse((ROOT / "pacc" / "errors.py").read_text(encoding="utf-8"))
    assert imported_modules(tree) == []


def test_every_package_error_root_is_a_pacc_error() -> None:
    for root in (CodecError, EcuError, CloudSyncError, SimError, FormatError):
        assert issubclass(root, PaccError), root
