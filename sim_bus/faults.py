"""Fault injection on the simulator's transmitted frames, per message role.

SPEC (``--faults``): ``ROLE:KIND=VALUE[,KIND=VALUE]`` clauses separated by ``;``, ROLE one of
ego, pedals, radar, hmi or ``all``. KINDs: ``drop=P`` (lost on the wire, the counter advances),
``delay=S`` (s, order kept), ``crc=P`` (a corrupted byte), ``counter=P`` (the previous counter
repeated), and windows A-B in s: ``freeze`` (the values of time A, valid CRC), ``dropout`` and
``silence`` (nothing sent). E.g. ``radar:dropout=20-25;ego:crc=0.02;all:silence=100-100.5``;
clauses of one role merge. Random draws use the drive's seeded Generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sim_bus.errors import FaultSpecError

#: the roles the simulator transmits, each with its own fault plan
ROLES = ("ego", "pedals", "radar", "hmi")
#: second entropy word of the fault Generator's seed ("driv")
_FAULT_STREAM = 0x64726976
_PROB = ("drop", "crc", "counter")
_WINDOW = ("freeze", "dropout", "silence")


@dataclass(frozen=True)
class FaultPlan:
    """The faults of one role (probabilities 0..1, delay s, windows (start_s, end_s))."""

    drop: float = 0.0
    crc: float = 0.0
    counter: float = 0.0
    delay_s: float = 0.0
    freeze: tuple[tuple[float, float], ...] = ()
    silent: tuple[tuple[float, float], ...] = ()

    def silent_at(self, t_s: float) -> bool:
        """True when the role sends nothing at ``t_s``."""
        return any(a <= t_s < b for a, b in self.silent)

    def frozen_at(self, t_s: float) -> tuple[float, float] | None:
        """The freeze window containing ``t_s``, if any."""
        return next((w for w in self.freeze if w[0] <= t_s < w[1]), None)

    @property
    def random(self) -> bool:
        """True when the plan needs random draws."""
        return self.drop > 0 or self.crc > 0 or self.counter > 0


@dataclass(frozen=True)
class FaultSpec:
    """Fault plans per role; ``text`` is the spec it was parsed from."""

    plans: dict[str, FaultPlan] = field(default_factory=dict)
    text: str = ""


def _window(value: str, clause: str) -> tuple[float, float]:
    try:
        a_text, b_text = value.split("-", 1)
        a, b = float(a_text), float(b_text)
    except ValueError:
        raise FaultSpecError(
            f"{clause!r}: a window is START-END in seconds, got {value!r}"
        ) from None
    if not (0 <= a < b < math.inf):
        raise FaultSpecError(f"{clause!r}: window needs finite 0 <= START < END, got {value!r}")
    return a, b


def parse_faults(text: str | None) -> FaultSpec:
    """Parse a SPEC (see module docstring); an empty or None SPEC means no faults."""
    if not text or not text.strip():
        return FaultSpec()
    drafts: dict[str, dict[str, Any]] = {}  # role -> FaultPlan's keyword arguments
    for clause in (c.strip() for c in text.split(";")):
        if not clause:
            continue
        if ":" not in clause:
            raise FaultSpecError(f"{clause!r}: expected ROLE:KIND=VALUE")
        role, body = (s.strip() for s in clause.split(":", 1))
        if role not in ROLES and role != "all":
            raise FaultSpecError(f"{clause!r}: unknown role {role!r} (one of {ROLES} or all)")
        targets = ROLES if role == "all" else (role,)
        for item in (i.strip() for i in body.split(",")):
            if "=" not in item:
                raise FaultSpecError(f"{clause!r}: expected KIND=VALUE, got {item!r}")
            kind, value = (s.strip() for s in item.split("=", 1))
            for tgt in targets:
                _apply(drafts.setdefault(tgt, {}), kind, value, clause)
    return FaultSpec({role: FaultPlan(**kw) for role, kw in drafts.items()}, text)


def _apply(draft: dict[str, Any], kind: str, value: str, clause: str) -> None:
    if kind in (*_PROB, "delay"):  # a probability 0..1, or a delay of 0..10 s
        what, top, unit = ("seconds", 10.0, " s") if kind == "delay" else ("a probability", 1, "")
        try:
            x = float(value)
        except ValueError:
            raise FaultSpecError(f"{clause!r}: {kind} needs {what}, got {value!r}") from None
        if not 0.0 <= x <= top:
            raise FaultSpecError(f"{clause!r}: {kind} must lie in 0..{top:g}{unit}")
        draft["delay_s" if kind == "delay" else kind] = x
    elif kind in _WINDOW:
        key = "freeze" if kind == "freeze" else "silent"
        draft[key] = (*draft.get(key, ()), _window(value, clause))
    else:
        raise FaultSpecError(
            f"{clause!r}: unknown fault kind {kind!r} (one of {_PROB + ('delay',) + _WINDOW})"
        )


def fault_rng(seed: int) -> np.random.Generator:
    """The Generator of the random faults of a run with ``seed`` (>= 0), lockstep or real time."""
    return np.random.default_rng(np.random.SeedSequence([seed, _FAULT_STREAM]).spawn(1)[0])
