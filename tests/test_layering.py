"""Packages depend one way: pacc.errors ← dbc ← ecu ← cloud_sync ← sim_bus ← entry points ← tools.

The entry points are the modules behind the ``pacc`` sub-commands (``pacc.cli.SUBCOMMANDS``:
``ecu.cli``, ``sim_bus.cli``, ``cloud_sync.cli`` ...), the ``__main__`` modules and
``pacc.cli`` itself: they only wire the libraries together (``pacc ecu`` may hand its takeover
recorder a cloud_sync spool), so they sit above every library. A module may import modules of
its own layer or of a lower one, never of a higher one; the check reads every ``import``
statement (top-level and lazy ones inside functions) with ``ast``, so an import that only runs
on some path is caught too. ``tests`` and ``bench`` sit above everything and are not
importable from the shipped packages.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from cloud_sync.errors import CloudSyncError
from dbc.errors import CodecError
from ecu import EcuError
from pacc.cli import SUBCOMMANDS
from pacc.errors import PaccError
from sim_bus.errors import SimError

ROOT = Path(__file__).resolve().parents[1]

#: (module prefix, layer): the longest matching prefix gives a module's layer, low to high
LAYERS: tuple[tuple[str, int], ...] = (
    ("pacc.errors", 0),
    ("dbc", 1),
    ("ecu", 2),
    ("cloud_sync", 3),
    ("sim_bus", 4),
    ("pacc", 5),
    # the study's drives as engine tasks: it runs sim_bus.drive (an entry point) and is kept
    # out of the sim_bus.study package only so that a worker does not import the harness
    ("sim_bus.drive_tasks", 5),
    ("tools", 6),
    ("tests", 7),
    ("bench", 7),
)
SHIPPED = ("pacc", "dbc", "ecu", "cloud_sync", "sim_bus")
#: the entry points: every sub-command's module and every package's __main__
ENTRY_POINTS: tuple[tuple[str, int], ...] = tuple(
    (module, 5)
    for module in sorted(
        {module for module, _ in SUBCOMMANDS.values()} | {f"{p}.__main__" for p in SHIPPED}
    )
)


def layer_of(module: str) -> int | None:
    """The layer of dotted ``module`` (None: a third-party or standard-library module)."""
    best: tuple[int, int] | None = None  # (prefix length, layer)
    for prefix, layer in LAYERS + ENTRY_POINTS:
        if (module == prefix or module.startswith(prefix + ".")) and (
            best is None or len(prefix) > best[0]
        ):
            best = (len(prefix), layer)
    return None if best is None else best[1]


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
    """Every import in ``package`` that reaches a higher layer, as 'file:line: a -> b'."""
    bad: list[str] = []
    for path in sorted((ROOT / package).rglob("*.py")):
        importer = module_name(path)
        own = layer_of(importer)
        assert own is not None, importer
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for line, target in imported_modules(tree):
            theirs = layer_of(target)
            if theirs is not None and theirs > own:
                bad.append(f"{path.relative_to(ROOT)}:{line}: {importer} -> {target}")
    return bad


@pytest.mark.parametrize("package", [*SHIPPED, "tools"])
def test_imports_point_down_the_layers(package: str) -> None:
    assert violations(package) == []


def test_the_check_catches_an_upward_import(tmp_path: Path) -> None:
    tree = ast.parse("def f():\n    from sim_bus.world import World\n\nimport numpy\n")
    found = imported_modules(tree)
    assert (2, "sim_bus.world.World") in found
    assert layer_of("sim_bus.world.World") == 4 > (layer_of("ecu.node") or 0)
    assert layer_of("numpy") is None
    assert layer_of("pacc.errors") == 0 and layer_of("pacc.cli") == 5
    assert layer_of("ecu_other") is None  # a prefix must end at a dot
    assert layer_of("ecu.cli") == 5 > (layer_of("cloud_sync.spool") or 0)  # an entry point
    assert layer_of("ecu.runtime") == 2


def test_the_project_root_error_imports_nothing() -> None:
    tree = ast.parse((ROOT / "pacc" / "errors.py").read_text(encoding="utf-8"))
    assert imported_modules(tree) == []


def test_every_package_error_root_is_a_pacc_error() -> None:
    for root in (CodecError, EcuError, CloudSyncError, SimError):
        assert issubclass(root, PaccError), root
