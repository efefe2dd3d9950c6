"""The vehicle's side of the cloud link: spool, uploader, signed-profile download.

- :mod:`cloud_sync.vehicle.spool` — trip logs waiting for the cloud, crash-safe, in a quota.
- :mod:`cloud_sync.vehicle.uploader` — drains the spool into the cloud, nothing lost.
- :mod:`cloud_sync.vehicle.reports` — end-of-trip reports queued in the spool, behind their
  segments.
- :mod:`cloud_sync.vehicle.download` — the newest signed DGPT, checked before use.
- :mod:`cloud_sync.vehicle.client` — the HTTP client of ``pacc cloud serve``.
- :mod:`cloud_sync.vehicle.connect` — ``--cloud URL`` (a service) or ``--cloud DIR`` (embedded).
- :mod:`cloud_sync.vehicle.link` — the vehicle's link as ``pacc ecu --cloud`` wires it.
"""
