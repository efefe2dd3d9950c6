"""Driver profiles: the HMI's ``DriverProfileId`` selects the DGPT the node runs on.

``n > 0`` loads ``profile_dir/profile_<n>.json`` in a worker thread, never in the control
cycle; an invalid file is refused (the node keeps its table and reports FaultCode PROFILE), a
missing one keeps the table; ``n = 0`` (guest) returns to the startup table. Nothing here
raises into the control loop.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import Dgpt, DgptError, predefined
from dbc.vocab.dgpt_file import load_dgpt
from ecu.node import EcuNode

#: The profile id of the guest (the node's startup table).
GUEST_PROFILE = 0
#: HMI ``GapSetting`` 1..3 -> the predefined table's headway, s (the paper's low, medium and
#: high settings)
GAP_SETTING_HEADWAY_S: dict[float, float] = {1: 1.0, 2: 3.0, 3: 4.0}


def gap_setting_table(table: Dgpt, code: float | None) -> Dgpt | None:
    """The predefined table of HMI gap setting ``code`` in place of ``table`` (same standstill
    gap, driver and condition); None when ``table`` is not a predefined one (a learned table
    is the driver's own gap) or ``code`` is not 1..3."""
    headway = GAP_SETTING_HEADWAY_S.get(code) if code is not None else None
    if headway is None or table.source != "predefined":
        return None
    standstill = float(table.meta.get("standstill_m", table.gap_m[0]))
    try:
        return predefined(
            headway,
            standstill,
            table.driver_id,
            condition=table.condition,
            created_utc=table.created_utc,
        )
    except DgptError:
        return None


class ProfileSwitcher:
    """Switches ``node`` to the profile the HMI asks for (``profile_dir/profile_<n>.json``), once
    per change of the id."""

    def __init__(self, node: EcuNode, profile_dir: str | os.PathLike[str]) -> None:
        self.node = node
        self.profile_dir = Path(profile_dir)
        self._guest_table = node.table
        self._profile_id: int | None = None
        self._lock = threading.Lock()
        # a load's outcome: (id, the table or _KEEP, or None for a refusal; the event text)
        self._done: tuple[int, Dgpt | None, str] | None = None
        #: the latest load's worker thread (None: none started)
        self.loading: threading.Thread | None = None

    @property
    def selected(self) -> int | None:
        """The profile id the HMI selected last (None: none yet)."""
        return self._profile_id

    def request(self, profile_id: int | None) -> None:
        """The HMI asks for ``profile_id`` (None: no valid HMI, nothing changes); the finished
        load of the selected profile is applied now (an older selection's is dropped)."""
        with self._lock:
            done, self._done = self._done, None
        if done is not None and done[0] == self._profile_id:
            _, table, message = done
            if table is None:
                self.node.report_profile_fault(message)
            else:  # the loaded table, or the node's own (a missing file clears the fault)
                self.node.set_table(table if table is not _KEEP else self.node.table, message)
        if profile_id is not None and profile_id != self._profile_id:
            self._profile_id = profile_id
            if profile_id != GUEST_PROFILE:
                self.loading = threading.Thread(
                    target=self._load, args=(profile_id,), name="profile-load", daemon=True
                )
                self.loading.start()
            elif self.node.table is not self._guest_table:
                self.node.set_table(self._guest_table, "profile 0 (guest): startup table")

    def _load(self, profile_id: int) -> None:
        """Worker thread: read profile ``profile_id``; its outcome waits for the cycle."""
        path = self.profile_dir / f"profile_{profile_id}.json"
        current = self.node.table
        keeping = f"keeping the last good DGPT ({current.driver_id} v{current.version})"
        table: Dgpt | None = _KEEP
        try:
            if not path.exists():
                message = f"profile {profile_id}: no {path}, keeping DGPT v{current.version}"
            else:
                table = load_dgpt(path, self.node.config.bounds)
                message = f"profile {profile_id}: {table.driver_id} {table.source} v{table.version}"
        except OSError as exc:  # e.g. EACCES, ENAMETOOLONG: not "missing", unusable
            table = None
            message = f"profile {profile_id} refused: {path}: {exc.strerror or exc}; {keeping}"
        except DgptError as exc:
            table = None
            message = f"profile {profile_id} refused: {exc}; {keeping}"
        with self._lock:
            self._done = (profile_id, table, message)


#: a load's outcome "keep the node's table" (the profile's file does not exist)
_KEEP = predefined(1.0)


def may_swap(state: AccState) -> bool:
    """True when a new table may replace the node's: in any state but ACTIVE."""
    return state is not AccState.ACTIVE


class TableOffer:
    """A one-slot mailbox for a table from another thread; the newest offer wins."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._pending: tuple[Dgpt, str] | None = None
        #: tables swapped in so far
        self.applied = 0

    def offer(self, table: Dgpt, message: str) -> None:
        """Hand ``table`` to the node at its next safe cycle (replaces an older offer)."""
        with self._lock:
            self._pending = (table, message)

    @property
    def pending(self) -> bool:
        """True while an offered table waits for a safe cycle."""
        return self._pending is not None

    def apply(self, node: EcuNode) -> bool:
        """Swap the pending table in if ``node`` is not ACTIVE; True when it did."""
        if self._pending is None or not may_swap(node.state):
            return False
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is None:
            return False
        node.set_table(*pending)
        self.applied += 1
        return True
