"""Driver profiles: the HMI's ``DriverProfileId`` selects the DGPT the node runs on.

``n > 0`` loads ``profile_dir/profile_<n>.json``; an invalid file is refused (the node keeps
its last good table and reports FaultCode PROFILE), a missing one keeps the table; ``n = 0``
(guest) returns to the table the node started with. File I/O happens here, at the edge,
between two cycles; nothing here raises into the control loop.
"""

from __future__ import annotations

import os
from pathlib import Path

from ecu.dgpt import DgptError, load_dgpt
from ecu.node import EcuNode

#: The profile id of the guest (the node's startup table).
GUEST_PROFILE = 0


def profile_path(profile_dir: Path, profile_id: int) -> Path:
    """The file of driver profile ``profile_id`` in ``profile_dir``."""
    return profile_dir / f"profile_{profile_id}.json"


class ProfileSwitcher:
    """Switches ``node`` to the profile the HMI asks for, once per change of the id.

    Args:
        node: the node whose table is switched.
        profile_dir: the folder of ``profile_<n>.json`` files.
    """

    def __init__(self, node: EcuNode, profile_dir: str | os.PathLike[str]) -> None:
        self.node = node
        self.profile_dir = Path(profile_dir)
        self._guest_table = node.table
        self._profile_id: int | None = None

    def request(self, profile_id: int | None) -> None:
        """The HMI asks for ``profile_id`` (None: no valid HMI, nothing changes)."""
        if profile_id is not None and profile_id != self._profile_id:
            self._switch(profile_id)

    def _switch(self, profile_id: int) -> None:
        """Load driver profile ``profile_id`` (never raises)."""
        self._profile_id = profile_id
        node = self.node
        if profile_id == GUEST_PROFILE:
            if node.table is not self._guest_table:
                node.set_table(self._guest_table, "profile 0 (guest): startup table")
            return
        path = profile_path(self.profile_dir, profile_id)
        keeping = f"keeping the last good DGPT ({node.table.driver_id} v{node.table.version})"
        try:
            missing = not path.exists()
        except OSError as exc:  # e.g. EACCES, ENAMETOOLONG: not "missing", unusable
            node.report_profile_fault(
                f"profile {profile_id} refused: {path}: {exc.strerror or exc}; {keeping}"
            )
            return
        if missing:
            node.set_table(
                node.table, f"profile {profile_id}: no {path}, keeping DGPT v{node.table.version}"
            )
            return
        try:
            table = load_dgpt(path, node.config.bounds)
        except DgptError as exc:
            node.report_profile_fault(f"profile {profile_id} refused: {exc}; {keeping}")
            return
        node.set_table(
            table, f"profile {profile_id}: {table.driver_id} {table.source} v{table.version}"
        )


__all__ = ["GUEST_PROFILE", "ProfileSwitcher", "profile_path"]
