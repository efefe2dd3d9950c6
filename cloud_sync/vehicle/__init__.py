"""The vehicle's side of the cloud link: :mod:`cloud_sync.vehicle.link` (the one wiring) of
:mod:`cloud_sync.vehicle.spool`, :mod:`cloud_sync.vehicle.uploader` (batches, then trip reports
behind their segments),
:mod:`cloud_sync.vehicle.download` (verified tables), over :mod:`cloud_sync.vehicle.client`
(HTTP) or what :mod:`cloud_sync.vehicle.connect` picks (``--cloud URL`` or ``DIR``).
"""
