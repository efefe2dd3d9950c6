"""The cloud service: who may do what, ingest, learning jobs, signed DGPT versions.

:mod:`cloud_sync.service.rules` (``CloudService``, free of any transport) over
:mod:`cloud_sync.service.store` (SQLite index, blobs), with :mod:`cloud_sync.service.ingest`
(upload checks) and :mod:`cloud_sync.service.trips` (trip reports); carried by
:mod:`cloud_sync.service.http` (FastAPI, with read-only views and the dashboard) or in process
by :mod:`cloud_sync.service.local`.
"""
