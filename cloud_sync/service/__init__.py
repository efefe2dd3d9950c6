"""The cloud service: who may do what, ingest, learning jobs, signed DGPT versions.

- :mod:`cloud_sync.service.store` — the SQLite index and content-addressed blobs.
- :mod:`cloud_sync.service.rules` — ``CloudService``: the rules, free of any transport.
- :mod:`cloud_sync.service.ingest` — checks of an upload: a pacc trip log of a known kind;
  storage failures become retryable answers (``StorageFullError``).
- :mod:`cloud_sync.service.jobs` — where learning jobs run (``InlineExecutor``,
  ``DeferredExecutor``) and the training itself (``train_table``).
- :mod:`cloud_sync.service.http` — the rules as an HTTP service (FastAPI).
- :mod:`cloud_sync.service.local` — the embedded cloud: the service in-process over a folder.
- :mod:`cloud_sync.service.views` — what a person looks at: read-only lists of the cloud's
  state, and the dashboard page.
- :mod:`cloud_sync.service.trips` — trip reports: the per-trip measures (PoI, takeovers per
  minute) the cloud computes from a trip's uploaded takeover segments.
"""
