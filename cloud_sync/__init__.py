"""The cloud side of pacc and the vehicle's link to it.

:mod:`cloud_sync.irl` (IRL: trips in, a DGPT out), :mod:`cloud_sync.learners` (learners behind
one interface), :mod:`cloud_sync.service` (the cloud service), :mod:`cloud_sync.vehicle` (spool,
uploader, verified download), :mod:`cloud_sync.engine` (where work runs); beside them
:mod:`cloud_sync.api` (the vehicle–cloud contract), :mod:`cloud_sync.signing`,
:mod:`cloud_sync.durable` (crash-safe files) and :mod:`cloud_sync.errors` (rooted at
:class:`CloudSyncError`). Only the error tree is imported here.
"""

from __future__ import annotations

from cloud_sync.errors import CloudSyncError, DemoError, TrainingError

__all__ = ["CloudSyncError", "DemoError", "TrainingError"]
