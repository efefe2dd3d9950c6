"""``pacc cloud sync``: spool trip logs and upload a spool to the cloud, once.

    pacc cloud sync --spool DIR --cloud URL|DIR --token-file F [--add FILE ...]
                    [--quota-mb 256] [--fetch DRIVER --trust KEY.pub -o DGPT.signed.json]

Each ``--add`` file (an MCAP trip log) is checked and spooled; then every pending batch is
uploaded (retrying while the cloud is unavailable, up to ``--retry-s`` seconds) and deleted
only once the cloud acknowledged it. With ``--fetch`` the driver's newest signed table is
downloaded, verified against the trusted key and kept in ``DIR/profiles``.
"""

from __future__ import annotations

import argparse
import threading
from typing import Any

from cloud_sync.errors import CloudSyncError

__all__ = ["add_subparser"]


def _do_sync(args: argparse.Namespace) -> int:
    # numpy, MCAP, httpx and the embedded service (~2 s of imports): not for `--help`
    from cloud_sync.signing import load_public_key  # noqa: PLC0415
    from cloud_sync.vehicle.connect import connect, read_token  # noqa: PLC0415
    from cloud_sync.vehicle.download import ProfileDownloader  # noqa: PLC0415
    from cloud_sync.vehicle.spool import Spool  # noqa: PLC0415
    from cloud_sync.vehicle.uploader import Uploader, UploaderConfig  # noqa: PLC0415

    if args.fetch and not args.trust:
        print("pacc cloud sync: error: --fetch needs --trust KEY.pub (the cloud's public key)")
        return 2
    try:
        spool = Spool(args.spool, quota_bytes=int(args.quota_mb * 1024 * 1024))
        for path in args.add:
            batch = spool.put_file(path)
            print(f"spooled {path}: {batch.kind} batch {batch.seq} ({batch.digest[:12]})")
        cloud = connect(args.cloud, read_token(args.token_file))
        trusted = load_public_key(args.trust) if args.fetch else None
    except (CloudSyncError, OSError) as exc:
        print(f"pacc cloud sync: error: {exc}")
        return 1
    uploader = Uploader(spool, cloud, UploaderConfig(backoff_max_s=min(args.retry_s, 30.0)))
    timer = threading.Timer(args.retry_s, uploader.stop)  # give up retrying after --retry-s
    timer.start()
    try:
        done = uploader.drain()
    finally:
        timer.cancel()
    left = spool.pending()
    print(
        f"uploaded {done} batch(es) ({uploader.stats.duplicates} already held), "
        f"{uploader.stats.rejected} rejected, {len(left)} still spooled"
    )
    code = 0 if not left and not uploader.stats.rejected else 1
    if trusted is not None:
        downloader = ProfileDownloader(cloud, trusted, spool.root / "profiles")
        table = downloader.fetch(args.fetch, args.condition)
        table = table or downloader.last_good(args.fetch, args.condition)
        if table is None:
            print(f"no usable table for {args.fetch}: {downloader.report}")
            return 1
        print(
            f"DGPT {table.driver_id}/{table.condition} v{table.version} verified, kept in "
            f"{downloader.cache_path(args.fetch, args.condition)}"
        )
    return code


def add_subparser(subparsers: Any) -> None:
    """Register ``sync`` on the ``pacc cloud`` parser."""
    p = subparsers.add_parser("sync", help="spool trip logs and upload the spool once")
    p.add_argument("--spool", required=True, help="the vehicle's spool folder")
    p.add_argument("--cloud", required=True, help="the service URL, or a folder (embedded)")
    p.add_argument("--token-file", required=True, help="file holding the vehicle's token")
    p.add_argument("--add", nargs="*", default=[], help="MCAP trip logs to spool first")
    p.add_argument("--quota-mb", type=float, default=256.0, help="spool size quota, MiB")
    p.add_argument("--retry-s", type=float, default=60.0, help="stop retrying after, s")
    p.add_argument("--fetch", metavar="DRIVER", help="download this driver's newest table")
    p.add_argument("--condition", default="default", help="driving condition of --fetch")
    p.add_argument("--trust", help="the cloud's public key (PEM) to verify --fetch with")
    p.set_defaults(func=_do_sync)
