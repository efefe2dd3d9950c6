"""The compute engine where drives and learning run: one seam between pure work and workers.

- :mod:`cloud_sync.engine.base` — ``Engine``: in-process or a local process pool.
- :mod:`cloud_sync.engine.dask_backend` — the Dask distributed backend (extra ``pacc[dask]``).

:func:`open_engine` picks one from a command line's ``--scheduler`` and ``--workers``.
"""

from __future__ import annotations

from cloud_sync.engine.base import Engine, InlineEngine, ProcessEngine
from cloud_sync.errors import EngineError


def open_engine(scheduler: str | None, workers: int) -> Engine:
    """The engine of a command line: ``scheduler`` None -> :class:`InlineEngine` for one
    worker, else a :class:`ProcessEngine` of ``workers``; ``"local"`` -> a Dask
    ``LocalCluster`` of ``workers`` processes; ``tcp://HOST:PORT`` (or any Dask address) ->
    that cluster. :class:`EngineError` if Dask is missing or the scheduler does not answer."""
    if scheduler is None:
        return InlineEngine() if workers <= 1 else ProcessEngine(workers)
    try:
        # Dask is an optional extra and costs ~1 s of import: only a --scheduler needs it
        from cloud_sync.engine.dask_backend import DaskEngine  # noqa: PLC0415
    except ImportError as exc:
        raise EngineError(
            f"--scheduler needs Dask: pip install 'pacc[dask]' ({exc.name} is missing)"
        ) from exc
    if scheduler == "local":
        return DaskEngine.local(workers)
    return DaskEngine.connect(scheduler)


__all__ = ["open_engine"]
