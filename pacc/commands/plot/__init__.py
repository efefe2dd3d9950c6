"""``pacc plot LOG [SIGNAL ...] -o fig.png``: one recorded drive over time.

LOG is a pacc bus recording (``.mcap`` or a killed recorder's ``.mcap.part``), a trip log, or
any log python-can reads, decoded with ``--dbc``. SIGNALs (``Message.signal``,
``/topic.field`` or a bare name) get a panel each; without them the fixed panels over time
(s): speeds, gap and desired gap, pedals, the ACC's request and state, takeovers marked. A
recording without the ECU's channels (``pacc sim``) is drawn from ``/sim/world``. Exit status:
0, 2 on a bad recording or one with nothing to draw.

The command is a package: :mod:`pacc.commands.plot.layout` (``--plotjuggler LAYOUT.xml``: a
PlotJuggler layout that opens the recording).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dbc.errors import DbcError, UsageError
from dbc.vocab import FormatError
from dbc.vocab.acc_state import AccState
from ecu import EcuError
from pacc.commands._args import CommandParser, check_distinct_outputs, fail, integer, same_file

if TYPE_CHECKING:  # numpy, MCAP and the readers are imported when drawing, not for --help
    import numpy as np

    from dbc.vocab.triplog import Trip
    from ecu.buslog.reader import CanLog


@dataclass(frozen=True)
class Traces:
    """The curves of one plot; arrays of shape ``(n,)`` on the time ``t_s``."""

    t_s: np.ndarray
    v_mps: np.ndarray
    v_lead_mps: np.ndarray
    gap_m: np.ndarray
    target_gap_m: np.ndarray
    target_label: str
    accel_pedal: np.ndarray
    brake_pedal: np.ndarray
    request_mps2: np.ndarray
    acc_state: np.ndarray
    source: str


def traces(log: CanLog) -> Traces:
    """The curves of ``log``: the ECU's inputs and outputs, else the simulated world.

    Raises:
        CanLogError: the recording holds neither.
    """
    import numpy as np  # noqa: PLC0415

    from ecu.buslog.format import (  # noqa: PLC0415
        INPUTS_TOPIC,
        OUTPUTS_TOPIC,
        WORLD_TOPIC,
        CanLogError,
    )

    if INPUTS_TOPIC in log.series and OUTPUTS_TOPIC in log.series:
        i, o = log.series[INPUTS_TOPIC], log.series[OUTPUTS_TOPIC]
        lead = i["lead_valid"] > 0
        return Traces(
            t_s=i["t_s"],
            v_mps=i["v_mps"],
            v_lead_mps=np.where(lead, i["v_mps"] + i["rel_speed_mps"], np.nan),
            gap_m=np.where(lead, i["gap_m"], np.nan),
            target_gap_m=o["desired_gap_m"],
            target_label="desired gap (DGPT)",
            accel_pedal=i["accel_pedal"],
            brake_pedal=i["brake_pedal"],
            request_mps2=np.where(o["request_active"] > 0, o["accel_request_mps2"], np.nan),
            acc_state=o["acc_state"],
            source="the ECU's inputs and outputs",
        )
    if WORLD_TOPIC in log.series:
        w = log.series[WORLD_TOPIC]
        return Traces(
            t_s=w["t_s"],
            v_mps=w["v_mps"],
            v_lead_mps=w["v_lead_mps"],
            gap_m=w["gap_m"],
            target_gap_m=w["pref_gap_m"],
            target_label="driver's preferred gap",
            accel_pedal=np.clip(w["accel_pct"] / 100.0, 0.0, 1.0),
            brake_pedal=(w["brake_pressed"] > 0).astype(np.float64),
            request_mps2=np.where(w["request_active"] > 0, w["a_request_mps2"], np.nan),
            acc_state=w["acc_state"],
            source="the simulated world",
        )
    raise CanLogError(
        f"{log.path}: nothing to plot (no {INPUTS_TOPIC}/{OUTPUTS_TOPIC} or {WORLD_TOPIC}; "
        f"topics: {', '.join(log.topics)})"
    )


def trip_traces(trip: Trip) -> Traces:
    """The fixed panels of a trip log."""
    import numpy as np  # noqa: PLC0415

    pref = trip.meta.get("pref_gap_m")
    n = len(trip.t_s)
    target = np.full(n, float(pref)) if isinstance(pref, int | float) else np.full(n, np.nan)
    return Traces(
        t_s=trip.t_s,
        v_mps=trip.v_mps,
        v_lead_mps=trip.v_lead_mps,
        gap_m=trip.gap_m,
        target_gap_m=target,
        target_label="driver's preferred gap" if isinstance(pref, int | float) else "",
        accel_pedal=trip.accel_pedal,
        brake_pedal=trip.brake_pedal,
        request_mps2=np.full(n, np.nan),
        acc_state=trip.acc_state.astype(np.float64),
        source="the bus, decoded through the binding"
        if trip.meta.get("mode") == "bus"
        else f"trip log of driver {trip.meta.get('driver_id', '?')}",
    )


def takeovers(log: CanLog | None, tr: Traces) -> list[float]:
    """Times of the driver's takeovers (node clock, s): the ECU's takeover events, else the
    changes from ACTIVE to OVERRIDE or OFF."""
    import numpy as np  # noqa: PLC0415

    if log is not None:
        marks = [t for t, text in log.events if "takeover" in text.lower() and np.isfinite(t)]
        if marks:
            return marks
    s = tr.acc_state
    active, after = int(AccState.ACTIVE), (int(AccState.OVERRIDE), int(AccState.OFF))
    hits = np.flatnonzero((s[:-1] == active) & np.isin(s[1:], after)) + 1
    return [float(tr.t_s[i]) for i in hits]


def _draw_fixed(fig: Any, tr: Traces, marks: list[float]) -> Any:
    t = tr.t_s - tr.t_s[0] if len(tr.t_s) else tr.t_s
    ax = fig.subplots(5, 1, sharex=True, height_ratios=(3, 3, 2, 2, 1.5))
    ax[0].plot(t, tr.v_mps, label="ego")
    ax[0].plot(t, tr.v_lead_mps, label="lead", alpha=0.8)
    ax[0].set_ylabel("speed, m/s")
    ax[1].plot(t, tr.gap_m, label="gap")
    if tr.target_label:
        ax[1].plot(t, tr.target_gap_m, label=tr.target_label, linestyle="--")
    ax[1].set_ylabel("gap, m")
    ax[2].plot(t, tr.accel_pedal, label="accelerator")
    ax[2].plot(t, tr.brake_pedal, label="brake")
    ax[2].set_ylabel("pedal, 0..1")
    ax[3].plot(t, tr.request_mps2, color="tab:purple")
    ax[3].axhline(0.0, color="grey", linewidth=0.5)
    ax[3].set_ylabel("request, m/s²")
    ax[4].step(t, tr.acc_state, where="post", color="black")
    ax[4].set_yticks([int(s) for s in AccState], [s.name for s in AccState], fontsize=7)
    ax[4].set_ylabel("ACC")
    for a in ax[:3]:
        a.legend(loc="upper right", fontsize=8)
    t0 = tr.t_s[0] if len(tr.t_s) else 0.0
    for a in ax:
        for m in marks:
            a.axvline(m - t0, color="tab:red", linewidth=0.8, alpha=0.6)
    return ax


def _draw_signals(fig: Any, curves: list[tuple[str, np.ndarray, np.ndarray]], t0: float) -> Any:
    ax = fig.subplots(len(curves), 1, sharex=True, squeeze=False)[:, 0]
    for a, (label, t, y) in zip(ax, curves, strict=True):
        a.plot(t - t0, y)
        a.set_ylabel(label, fontsize=8)
    return ax


def signal_curves(log: CanLog, signals: Sequence[str]) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(axis label: the name and its unit, t_s, values) of each of ``signals`` (:func:`pick`)."""
    curves = []
    for name in signals:
        label, t, y = pick(log, name)
        unit = unit_of(log, label)
        curves.append((f"{label}, {unit}" if unit else label, t, y))
    return curves


def unit_of(log: CanLog, label: str) -> str:
    """The unit of the signal ``label`` as :func:`pick` names it: a decoded frame's signal in
    the recording's DBC's unit (else the binding's, for a signal the DBC gives none), an
    internal in its field name's (``gap_m`` m, ``v_mps`` m/s: :mod:`dbc.units`); "" if none."""
    from dbc.units import logical_unit  # noqa: PLC0415
    from ecu.buslog.replay import codec_of  # noqa: PLC0415 - the DBC only for a signal's unit

    message, _, name = label.rpartition(".")
    if message.startswith("/"):
        return logical_unit(name) or ""
    codec = codec_of(log)
    try:
        unit = codec.db.get_message_by_name(message).get_signal_by_name(name).unit
    except KeyError:
        return ""
    if not unit:
        fields = [
            f
            for role in codec.binding.roles.values()
            for part in role.parts
            if part.message == message
            for f in part.fields.values()
            if f.signal == name and f.unit
        ]
        unit = fields[0].unit if fields else ""
    return str(unit or "")


def plot(
    log: CanLog | None,
    out: Path,
    dpi: int = 120,
    signals: Sequence[str] = (),
    trip: Trip | None = None,
    title: str = "",
) -> None:
    """Draw ``log`` (its ``signals``, else the fixed panels of :func:`traces`) or ``trip``
    into the PNG ``out``."""
    from matplotlib.figure import Figure  # noqa: PLC0415 - matplotlib only when drawing

    fig = Figure(figsize=(10, 9), constrained_layout=True)
    if signals and log is not None:
        curves = signal_curves(log, signals)
        t0 = min((float(c[1][0]) for c in curves if len(c[1])), default=0.0)
        ax = _draw_signals(fig, curves, t0)
        source = "selected signals"
    else:
        tr = trip_traces(trip) if trip is not None else traces(log)  # type: ignore[arg-type]
        ax = _draw_fixed(fig, tr, takeovers(log, tr))
        source = tr.source
    ax[-1].set_xlabel("time since the start of the recording, s")
    for a in ax:
        a.grid(alpha=0.3)
    fig.suptitle(f"{title} ({source})", fontsize=10)
    fig.savefig(out, dpi=dpi, format="png")


def pick(log: CanLog, name: str) -> tuple[str, np.ndarray, np.ndarray]:
    """(label, t_s, values) of the signal ``name``: ``Message.signal``, ``/topic.field`` or a
    bare name found in exactly one place; CanLogError otherwise.
    """
    import numpy as np  # noqa: PLC0415

    from ecu.buslog.format import CanLogError  # noqa: PLC0415

    tables = {f"{m}.": cols for m, cols in log.decoded.items()}
    tables.update({f"{topic}.": cols for topic, cols in log.series.items()})
    for prefix, cols in tables.items():
        if name.startswith(prefix) and name[len(prefix) :] in cols:
            return name, cols["t_s"], np.asarray(cols[name[len(prefix) :]], dtype=np.float64)
    hits = [p + name for p, cols in tables.items() if name in cols and name != "t_s"]
    if len(hits) == 1:
        return pick(log, hits[0])
    where = ", ".join(hits) if hits else "none of its messages and channels"
    raise CanLogError(f"{log.path}: signal {name!r} is in {where}")


def load(path: Path, dbc: str | None, warn: Any) -> tuple[CanLog | None, Trip | None]:
    """The recording or trip log at ``path``; any other log through python-can and ``dbc``."""
    import tempfile  # noqa: PLC0415

    from dbc.vocab.triplog_file import read_trip  # noqa: PLC0415
    from ecu.buslog.format import CanLogError  # noqa: PLC0415
    from ecu.buslog.reader import read_canlog, read_recording  # noqa: PLC0415
    from pacc.commands.export import convert  # noqa: PLC0415

    if path.name.endswith((".mcap", ".mcap.part")):
        try:
            return read_recording(path, warn), None
        except CanLogError as exc:
            if "not a pacc bus recording" not in str(exc):
                raise
        return None, read_trip(path)
    with tempfile.TemporaryDirectory(prefix="pacc-plot-") as tmp:
        mcap = Path(tmp) / "log.mcap"
        convert(path, mcap, dbc)
        return read_canlog(mcap), None


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="pacc plot", description="plot one recorded drive over time")
    p.add_argument("log", type=Path, metavar="LOG", help="a recording, trip log or python-can log")
    p.add_argument("signals", nargs="*", metavar="SIGNAL", help="Message.signal, /topic.field")
    p.add_argument("-o", "--out", type=Path, help="the PNG to write")
    p.add_argument("--plotjuggler", type=Path, metavar="LAYOUT", help="a PlotJuggler layout .xml")
    p.add_argument("--dbc", help="a foreign log: decode it with this DBC (default: pacc's)")
    p.add_argument("--binding", help="a foreign log: the fixed panels through this binding")
    p.add_argument("--dpi", type=integer(10, 1200), default=120, help="resolution (default 120)")
    return p


def _bus_trip(args: argparse.Namespace) -> Trip:
    """A foreign log decoded through ``--binding`` as one trip (the fixed panels)."""
    from cloud_sync.irl.sources.bus_demos import bus_trip, read_frames  # noqa: PLC0415
    from dbc.codec import load_codec, network_paths  # noqa: PLC0415

    codec = load_codec(*network_paths(args.dbc, args.binding))
    return bus_trip(read_frames(args.log), codec, {"log": args.log.name})


def _write_layout(path: Path, log: CanLog | None, layout: Path) -> None:
    """Write the PlotJuggler layout of the recording ``path`` to ``layout`` and say so."""
    from ecu.buslog.format import CanLogError  # noqa: PLC0415
    from pacc.commands.plot.layout import layout_xml, recording_series  # noqa: PLC0415

    if log is None or not path.name.endswith(".mcap"):
        raise CanLogError(
            f"{path}: PlotJuggler opens pacc's .mcap recordings; convert this log first "
            f"(pacc export {path.name} LOG.mcap)"
        )
    text = layout_xml(path, layout, recording_series(log.decoded, log.series))
    layout.write_text(text, encoding="utf-8")
    print(f"plotjuggler layout: {layout} (plotjuggler -l {layout})")


def _warn(text: str) -> None:
    print(f"pacc plot: warning: {text}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc plot``; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.out is None and args.plotjuggler is None:
        parser.error("give -o OUT.png, --plotjuggler LAYOUT.xml, or both")
    png = (
        None if args.out is None else args.out if args.out.suffix else args.out.with_suffix(".png")
    )
    try:
        if png is not None and png.suffix.lower() != ".png":
            raise UsageError(f"-o {png}: pacc plot writes a PNG; name it .png")
        check_distinct_outputs(out=png, plotjuggler=args.plotjuggler)
        for option, path in (("-o", png), ("--plotjuggler", args.plotjuggler)):
            if path is not None and same_file(path, args.log):
                raise UsageError(f"{option} {path} is LOG itself: it would overwrite the recording")
    except UsageError as exc:
        parser.error(str(exc))
    from ecu.buslog.format import CanLogError  # noqa: PLC0415

    try:
        log, trip = load(args.log, args.dbc, _warn)
        if args.plotjuggler is not None:
            _write_layout(args.log, log, args.plotjuggler)
        if png is None:
            return 0
        out: Path = png
        if log is not None and args.binding and not args.signals:
            trip, log = _bus_trip(args), None
        if trip is not None and args.signals:
            raise CanLogError(f"{args.log}: a trip log has no signals to pick; drop SIGNAL")
        kind = trip.meta.get("mode") if trip is not None else None
        node = log.node if log is not None else "bus" if kind == "bus" else "trip"
        start = log.metadata.get("pacc", {}).get("start_utc", "?") if log is not None else "?"
        plot(log, out, args.dpi, args.signals, trip, f"{args.log.name}: {node} from {start} UTC")
    except (EcuError, FormatError, DbcError, OSError, ValueError) as exc:
        return fail("pacc plot", exc)
    print(f"plot: {out}")
    return 0
