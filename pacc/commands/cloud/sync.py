"""``pacc cloud sync``: spool trip logs and upload a spool to the cloud, once.

Each ``--add`` file (an MCAP trip log) is checked and spooled; then every pending batch is
uploaded (retrying while the cloud is unavailable, up to ``--retry-s`` seconds) and deleted
only once the cloud acknowledged it; then the trip reports ``pacc ecu --cloud`` queued in
``DIR/reports`` are posted, each once its segments are up
(:mod:`cloud_sync.vehicle.uploader`). With ``--fetch`` the driver's newest signed table is
downloaded, verified against the trusted key and kept in ``DIR/profiles``; a served cloud
learns in the background, so ``--wait S`` first waits up to S s for the driver's learning job
to be idle (the batches just uploaded learned from). Exits 1 while a batch or a report stays
queued or one was set aside (``DIR/rejected``, ``DIR/reports/rejected``), so a timer can tell.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from cloud_sync.errors import CloudSyncError
from pacc.commands._args import fail, number


def _condition_hint(not_found: int) -> str:
    if not not_found:
        return ""
    return (
        " (conditions: 'default' for trips at the nominal condition factor 1, "
        "'factor-<f>' otherwise; --condition picks one)"
    )


def _do_sync(args: argparse.Namespace) -> int:
    from cloud_sync.api import is_plain_name  # noqa: PLC0415
    from cloud_sync.signing import load_public_key  # noqa: PLC0415
    from cloud_sync.vehicle.connect import connect, read_token  # noqa: PLC0415
    from cloud_sync.vehicle.download import ProfileDownloader  # noqa: PLC0415
    from cloud_sync.vehicle.link import VehicleLink  # noqa: PLC0415
    from cloud_sync.vehicle.spool import Spool  # noqa: PLC0415

    if args.fetch and not args.trust:
        return fail("pacc cloud sync", "--fetch needs --trust KEY.pub (the cloud's public key)")
    if args.wait and not args.fetch:
        return fail("pacc cloud sync", "--wait waits to --fetch a table: give --fetch DRIVER")
    for option, name in (("--fetch", args.fetch), ("--condition", args.condition)):
        if name is not None and not is_plain_name(name):
            return fail(
                "pacc cloud sync", f"{option} {name!r}: not a plain name (letters, digits, _.-)"
            )
    try:
        spool = Spool(args.spool, quota_bytes=int(args.quota_mb * 1024 * 1024))
        for path in args.add:
            batch = spool.put_file(path)
            print(f"spooled {path}: {batch.kind} batch {batch.seq} ({batch.digest[:12]})")
        cloud = connect(args.cloud, read_token(args.token_file))
        downloader = None
        if args.fetch:
            key = load_public_key(args.trust)
            downloader = ProfileDownloader(cloud, key, spool.root / "profiles")
        link = VehicleLink(cloud, spool, None, downloader=downloader)
    except (CloudSyncError, OSError) as exc:
        return fail("pacc cloud sync", exc, 1)
    if spool.stats.quarantined:
        print(
            f"pacc cloud sync: warning: {spool.stats.quarantined} file(s) in {args.spool} are "
            f"not spool batches (name or digest): moved to {args.spool}/quarantine/",
            file=sys.stderr,
        )
    code = _upload(link, args.retry_s)
    if downloader is not None:
        return _fetch(args, link, downloader) or code
    return code


def _upload(link: Any, retry_s: float) -> int:
    """One upload pass of the spool and its reports, for up to ``retry_s`` s, said; 0 when
    nothing stays queued and nothing was set aside, else 1."""
    uploader = link.drain(retry_s, backoff_max_s=min(retry_s, 30.0))
    left = link.spool.pending()
    stats = uploader.stats
    print(
        f"uploaded {stats.sent} batch(es) ({stats.duplicates} already held), "
        f"{stats.rejected} rejected, {len(left)} still spooled"
    )
    if stats.held and stats.last_held:
        print(f"pacc cloud sync: batches kept: {stats.last_held}", file=sys.stderr)
    reports = uploader.reports
    queued = reports.pending()
    if reports.stats.sent or reports.stats.rejected or queued:  # pacc ecu --cloud's trips
        print(
            f"trip reports: {reports.stats.sent} sent, {reports.stats.rejected} refused "
            f"(in {reports.root}/rejected), {len(queued)} still queued"
        )
    if reports.stats.held and reports.stats.last_held:
        print(f"pacc cloud sync: trip reports kept: {reports.stats.last_held}", file=sys.stderr)
    refused = stats.rejected or reports.stats.rejected
    return 0 if not left and not refused and not queued else 1


def _fetch(args: argparse.Namespace, link: Any, downloader: Any) -> int:
    """Download and verify ``--fetch``'s table (after ``--wait``); 0 or 1."""
    if args.wait:
        try:  # the cloud learns in the background: let it finish with what was just uploaded
            link.cloud.wait_learned(args.fetch, args.condition, timeout_s=args.wait)
        except CloudSyncError as exc:
            print(f"pacc cloud sync: warning: {exc}", file=sys.stderr)
    table = link.table(args.fetch, args.condition)
    if table is None:
        hint = _condition_hint(downloader.report.not_found)
        why = f"no usable table for {args.fetch}/{args.condition}: "
        return fail("pacc cloud sync", why + downloader.report.describe() + hint, 1)
    print(
        f"DGPT {table.driver_id}/{table.condition} v{table.version} verified, kept in "
        f"{downloader.cache_path(args.fetch, args.condition)}"
    )
    return 0


def add_subparser(subparsers: Any) -> None:
    """Register ``sync`` on the ``pacc cloud`` parser."""
    p = subparsers.add_parser(
        "sync",
        help="spool trip logs, upload the spool and its queued trip reports once",
        description="Spool trip logs, upload the spool's batches, then post the trip reports "
        "pacc ecu --cloud queued in SPOOL/reports (each once its segments are up). "
        "Exits 1 while anything stays queued or was set aside.",
    )
    p.add_argument("--spool", required=True, help="the vehicle's spool folder")
    p.add_argument("--cloud", required=True, help="the service URL, or a folder (embedded)")
    p.add_argument("--token-file", required=True, help="file holding the vehicle's token")
    p.add_argument("--add", nargs="*", default=[], help="MCAP trip logs to spool first")
    p.add_argument("--quota-mb", type=number(0.0, 2.0**20, lo_open=True), default=256.0)
    p.add_argument("--retry-s", type=number(0.0, 86400.0), default=60.0, help="give up after, s")
    p.add_argument("--fetch", metavar="DRIVER", help="download this driver's newest table")
    p.add_argument("--condition", default="default", help="driving condition of --fetch")
    p.add_argument("--trust", help="the cloud's public key (PEM) to verify --fetch with")
    p.add_argument("--wait", type=number(0.0, 86400.0), default=0.0, help="learning wait, s")
    p.set_defaults(func=_do_sync)
