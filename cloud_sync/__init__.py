"""Cloud side of pacc: each driver's DGPT learned by inverse RL from trip logs.

The trip-log format (:mod:`ecu.triplog`) and the DGPT format (:mod:`ecu.dgpt`) live in the ECU
package, which writes them; this package reads them. Modules, one concept each:
:mod:`~cloud_sync.tripfiles` (CSV pairs, dispatch by suffix), :mod:`~cloud_sync.demos`
(trips → segments and feature counts), :mod:`~cloud_sync.mdp` (grid, sparse transitions),
:mod:`~cloud_sync.features` (reward basis), :mod:`~cloud_sync.mce_irl` (soft value
iteration, visitation, objective), :mod:`~cloud_sync.model` (fresh or an earlier table's grid,
basis and α), :mod:`~cloud_sync.fit` (L-BFGS on the dual), :mod:`~cloud_sync.extract`
(reward → table, baseline), :mod:`~cloud_sync.blend` (coverage, evidence, blending into an
earlier table), :mod:`~cloud_sync.trainer` (``learn_dgpt``, ``fine_tune``: compositions of
those phases), :mod:`~cloud_sync.plot`,
:mod:`~cloud_sync.cli` (``pacc cloud``). Errors derive from :class:`CloudSyncError`. Only the
error tree is imported here; the numerical modules import numpy/scipy, import them explicitly.
"""

from __future__ import annotations

from cloud_sync.errors import CloudSyncError, DemoError, TrainingError

__all__ = ["CloudSyncError", "DemoError", "TrainingError"]
