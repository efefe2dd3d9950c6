"""The session's vehicle–cloud link: upload drives, learn and fine-tune the table.

The study's plumbing (:class:`pacc.study.loop.StudyCloud`: spool -> uploader -> cloud,
download with signature and bounds checks), with an embedded cloud that survives a resumed
session: it lives in ``<session>/cloud`` and the vehicle's token in ``cloud/vehicle.token``
(an embedded study cloud is made afresh each run; a session's must not be).
"""

from __future__ import annotations

from pathlib import Path

from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.signing import load_public_key
from cloud_sync.vehicle.download import ProfileDownloader
from cloud_sync.vehicle.spool import Spool
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip
from pacc.study.loop import STUDY_VEHICLE, StudyCloud
from sim_bus.errors import SimError

TOKEN_FILE = "vehicle.token"


def open_cloud(
    folder: Path,
    participant: str,
    seed: int,
    remote: tuple[str, Path, Path] | None = None,
) -> StudyCloud:
    """The session's cloud: ``remote`` (URL or folder, token file, trusted key) or the
    embedded one in ``folder/cloud`` (created with the participant registered, or reopened)."""
    if remote is not None:
        return StudyCloud.remote(remote[0], remote[1], remote[2], folder)
    service = CloudService.open(folder / "cloud", DeferredExecutor(1), ServiceConfig(seed=seed))
    token_path = folder / "cloud" / TOKEN_FILE
    if token_path.is_file():
        token = token_path.read_text(encoding="utf-8").strip()
    else:
        token = service.register_vehicle(STUDY_VEHICLE)
        service.register_driver(STUDY_VEHICLE, participant)
        tmp = token_path.with_name(TOKEN_FILE + ".part")
        tmp.write_text(token, encoding="utf-8")
        tmp.replace(token_path)
    api = LocalCloud(service, token)
    public = load_public_key(service.public_key_pem())
    downloader = ProfileDownloader(api, public, folder / "spool" / "profiles")
    return StudyCloud(api, downloader, Spool(folder / "spool"))


def learn(cloud: StudyCloud, trips: list[Trip], participant: str) -> tuple[Dgpt, int]:
    """Upload the manual ``trips``; the learned table (downloaded, verified) and the
    batches uploaded. SimError when the cloud gives no usable table."""
    batches = cloud.upload(trips)
    table = cloud.table(participant, str(trips[0].meta["condition"]))
    if table is None:
        raise SimError("no usable table: " + ("; ".join(cloud.refusals()) or "none learned"))
    return table, batches


def fine_tune(cloud: StudyCloud, segments: list[Trip], table: Dgpt) -> tuple[Dgpt, int]:
    """Upload a drive's takeover ``segments``; the newest verified table (``table`` when the
    cloud has nothing newer) and the batches uploaded."""
    batches = cloud.upload(segments) if segments else 0
    newer = cloud.table(table.driver_id, table.condition)
    return (newer if newer is not None and newer.version > table.version else table), batches
