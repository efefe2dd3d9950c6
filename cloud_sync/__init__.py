"""The cloud side of pacc and the vehicle's link to it.

Sub-packages, one subsystem each:

- :mod:`cloud_sync.irl` — maximum-entropy IRL: trips in, a driver's DGPT out;
- :mod:`cloud_sync.service` — the cloud service (SQLite index, blobs, jobs, signed tables, HTTP);
- :mod:`cloud_sync.vehicle` — the vehicle's spool, uploader and signed-profile download;
- :mod:`cloud_sync.engine` — where drives and learning run (in-process, processes, Dask).

Beside them: :mod:`cloud_sync.api` (the vehicle–cloud contract, whatever carries it),
:mod:`cloud_sync.signing` (Ed25519-signed tables), :mod:`cloud_sync.durable` (crash-safe files:
the folder fsync the store and the spool share) and :mod:`cloud_sync.errors` (the error tree,
:mod:`cloud_sync.learners` (learners: trips -> a driver's DGPT, behind one small interface);
rooted at :class:`CloudSyncError`). The formats it reads (DGPT, trip logs) are the shared
vocabulary of :mod:`dbc.vocab`. Only the error tree is imported here.
"""

from __future__ import annotations

from cloud_sync.errors import CloudSyncError, DemoError, TrainingError

__all__ = ["CloudSyncError", "DemoError", "TrainingError"]
