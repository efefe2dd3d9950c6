"""The paper's protocol for one participant, and its counterbalancing (pure functions).

A session is a list of :class:`Step`: consent, a practice drive, the four manual (ACC off)
drives manual1..manual4, the IRL table learned in the cloud, a break, then the four
controllers × Scenarios A and B in the participant's row of a balanced Latin square, a break
half way. Drives are blind: a step's ``label`` (what the page shows) never names the controller.
"""

from __future__ import annotations

import dataclasses
import re
from dataclasses import dataclass

from pacc.study.drive import CONTROLLERS
from pacc.study.irl_table import MANUAL_PROFILES
from sim_bus.errors import SimError

#: the eight ACC conditions of Table I, (controller, scenario)
CONDITIONS: tuple[tuple[str, str], ...] = tuple((c, s) for s in ("A", "B") for c in CONTROLLERS)
#: the conditions the page can show a drive in
WEATHER = ("day", "rain", "night")


def with_weather(steps: list[Step], weather: str) -> list[Step]:
    """``steps`` with their drives' ``weather``: one condition for every drive, or a
    comma-separated list with one per drive in plan order (e.g. ``day,rain,night``)."""
    names = [w.strip() for w in weather.split(",")]
    drives = [s for s in steps if s.kind == "drive"]
    if any(w not in WEATHER for w in names) or len(names) not in (1, len(drives)):
        raise SimError(
            f"--weather: one of {'/'.join(WEATHER)}, or {len(drives)} of them comma-separated "
            f"(one per drive), got {weather!r}"
        )
    per = iter(names * len(drives) if len(names) == 1 else names)
    return [dataclasses.replace(s, weather=next(per)) if s.kind == "drive" else s for s in steps]


@dataclass(frozen=True)
class Step:
    """One step of a session: ``id`` names its files, ``label`` is what the page shows (never
    the controller); a drive's ``scenario``, ``controller`` (None: manual), ``practice``,
    ``weather`` (:data:`WEATHER`).
    """

    id: str
    kind: str  # consent, drive (practice, manual or ACC), learn, break or done
    label: str
    scenario: str = ""
    controller: str | None = None
    practice: bool = False
    weather: str = "day"


def balanced_latin_square(n: int, row: int) -> list[int]:
    """Row ``row`` (any integer, taken mod n, or mod 2n for odd n) of a balanced Latin square
    of order ``n`` (Williams 1949): over n rows (2n for odd n) each condition comes once in
    every position and directly follows every other condition equally often."""
    if n < 1:
        raise ValueError(f"a Latin square has order >= 1, got {n}")
    first = [0] + [(k + 1) // 2 if k % 2 else n - k // 2 for k in range(1, n)]
    rows = n if n % 2 == 0 else 2 * n
    r = row % rows
    seq = [(c + r) % n for c in first]
    return seq if r < n else seq[::-1]


def participant_index(participant: str) -> int:
    """The participant's number, from the digits of its id (``P07`` -> 7)."""
    digits = re.findall(r"\d+", participant)
    if not digits:
        raise SimError(f"participant id {participant!r} has no number: use e.g. P01")
    return int(digits[-1])


def acc_order(participant: str) -> list[tuple[str, str]]:
    """The participant's order of the eight (controller, scenario) conditions: row
    ``number - 1`` of the balanced Latin square of order 8."""
    row = balanced_latin_square(len(CONDITIONS), participant_index(participant) - 1)
    return [CONDITIONS[i] for i in row]


def paper_plan(participant: str, incremental: int = 0) -> list[Step]:
    """The paper's session for one participant (see the module docstring); ``incremental``:
    then that many IRL + OA drives on Scenario B, the cloud fine-tuning the table between them
    (the paper's incremental learning; steps ``inc1``..)."""
    if incremental < 0:
        raise SimError(f"incremental drives: a count >= 0, got {incremental}")
    steps = [
        Step("consent", "consent", "Consent"),
        Step("practice", "drive", "Practice drive", "manual4", "predefined", practice=True),
    ]
    for k, name in enumerate(MANUAL_PROFILES, 1):
        steps.append(Step(name, "drive", f"Manual drive {k} of 4 (cruise control off)", name))
    steps.append(Step("learn", "learn", "Learning your driving style"))
    steps.append(Step("break1", "break", "Break"))
    order = acc_order(participant)
    total = len(order) + incremental
    for k, (controller, scenario) in enumerate(order, 1):
        steps.append(
            Step(f"acc{k}-{scenario}", "drive", f"Drive {k} of {total}", scenario, controller)
        )
        if k == len(order) // 2:
            steps.append(Step("break2", "break", "Break"))
    if incremental:
        steps.append(Step("break3", "break", "Break"))
    for k in range(1, incremental + 1):
        label = f"Drive {len(order) + k} of {total}"
        steps.append(Step(f"inc{k}-B", "drive", label, "B", "irl+oa"))
    steps.append(Step("done", "done", "Thank you"))
    return steps


def free_plan(scenario: str, controller: str | None) -> list[Step]:
    """One drive without a study (``pacc hil`` without ``--protocol``)."""
    return [Step("drive", "drive", "Free drive", scenario, controller), Step("done", "done", "End")]


def trip_of(step_id: str) -> int:
    """The trip number of an incremental drive's step (``inc2-B`` -> 2), else 0."""
    return int(step_id[3:].split("-")[0]) if step_id.startswith("inc") else 0
