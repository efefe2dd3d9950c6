"""Finding methods by name: built-ins, Python entry points and ``module:attribute``.

Groups: ``pacc.controllers`` (:class:`ecu.methods.GapController`), ``pacc.adaptations``
(:class:`ecu.methods.Adaptation`), ``pacc.learners`` (:class:`cloud_sync.learners.Learner`).
A *spec* (a built-in's name, an entry point of the group, or ``pkg.mod:Factory``) names a
factory: a callable taking the method's parameters as keywords. This module only finds
factories (entry points cached); each room checks and guards what they return.
:func:`provenance` names the distribution a spec's code comes from (a run's manifest).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, entry_points, packages_distributions, version
from typing import Any

from dbc.vocab import FormatError

GROUPS: tuple[str, ...] = ("pacc.controllers", "pacc.adaptations", "pacc.learners")


class PluginError(FormatError):
    """A method spec that names nothing loadable (unknown name, import error, not callable)."""


@dataclass(frozen=True)
class Found:
    """One method that a spec can name: its name, where it comes from, its target."""

    name: str
    origin: str  # "built-in" or the distribution that declares the entry point
    target: str  # "module:attribute"


@lru_cache(maxsize=8)
def _entry_points(group: str) -> dict[str, tuple[str, str]]:
    """name -> (target, distribution) of the installed entry points of ``group``."""
    found: dict[str, tuple[str, str]] = {}
    for ep in entry_points(group=group):
        dist = ep.dist.name if ep.dist is not None else "?"
        found.setdefault(ep.name, (ep.value, dist))
    return found


def load_target(target: str) -> Any:
    """The object at ``"module:attribute"`` (dotted attributes allowed); PluginError if none."""
    module_name, sep, attr = target.partition(":")
    if not sep or not module_name or not attr:
        raise PluginError(f"{target!r} is not 'module:attribute'")
    try:
        obj: Any = importlib.import_module(module_name)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise PluginError(f"cannot load {target!r}: {exc}") from exc
    return obj


def _find(group: str, name: str, builtins: Mapping[str, str]) -> tuple[str, str | None] | None:
    """(target, declaring distribution or None) of a built-in, an entry point or
    ``module:attribute`` named ``name``; None if it names none."""
    if name in builtins:
        return builtins[name], None
    if name in _entry_points(group):
        return _entry_points(group)[name]
    return (name, None) if ":" in name else None


def resolve(group: str, spec: str, builtins: Mapping[str, str]) -> Callable[..., Any]:
    """The factory a spec names in ``group``: a built-in (``builtins``: name -> target), an
    installed entry point, or ``module:attribute``. PluginError naming what exists if none."""
    if group not in GROUPS:
        raise PluginError(f"unknown plug-in group {group!r}: one of {GROUPS}")
    found = _find(group, spec.strip(), builtins)
    if found is None:
        known = sorted({*builtins, *_entry_points(group)})
        raise PluginError(
            f"no {group.split('.')[-1][:-1]} {spec!r}: one of {', '.join(known)} "
            "or 'module:attribute'"
        )
    target = found[0]
    factory = load_target(target)
    if not callable(factory):
        raise PluginError(f"{spec!r} ({target}) is not callable")
    return factory  # type: ignore[no-any-return]


def build(group: str, spec: str, builtins: Mapping[str, str], params: Mapping[str, Any]) -> Any:
    """The method object: the factory of ``spec`` called with ``params``; PluginError if the
    factory refuses them."""
    factory = resolve(group, spec, builtins)
    try:
        return factory(**dict(params))
    except (TypeError, ValueError, FormatError) as exc:
        raise PluginError(f"{spec!r} refused its parameters {dict(params)}: {exc}") from exc


def provenance(group: str, spec: str, builtins: Mapping[str, str]) -> dict[str, str | None]:
    """Where the code a spec names comes from: ``{"target", "distribution", "version"}`` (the
    distribution declaring the entry point, else the one holding the target's top-level
    module; None for a module on the path that no installed distribution holds)."""
    name = spec.strip()
    target, dist = _find(group, name, builtins) or (name, None)
    if dist is None:
        top = target.partition(":")[0].split(".")[0]
        dist = next(iter(packages_distributions().get(top, [])), None)
    try:
        ver = version(dist) if dist else None
    except PackageNotFoundError:
        ver = None
    return {"target": target, "distribution": dist, "version": ver}


def installed(group: str, builtins: Mapping[str, str]) -> list[Found]:
    """Every method of ``group``: the built-ins, then the entry points (a name taken by a
    built-in shadows an entry point of that name)."""
    out = [Found(name, "built-in", target) for name, target in builtins.items()]
    for name, (target, dist) in sorted(_entry_points(group).items()):
        if name not in builtins:
            out.append(Found(name, dist, target))
    return out
