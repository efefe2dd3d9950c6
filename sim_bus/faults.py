"""Fault injection on the simulator's transmitted frames, configurable per message role.

SPEC syntax (``--faults``): clauses separated by ``;``, each ``ROLE:KIND=VALUE[,KIND=VALUE]``.
ROLE is one of ego, pedals, radar, hmi, or ``all`` (every role). KINDs:

- ``drop=P``       drop each frame with probability P (the counter still advances: lost on
                   the wire);
- ``delay=S``      deliver every frame S seconds late (order kept);
- ``crc=P``        corrupt the CRC byte of a frame with probability P;
- ``counter=P``    repeat the previous alive counter with probability P;
- ``freeze=A-B``   from A to B seconds, keep sending the values of time A (valid CRC/counter);
- ``dropout=A-B``  from A to B seconds, send nothing (e.g. a radar dropout);
- ``silence=A-B``  same as dropout; meant for ``all`` (bus silence).

Example: ``radar:dropout=20-25;ego:crc=0.02;all:silence=100-100.5``. Several clauses for
one role merge; window kinds may repeat. Random decisions use the drive's seeded Generator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

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
        for w in self.freeze:
            if w[0] <= t_s < w[1]:
                return w
        return None

    @property
    def random(self) -> bool:
        """True when the plan needs random draws."""
        return self.drop > 0 or self.crc > 0 or self.counter > 0


@dataclass(frozen=True)
class FaultSpec:
    """Fault plans per role; ``text`` is the spec it was parsed from."""

    plans: dict[str, FaultPlan] = field(default_factory=dict)
    text: str = ""

    def plan(self, role: str) -> FaultPlan | None:
        """The plan of ``role`` or None when it has no fault."""
        return self.plans.get(role)


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


@dataclass
class _Draft:
    """The faults of one role while a SPEC is parsed (the mutable twin of FaultPlan)."""

    values: dict[str, float] = field(default_factory=dict)  # drop, crc, counter, delay
    freeze: list[tuple[float, float]] = field(default_factory=list)
    silent: list[tuple[float, float]] = field(default_factory=list)

    def plan(self) -> FaultPlan:
        v = self.values
        return FaultPlan(
            drop=v.get("drop", 0.0),
            crc=v.get("crc", 0.0),
            counter=v.get("counter", 0.0),
            delay_s=v.get("delay", 0.0),
            freeze=tuple(self.freeze),
            silent=tuple(self.silent),
        )


def parse_faults(text: str | None) -> FaultSpec:
    """Parse a SPEC (see module docstring); an empty or None SPEC means no faults."""
    if not text or not text.strip():
        return FaultSpec()
    drafts: dict[str, _Draft] = {}
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
                _apply(drafts.setdefault(tgt, _Draft()), kind, value, clause)
    return FaultSpec({role: d.plan() for role, d in drafts.items()}, text)


def _apply(draft: _Draft, kind: str, value: str, clause: str) -> None:
    if kind in _PROB:
        try:
            p = float(value)
        except ValueError:
            raise FaultSpecError(f"{clause!r}: {kind} needs a probability, got {value!r}") from None
        if not 0.0 <= p <= 1.0:
            raise FaultSpecError(f"{clause!r}: {kind} probability must lie in 0..1")
        draft.values[kind] = p
    elif kind == "delay":
        try:
            d = float(value)
        except ValueError:
            raise FaultSpecError(f"{clause!r}: delay needs seconds, got {value!r}") from None
        if not 0.0 <= d <= 10.0:
            raise FaultSpecError(f"{clause!r}: delay must lie in 0..10 s")
        draft.values["delay"] = d
    elif kind in _WINDOW:
        (draft.freeze if kind == "freeze" else draft.silent).append(_window(value, clause))
    else:
        raise FaultSpecError(
            f"{clause!r}: unknown fault kind {kind!r} (one of {_PROB + ('delay',) + _WINDOW})"
        )


def fault_rng(seed: int) -> np.random.Generator:
    """The Generator of the random faults of a run with ``seed`` (>= 0), lockstep or real time."""
    return np.random.default_rng(np.random.SeedSequence([seed, _FAULT_STREAM]).spawn(1)[0])
