"""Benchmark: a 300-s closed-loop drive on the lockstep bus, against the virtual bus.

Run: ``python bench/drive.py [--scenario B] [--driver d2] [--controller ...]`` from the root.

- drive: ``pacc.study.drive.run_drive`` — the full ECU (EcuNode + EcuRuntime, DBC codec, E2E)
  and the simulator (plant, driver, bus node), 300 s of scenario B, simulated seconds per
  wall second, on the lockstep bus (:mod:`dbc.lockstep`, the default) and on python-can's
  virtual bus (the named peer, ``--bus virtual``), alternating, best of ROUNDS each;
- bare bus (the old ceiling): the same frames at the same DBC periods on python-can's virtual
  bus, packed with ``struct`` plus a table CRC-8, received and checked, no logic at all;
- where the lockstep drive's CPU time goes: the ECU's control step, the world (plant and
  driver), the rest (bus, codec, E2E, the nodes' I/O, clocks);
- a cProfile of a 60-s drive on the lockstep bus (top functions by own time).

The last line is ``drive: R x the virtual bus`` (goal >= 2.5, and the drive faster than the
bare bus).

``--compiled`` runs the same bench on a copy of pacc whose per-frame path is compiled with
mypyc (``python -m tools.compile``: built into ``build/compiled`` first, rebuilt when a
source changed; needs gcc and Python's headers), after the line of this, pure, build. The
first line says which build was measured.

``--plugins`` instead times the same drive with the built-ins called directly
against the same built-ins through the guarded plug-in interface (``--gap-controller pid
--adaptation timegap``) and a trivial plug-in controller, interleaved, the median of
``--repeats`` drives each; the last line is ``plug-in interface: +N % drive time``.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import math
import os
import pstats
import statistics
import struct
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import can

import dbc.endpoint
import dbc.message
from dbc.codec import load_codec
from dbc.e2e import CRC8_TABLE
from dbc.vocab.dgpt import Dgpt
from ecu.node import EcuNode
from pacc.study.drive import BUSES, DriveConfig, DriveResult, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams
from sim_bus.faults import ROLES as TX_ROLES
from sim_bus.world import World

_ROOT = str(Path(__file__).resolve().parent.parent)
SIM_S = 300.0
#: alternating runs of each bus (the best of each is reported: a shared machine's load)
ROUNDS = 3
TICK_S = 0.01
#: roles the ECU sends (the simulator's are sim_bus.node.TX_ROLES)
ECU_ROLES = ("command", "status")
#: the bare bus's own 8-byte layout, CRC first: a peer with no codec, not the DBC's layout
_PACK = struct.Struct("<BBHhh")


def build_name() -> str:
    """Which pacc this process runs: the pure-Python package, or a compiled copy (mypyc
    extension modules, ``tools/compile.py``) and where it lies."""
    where = Path(dbc.endpoint.__file__)
    if where.suffix == ".py":
        return f"pure Python ({where.parent.parent})"
    codecs = "its codecs too" if dbc.message.compiled_codecs() else "its codecs NOT loaded"
    return f"compiled with mypyc ({where.parent.parent}; {codecs})"


def compiled_run(argv: list[str]) -> int:
    """Build the compiled copy (``python -m tools.compile``) and run this bench, ``argv``
    less ``--compiled``, on it; its exit status."""
    out = Path(_ROOT) / "build" / "compiled"
    sys.stdout.flush()  # this build's lines before the child's
    subprocess.run(
        [sys.executable, "-m", "tools.compile", "--out", str(out)], cwd=_ROOT, check=True
    )
    env = {**os.environ, "PYTHONPATH": str(out)}
    args = [a for a in argv if a != "--compiled"]
    return subprocess.run([sys.executable, __file__, *args], env=env, check=False).returncode


def schedule(roles: tuple[str, ...]) -> tuple[tuple[int, int], ...]:
    """(frame id, every n ticks) of ``roles``, read from the packaged DBC."""
    codec = load_codec()
    return tuple(
        (codec.by_role[r].frame_id, max(1, round(codec.by_role[r].cycle_s / TICK_S))) for r in roles
    )


def _crc(data: bytes | bytearray) -> int:
    c = 0xFF
    for b in data[1:]:
        c = CRC8_TABLE[c ^ b]
    return c ^ 0xFF


def _frame(frame_id: int, counter: int, value: int, t: float) -> can.Message:
    body = bytearray(_PACK.pack(0, counter << 0 & 0x0F, value & 0xFFFF, 0, 0))
    body[0] = _crc(body)
    return can.Message(arbitration_id=frame_id, data=body, is_extended_id=False, timestamp=t)


def _drain(bus: can.BusABC) -> int:
    n = 0
    while (m := bus.recv(0.0)) is not None:
        if _crc(m.data) != m.data[0]:
            raise RuntimeError("CRC")
        _PACK.unpack(m.data)
        n += 1
    return n


def bare_bus(seconds: float = SIM_S) -> tuple[float, float]:
    """Simulated seconds per wall second of the bare bus (struct codec, table CRC), and the
    CPU time it took (s)."""
    sim_frames = schedule(TX_ROLES)
    ecu_frames = schedule(ECU_ROLES)
    a = can.Bus(interface="virtual", channel="bench-bare", preserve_timestamps=True)
    b = can.Bus(interface="virtual", channel="bench-bare", preserve_timestamps=True)
    counters = [0] * (len(sim_frames) + len(ecu_frames))
    try:
        start, cpu = time.perf_counter(), time.process_time()
        for tick in range(int(round(seconds / TICK_S))):
            t = tick * TICK_S
            _drain(a)
            for k, (fid, every) in enumerate(sim_frames):
                if tick % every == 0:
                    counters[k] = (counters[k] + 1) & 0xF
                    a.send(_frame(fid, counters[k], tick, t))
            _drain(b)
            for k, (fid, every) in enumerate(ecu_frames, start=len(sim_frames)):
                if tick % every == 0:
                    counters[k] = (counters[k] + 1) & 0xF
                    b.send(_frame(fid, counters[k], tick, t))
        wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    finally:
        a.shutdown()
        b.shutdown()
    return seconds / wall, cpu


def breakdown(cfg: DriveConfig, driver: DriverParams, table: Dgpt) -> dict[str, float]:
    """CPU seconds of one lockstep drive of ``cfg``: the whole drive, the ECU's control step
    (``EcuNode.step``: state machine, plan, control law) and the world (plant and driver),
    each timed by a wrapper around it (a little of the wrapper's cost included)."""
    spent = {"ECU control step": 0.0, "world (plant, driver)": 0.0}
    saved = EcuNode.step, World.advance

    def timed(f: Any, key: str) -> Any:
        def wrapper(*args: Any) -> Any:
            c0 = time.process_time()
            try:
                return f(*args)
            finally:
                spent[key] += time.process_time() - c0

        return wrapper

    EcuNode.step = timed(EcuNode.step, "ECU control step")  # type: ignore[method-assign]
    World.advance = timed(World.advance, "world (plant, driver)")  # type: ignore[method-assign]
    try:
        c0 = time.process_time()
        run_drive(cfg, driver, table, bus="lockstep")
        total = time.process_time() - c0
    finally:
        EcuNode.step, World.advance = saved  # type: ignore[method-assign]
    return {"drive": total, **spent}


def _short_paths(line: str) -> str:
    """A profile line with the repository and site-packages prefixes cut."""
    for prefix in (*(p + "/" for p in sys.path if p.endswith("site-packages")), _ROOT + "/"):
        line = line.replace(prefix, "")
    return line


class TrivialController:
    """The cheapest gap law: a constant request (the interface's cost, nothing else)."""

    def desired_accel(self, obs: object, memory: float, dt_s: float) -> tuple[float, float]:
        return 0.0, memory


def plugin_overhead(scenario: str, driver_id: str, controller: str, repeats: int) -> float:
    """Print the median CPU time of a drive direct / through the interface; the relative cost."""
    driver = BUILTIN_DRIVERS[driver_id]
    table = predefined_table(driver)
    base = DriveConfig(scenario=scenario, driver_id=driver_id, controller=controller, seed=0)  # type: ignore[arg-type]
    variants = {
        "built-ins called directly": base,
        "built-ins through the interface": replace(
            base, gap_controller="pid", adaptation_method="timegap"
        ),
        "trivial plug-in controller": replace(base, gap_controller="__main__:TrivialController"),
    }
    walls: dict[str, list[float]] = {k: [] for k in variants}
    metrics = {}
    for _ in range(repeats):
        for name, cfg in variants.items():
            cpu = time.process_time()  # CPU time: a loaded host's preemption does not count
            r = run_drive(cfg, driver, table)
            walls[name].append(time.process_time() - cpu)
            metrics[name] = r.metrics.as_dict()
    same = metrics["built-ins called directly"] == metrics["built-ins through the interface"]
    direct = statistics.median(walls["built-ins called directly"])
    for name, w in walls.items():
        each = ", ".join(f"{x:.3f}" for x in w)
        print(f"{name:<34} median {statistics.median(w):.3f} s CPU of {repeats} ({each})")
    print(f"metrics identical direct vs interface: {same}")
    cost = statistics.median(walls["built-ins through the interface"]) / direct - 1.0
    print(f"plug-in interface: {100 * cost:+.1f} % drive time")
    return cost


def main(argv: list[str] | None = None) -> int:
    """Print the drive on each bus, the bare-bus ceiling, a profile; last line the ratio."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    p.add_argument("--scenario", default="B")
    p.add_argument("--driver", default="d2")
    p.add_argument("--controller", default="predefined+oa")
    p.add_argument("--top", type=int, default=16, help="profile lines (0: no profile)")
    p.add_argument("--rounds", type=int, default=ROUNDS, help="alternating runs of each bus")
    p.add_argument("--plugins", action="store_true", help="time the plug-in interface only")
    p.add_argument("--repeats", type=int, default=5, help="drives per variant (--plugins)")
    p.add_argument(
        "--compiled",
        action="store_true",
        help="also run on a mypyc-compiled copy (tools/compile.py)",
    )
    args = p.parse_args(argv)
    if args.compiled:  # this (pure) build first, then the compiled copy
        given = sys.argv[1:] if argv is None else argv
        main([a for a in given if a != "--compiled"])
        return compiled_run(given)
    print(f"build: {build_name()}")
    if args.plugins:
        plugin_overhead(args.scenario, args.driver, args.controller, args.repeats)
        return 0
    driver = BUILTIN_DRIVERS[args.driver]
    table = predefined_table(driver)
    cfg = DriveConfig(
        scenario=args.scenario, driver_id=driver.driver_id, controller=args.controller, seed=0
    )
    for bus in BUSES:  # warm-up
        run_drive(DriveConfig(scenario=args.scenario, duration_s=5.0), driver, table, bus=bus)
    best: dict[str, DriveResult] = {}
    cpu: dict[str, float] = {}
    bare, bare_cpu = 0.0, math.inf
    for _ in range(args.rounds):
        rate, used = bare_bus()
        bare, bare_cpu = max(bare, rate), min(bare_cpu, used)
        for bus in BUSES:
            c0 = time.process_time()
            result = run_drive(cfg, driver, table, bus=bus)
            cpu[bus] = min(cpu.get(bus, math.inf), time.process_time() - c0)
            if bus not in best or result.wall_s < best[bus].wall_s:
                best[bus] = result
    print(
        f"bare bus (virtual, struct codec + table CRC, no logic): {bare:.0f}x real time "
        f"(best of {args.rounds}; CPU {bare_cpu:.2f} s)"
    )
    for bus, result in best.items():
        print(
            f"drive on the {bus} bus ({args.scenario}, {args.driver}, {args.controller}, "
            f"{result.sim_s:.0f} s, {result.frames_sent} simulator frames, "
            f"{result.summary.frames_out} ECU frames): {result.realtime_factor:.0f}x real time "
            f"in {result.wall_s:.2f} s (best of {args.rounds}; CPU {cpu[bus]:.2f} s)"
        )
    lock, virt = best["lockstep"], best["virtual"]
    if lock.metrics != virt.metrics:
        raise SystemExit("the drives on the two buses differ")
    factor = lock.realtime_factor
    print(
        f"lockstep drive / bare virtual bus = {factor / bare:.2f} "
        f"(CPU time, bare / lockstep: {bare_cpu / cpu['lockstep']:.2f})"
    )
    print(
        f"CPU time, virtual / lockstep = {cpu['virtual'] / cpu['lockstep']:.2f} "
        "(the whole drive: setup, simulation, ECU; a loaded machine's wall times vary more)"
    )
    if build_name().startswith("pure"):
        parts = min(
            (breakdown(cfg, driver, table) for _ in range(args.rounds)), key=lambda d: d["drive"]
        )
        total = parts.pop("drive")
        shares = ", ".join(f"{k} {100 * v / total:.0f} %" for k, v in parts.items())
        rest = 100 * (1 - sum(parts.values()) / total)
        print(
            f"the lockstep drive's CPU time ({total:.2f} s, timed parts): {shares}, the rest "
            f"(bus, codec, E2E, the nodes' I/O, clocks) {rest:.0f} %"
        )
        if args.top > 0:
            profile(args, driver, table)
    else:  # compiled callers call EcuNode.step directly: no wrapper, no Python profile
        print("CPU split and profile: not measured on a compiled build")
    print(f"drive: {factor / virt.realtime_factor:.2f}x the virtual bus")
    return 0


def profile(args: argparse.Namespace, driver: DriverParams, table: Dgpt) -> None:
    """Print a cProfile of a 60-s lockstep drive: the top ``args.top`` functions by own time."""
    prof = cProfile.Profile()
    short = DriveConfig(
        scenario=args.scenario,
        driver_id=driver.driver_id,
        controller=args.controller,
        seed=0,
        duration_s=60.0,
    )
    prof.enable()
    run_drive(short, driver, table, bus="lockstep")
    prof.disable()
    buf = io.StringIO()
    pstats.Stats(prof, stream=buf).sort_stats("tottime").print_stats(args.top)
    lines = [ln for ln in buf.getvalue().splitlines() if ln.strip()]
    start = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith("ncalls"))
    print(
        f"profile of a 60-s drive on the lockstep bus (top {args.top} by own time, cProfile "
        "overhead included):"
    )
    for ln in lines[start:]:
        print("  " + _short_paths(ln))


if __name__ == "__main__":
    raise SystemExit(main())
