"""Docs that cannot drift: every Python snippet of README.md and docs/*.md runs, and every
package docstring lists exactly the package's modules."""

from __future__ import annotations

import importlib
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
#: snippets that learn a table (a few seconds each): marked slow
SLOW = {"docs/irl.md"}


def snippets() -> list[object]:
    found: list[object] = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        name = str(doc.relative_to(ROOT))
        for m in FENCE.finditer(text):
            line = text.count("\n", 0, m.start()) + 2
            marks = [pytest.mark.slow] if name in SLOW else []
            found.append(pytest.param(name, line, m.group(1), id=f"{name}:{line}", marks=marks))
    return found


def test_the_docs_hold_python_snippets() -> None:
    assert len(snippets()) >= 3


@pytest.mark.parametrize(("doc", "line", "code"), snippets())
def test_snippet_runs(
    doc: str, line: int, code: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each snippet runs on its own in a fresh namespace, in an empty folder (files it needs it
    makes there)."""
    monkeypatch.chdir(tmp_path)
    compiled = compile("\n" * (line - 1) + code, str(ROOT / doc), "exec")
    exec(compiled, {"__name__": f"snippet_{line}"})  # noqa: S102 - the docs' own code


# -- docs/architecture.md ----------------------------------------------------------------------

ARCHITECTURE = ROOT / "docs" / "architecture.md"
TOPS = ("pacc", "dbc", "ecu", "sim_bus", "cloud_sync")
DOTTED = re.compile(r"`((?:" + "|".join(TOPS) + r")(?:\.\w+)+)`")


def resolve(dotted: str) -> object:
    """The object ``dotted`` names: the longest importable module, then attributes."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj: object = importlib.import_module(".".join(parts[:cut]))
        except ModuleNotFoundError:
            continue
        for name in parts[cut:]:
            obj = getattr(obj, name)
        return obj
    raise ModuleNotFoundError(dotted)


def test_the_architecture_names_every_module() -> None:
    named = set(DOTTED.findall(ARCHITECTURE.read_text(encoding="utf-8")))
    every = set().union(*(modules_of(p) for p in PACKAGES)) - set(PACKAGES)
    assert not every - named, f"docs/architecture.md does not name {sorted(every - named)}"


def test_every_name_in_the_architecture_exists() -> None:
    """The walks name real functions: a rename that forgets the page fails here."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    missing = []
    for dotted in sorted(set(DOTTED.findall(text))):
        try:
            resolve(dotted)
        except (ImportError, AttributeError):
            missing.append(dotted)
    assert not missing
    for cls_method in re.findall(r"`([A-Z]\w+)\.(_?\w+)`", text):  # Class.method
        owners = [
            getattr(m, cls_method[0])
            for m in map(resolve, set(DOTTED.findall(text)))
            if hasattr(m, cls_method[0])
        ]
        assert any(hasattr(o, cls_method[1]) for o in owners), ".".join(cls_method)


# -- package docstrings ------------------------------------------------------------------------

PACKAGES = [
    "pacc",
    "dbc.vocab",
    "pacc.commands",
    "pacc.commands.cloud",
    "pacc.commands.drive",
    "pacc.commands.ecu",
    "pacc.commands.plot",
    "dbc",
    "ecu",
    "ecu.cycle",
    "ecu.buslog",
    "sim_bus",
    "sim_bus.lead",
    "pacc.study",
    "pacc.hil",
    "pacc.study.bench",
    "ecu.methods",
    "cloud_sync.learners",
    "cloud_sync",
    "cloud_sync.irl",
    "cloud_sync.irl.sources",
    "cloud_sync.service",
    "cloud_sync.vehicle",
    "cloud_sync.engine",
]


def modules_of(package: str) -> set[str]:
    """The modules and sub-packages directly in ``package`` (no ``__init__``/``__main__``)."""
    folder = ROOT / package.replace(".", os.sep)
    names = {p.stem for p in folder.glob("*.py")} - {"__init__", "__main__"}
    names |= {p.parent.name for p in folder.glob("*/__init__.py")}
    return {f"{package}.{n}" for n in names}


def listed_in(package: str) -> set[str]:
    doc = importlib.import_module(package).__doc__ or ""
    named = set(re.findall(r":mod:`~?([\w.]+)`", doc))
    return {n for n in named if n.rsplit(".", 1)[0] == package}


@pytest.mark.parametrize("package", PACKAGES)
def test_a_package_docstring_lists_exactly_its_modules(package: str) -> None:
    have, listed = modules_of(package), listed_in(package)
    assert not have - listed, f"{package}: its docstring does not list {sorted(have - listed)}"
    assert not listed - have, f"{package}: its docstring lists {sorted(listed - have)}, absent"


def test_every_package_is_checked() -> None:
    found = {
        ".".join(p.parent.relative_to(ROOT).parts)
        for top in ("pacc", "dbc", "ecu", "sim_bus", "cloud_sync")
        for p in (ROOT / top).rglob("__init__.py")
    }
    assert found == set(PACKAGES)
