"""The compute engine where drives and learning run: one seam between pure work and workers.

- :mod:`cloud_sync.engine.base` — ``Engine``: in-process or a local process pool.
- :mod:`cloud_sync.engine.dask_backend` — the Dask distributed backend (extra ``pacc[dask]``).
"""
