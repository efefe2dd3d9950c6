# ruff: noqa: E501 - the table holds the documents' commands as printed
"""Every command printed in README.md and docs/*.md, run as printed.

:func:`doc_commands` reads the ```sh blocks (continuation lines joined, comments dropped).
:data:`PLANS` says, per document, what becomes of each of its commands, in order:

- ``run(check)``: run exactly as printed, in a scratch folder shared by the document's
  commands (so a recipe's later command reads what an earlier one wrote); ``check`` is a
  regular expression its output must match.
- ``short(command, check, why)``: a long command (a 300-s drive, a whole study) is run as the
  shortened equivalent given, and why is said.
- ``skip(why)``: a command this machine cannot run (SocketCAN, a Dask cluster, a server on a
  fixed port, the network, a placeholder like HOST); ``why`` names the test that covers it.

The fast test checks that every printed command has a plan and every plan a command (a doc
edit without its plan fails); the slow tests run each document's plan. There each ``pacc ...``
runs in the test's interpreter (:func:`pacc.cli.main`, what the console script calls, its
words and globs as sh expands them), sparing each its start-up (~0.5 s, most of a command's
time); ``mkdir``, ``python`` run in a shell; tests/pacc/test_cli.py runs the console script.
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from pacc import cli

ROOT = Path(__file__).resolve().parents[1]
DOCS = ["README.md", *sorted(str(p.relative_to(ROOT)) for p in (ROOT / "docs").glob("*.md"))]


def doc_commands(text: str) -> list[str]:
    """The commands of the ```sh blocks of a Markdown ``text``, in order: a trailing ``\\``
    joins the next line, ``# ...`` comments and comment-only lines are dropped, runs of
    spaces (aligned columns) become one."""
    commands: list[str] = []
    for block in re.findall(r"```(?:sh|bash|shell)\n(.*?)```", text, re.S):
        current = ""
        for raw in block.split("\n"):
            line = raw.rstrip()
            if not line.strip() or line.lstrip().startswith("#"):
                continue
            code = " ".join(re.sub(r"\s+#.*$", "", line).split())  # aligned columns: one space
            if current.endswith("\\"):
                current = current[:-1].rstrip() + " " + code
                continue
            if current:
                commands.append(current)
            current = code
        if current:
            commands.append(current)
    return commands


@dataclass(frozen=True)
class Plan:
    """What the recipe test does with one printed command (see the module docstring)."""

    command: str
    kind: str  # run, short, skip
    check: str = ""
    instead: str = ""
    why: str = ""


def run(command: str, check: str) -> Plan:
    return Plan(command, "run", check)


def short(command: str, instead: str, check: str, why: str) -> Plan:
    return Plan(command, "short", check, instead, why)


def skip(command: str, why: str) -> Plan:
    return Plan(command, "skip", why=why)


VCAN = "no SocketCAN in CI; the same options on a virtual bus: "
HIL = "a person at a browser page; a scripted participant in headless chromium: "
SERVER = "a server on a fixed port; tests/cloud_sync/test_cloud_api.py serves the app on an ephemeral one"
DASK = "needs a Dask cluster; tests/cloud_sync/test_engine.py runs a LocalCluster"
TOYOTA_DRIVE = "pacc drive --dbc toyota_nodsu_pt_generated.dbc --binding toyota_nodsu"

PLUGIN_DRIVE = (
    "pacc drive --controller irl+oa --adaptation bayes --gap-controller "
    "pacc_testplugins:TimeGapController"
)
#: README's study.toml: one driver, one scenario, two methods (a plug-in controller), 10-s drives
STUDY_TOML = """trials = 1
duration_s = 10.0
workers = 1
[drivers]
builtin = ["d2"]
[scenarios]
names = ["B"]
[[methods]]
table = "predefined"
adaptation = ["none", "bayes"]
controller = "test-timegap"
"""

#: document -> (set-up commands run first, then one plan per printed command, in order)
PLANS: dict[str, tuple[list[str], list[Plan]]] = {
    "README.md": (
        ["ln -s {root}/dbc dbc", "printf '%s' '" + STUDY_TOML + "' > study.toml"],
        [
            skip("make demo", "CI runs make test; make demo is the 1-min study of 120 drives (docs/study.md)"),
            skip("make test", "what CI runs"),
            short(
                "pacc drive --scenario B --driver d3 --controller irl+oa --seed 1 --log run.mcap",
                "pacc drive --scenario B --driver d3 --controller irl+oa --seed 1 --log run.mcap"
                " --duration 30",
                r"controller irl\+oa.*\n(.*\n)*  log            run\.mcap",
                "30 s of the 300-s drive",
            ),
            short(
                "pacc drive ... --can-log drive.mcap",
                "pacc drive --duration 10 --can-log drive.mcap",
                r"bus recording  drive\.mcap",
                "10 s",
            ),
            run("pacc replay drive.mcap --ecu", r"ECU sent +\d+ frames"),
            run("pacc export drive.mcap drive.blf", r"\d+ frames: drive\.mcap -> drive\.blf"),
            run("pacc plot drive.mcap -o drive.png", r"plot: drive\.png"),
            short(
                "pacc study --trials 3 --out out/study",
                "pacc study --drivers d1 --scenarios A --controllers predefined --trials 1 "
                "--duration 20 --out out/study -q",
                r"1 drives in [0-9.]+ s; outputs in out/study/",
                "one 20-s drive of the study (make demo runs it whole)",
            ),
            skip(
                "pacc study --population 100 --seed 2 --out out/pop",
                "hours; tests/pacc/test_study_population.py runs a small population",
            ),
            skip(
                "pacc validate people out/pop/drives.csv --plot people.png",
                "needs the population above; tests/pacc/test_validate.py runs it on a small one",
            ),
            skip(
                "pacc validate following --plot following.png",
                "about 12 min of fitting; tests/pacc/test_validate.py fits one pair",
            ),
            skip(
                "pacc hil --participant P01 --protocol paper --out sessions/",
                "a person at a browser; tests/hil/test_protocol.py drives a shortened protocol "
                "with a scripted participant in headless chromium",
            ),
            run("pacc plugins --check", r"bayes +built-in +ecu\.methods\.bayes:BayesAdaptation +ok"),
            short(
                PLUGIN_DRIVE,
                PLUGIN_DRIVE + " --duration 20",
                r"controller irl\+oa(.*\n)*  collisions     0",
                "20 s of the 300-s drive",
            ),
            run("pacc study --config study.toml --out out/mine", r"2 drives in [0-9.]+ s; outputs in out/mine/"),
            run(
                "pacc study --config out/mine/manifest.json --out out/again",
                r"2 drives in [0-9.]+ s; outputs in out/again/",
            ),
            skip(
                "pacc bench --seeds 2 --out out/bench",
                "a minute even shortened; tests/pacc/test_bench.py::"
                "test_a_small_bench_stores_its_seeds_writes_the_board_and_resumes runs a small one",
            ),
            skip(
                "pacc ecu -i socketcan -c vcan0 --headway 1.5 --set-speed 40 --driver d2 "
                "--takeovers spool/ --manual spool/",
                VCAN + "tests/pacc/test_data_loss.py::test_readme_takeover_flow_uploads_every_segment"
                " and tests/ecu/test_cli_manual.py::test_ecu_spools_the_manual_driving",
            ),
            skip(
                "pacc sim -i socketcan -c vcan0 --scenario B --driver d2",
                VCAN + "tests/sim_bus/test_two_processes.py",
            ),
            run(
                "mkdir -p trips && pacc drive --manual --scenario manual1 --driver d2 --log trips/m1.mcap",
                r"manual drive: scenario manual1, driver d2 by hand",
            ),
            run(
                "pacc cloud learn --demos trips/*.mcap --driver d2 -o d2.json --plot d2.png",
                r"driver d2 \(default\): DGPT v1 -> d2\.json(.*\n)*plot -> d2\.png",
            ),
            run(
                "pacc cloud register --data cloud/ --vehicle car1 --driver d2 "
                "--token-file car1.token",
                r"vehicle car1 registered \(drivers: d2\)\ntoken written to car1\.token\n"
                r"the vehicle trusts the key cloud/keys/cloud\.pub",
            ),
            skip("pacc cloud serve --data cloud/ --port 8080", SERVER),
            short(
                "pacc cloud sync --spool spool/ --cloud http://127.0.0.1:8080 --token-file "
                "car1.token --add trips/*.mcap",
                "pacc cloud sync --spool spool/ --cloud cloud/ --token-file car1.token "
                "--add trips/*.mcap",
                r"spooled trips/m1\.mcap: manual batch 1(.*\n)*uploaded 1 batch\(es\)",
                "the embedded cloud (cloud/) instead of the server on port 8080",
            ),
        ],
    ),
    "docs/cloud.md": (
        [],
        [
            run(
                "mkdir -p trips && pacc drive --manual --scenario manual1 --driver d1 "
                "--log trips/m1.mcap",
                r"trips/m1\.mcap",
            ),
            run(
                "pacc cloud register --data cloud/ --vehicle car1 --driver d1 --driver d2 "
                "--token-file car1.token",
                r"vehicle car1 registered \(drivers: d1, d2\)",
            ),
            skip("pacc cloud serve --data cloud/ --host 127.0.0.1 --port 8080 --workers 1", SERVER),
            short(
                "pacc cloud sync --spool spool/ --cloud http://127.0.0.1:8080 --token-file "
                "car1.token --add trips/*.mcap --fetch d1 --trust cloud/keys/cloud.pub --wait 120",
                "pacc cloud sync --spool spool/ --cloud cloud/ --token-file car1.token "
                "--add trips/*.mcap --fetch d1 --trust cloud/keys/cloud.pub --wait 120",
                r"uploaded 1 batch\(es\)(.*\n)*DGPT d1/default v1 verified",
                "the embedded cloud instead of the server on port 8080 (tests/cloud_sync/"
                "test_cloud_cmds.py waits on a served one)",
            ),
            run(
                "pacc cloud sync --spool spool/ --cloud cloud/ --token-file car1.token",
                r"uploaded 0 batch\(es\) \(0 already held\), 0 rejected, 0 still spooled",
            ),
            run(
                "pacc cloud vehicle --data cloud/ --vehicle car1 --driver d3",
                r"vehicle car1: driver\(s\) d3 added",
            ),
            run(
                "pacc cloud vehicle --data cloud/ --vehicle car1 --new-token car1.token --force",
                r"new token written to car1\.token",
            ),
            run(
                "pacc cloud vehicle --data cloud/ --vehicle car1 --revoke",
                r"vehicle car1: token revoked",
            ),
            run(
                "pacc cloud register --data lab/ --vehicle lab --driver d1 --driver d3 "
                "--token-file lab.token",
                r"vehicle lab registered \(drivers: d1, d3\)",
            ),
            skip(
                "pacc cloud serve --data lab/ --port 8080 --operator-token-file operator.token",
                SERVER + "; tests/cloud_sync/test_trips.py runs a study against a served cloud",
            ),
            short(
                "pacc study --drivers d1,d3 --incremental 5 --duration 60 --seed 2 "
                "--out study-out/ --cloud http://127.0.0.1:8080 --token-file lab.token "
                "--trust lab/keys/cloud.pub",
                "pacc study --drivers d3 --incremental 2 --duration 40 --seed 2 "
                "--out study-out/ --cloud lab/ --token-file lab.token --trust lab/keys/cloud.pub",
                r"Incremental learning(.*\n)*\| d3 \| 2 \|",
                "the cloud folder lab/ embedded instead of the server on port 8080; 2 short trips",
            ),
        ],
    ),
    "docs/ecu.md": (
        [],
        [
            skip(
                ".venv/bin/mutmut run && .venv/bin/mutmut results",
                "mutation testing of ecu/safety.py takes minutes; run by hand (kill rate in "
                "docs/ecu.md), tests/ecu/test_safety.py is what it mutates against",
            ),
        ],
    ),
    "docs/hil.md": (
        [],
        [
            skip("pacc hil", HIL + "tests/hil/test_page.py serves the page"),
            skip("pacc hil --scenario A --controller manual", HIL + "tests/hil/test_page.py"),
            skip(
                "pacc hil --controller irl+oa --table sessions/P01/tables/irl.json",
                HIL + "tests/hil/test_session.py",
            ),
            skip(
                "pacc hil --participant P01 --protocol paper --out sessions/",
                HIL + "tests/hil/test_protocol.py drives a shortened protocol",
            ),
            skip("pacc study --hil sessions/ --out out/hil", HIL + "tests/hil/test_protocol.py"),
            skip(
                "pacc study --hil sessions/ --out out/hil --beside out/study/drives.csv",
                HIL + "tests/hil/test_protocol.py",
            ),
        ],
    ),
    "docs/logs.md": (
        ["ln -s {root}/dbc/pacc.dbc car.dbc", "ln -s {root}/dbc/pacc.binding.toml car.binding.toml"],
        [
            short(
                "pacc drive --scenario B --driver d2 --controller predefined+oa --seed 1 "
                "--can-log drive.mcap",
                "pacc drive --scenario B --driver d2 --controller predefined+oa --seed 1 "
                "--can-log drive.mcap --duration 3",
                r"bus recording  drive\.mcap",
                "3 s (replay -i below plays it in real time)",
            ),
            short(
                "pacc study --can-logs --out out/study",
                "pacc study --can-logs --drivers d1 --scenarios A --controllers predefined "
                "--trials 1 --duration 5 --out out/study -q",
                r"outputs in out/study/ .*can/",
                "one 5-s drive of the study",
            ),
            short(
                "pacc drive --scenario B --driver d2 --foxglove",
                "pacc drive --scenario B --driver d2 --foxglove 127.0.0.1:0 --duration 5 --pace 20",
                r"foxglove: live view on ws://127\.0\.0\.1:\d+",
                "a free port instead of 8765, 5 s at 20x (default 1x); tests/ecu/test_live.py "
                "subscribes a client",
            ),
            run("pacc export drive.mcap drive.blf", r"\d+ frames: drive\.mcap -> drive\.blf"),
            short(
                "pacc export trace.asc trace.mcap --dbc car.dbc",
                "pacc export drive.mcap trace.asc && pacc export trace.asc trace.mcap --dbc car.dbc",
                r"\d+ frames: trace\.asc -> trace\.mcap",
                "trace.asc made from the drive first (car.dbc: pacc's DBC)",
            ),
            run("pacc replay drive.mcap --ecu", r"ECU sent +\d+ frames"),
            run("pacc plot drive.mcap -o drive.png", r"plot: drive\.png"),
            run(
                "pacc plot drive.mcap ESC_Speed.VehicleSpeed /ecu/outputs.desired_gap_m -o sig.png",
                r"plot: sig\.png",
            ),
            run("pacc plot drive.blf VehicleSpeed --dbc car.dbc -o blf.png", r"plot: blf\.png"),
            run(
                "pacc plot drive.blf --dbc car.dbc --binding car.binding.toml -o fixed.png",
                r"plot: fixed\.png",
            ),
            short(
                "pacc plot trips/d2_000.mcap -o trip.png",
                "mkdir -p trips && pacc drive --manual --scenario manual1 --driver d2 "
                "--log trips/d2_000.mcap --duration 10 && pacc plot trips/d2_000.mcap -o trip.png",
                r"log +trips/d2_000\.mcap(.*\n)*plot: trip\.png",
                "a 10-s manual drive writes the trip log first",
            ),
            run("pacc plot drive.mcap --plotjuggler drive.xml", r"plotjuggler layout: drive\.xml"),
        ],
    ),
    "docs/scale.md": (
        [],
        [
            skip("dask scheduler --port 8786", DASK),
            skip("dask worker tcp://HEAD:8786 --nworkers 8 --nthreads 1", DASK),
            skip("pacc study --scheduler tcp://HEAD:8786 --out out/study", DASK),
            skip("pacc cloud serve --data cloud/ --port 8080 --scheduler tcp://HEAD:8786", DASK),
            skip("pacc cloud serve --data cloud/ --port 8080 --scheduler local --workers 4", DASK),
        ],
    ),
    "docs/study.md": (
        [],
        [
            skip(
                "pacc study [--drivers d1,…] [--scenarios A,B] [--controllers predefined,…] "
                "[--trials 3]",
                "a synopsis, not a command",
            ),
            skip(
                "[--seed 0] [--duration S] [--workers 2] [--scheduler local|tcp://HOST:8786]",
                "a synopsis",
            ),
            skip("[--adaptation timegap|paper]", "a synopsis"),
            skip(
                "[--out out/study] [--no-logs] [--can-logs] [--cloud URL|DIR --token-file F "
                "--trust KEY.pub]",
                "a synopsis",
            ),
            skip(
                "[--direct [--cache DIR]] [--incremental N] [--dbc CAR.dbc --binding "
                "CAR.binding.toml]",
                "a synopsis",
            ),
            skip(
                "pacc study --population N [--seed S] [--scenarios B] [--trials 1] "
                "[--duration 120] [--cache DIR] [--roads per-driver|shared]",
                "a synopsis",
            ),
            skip(
                "pacc study --population 20 --seed 342964 --out out/pop --cache out/cache",
                "minutes; tests/pacc/test_study_population.py runs a small population",
            ),
        ],
    ),
    "docs/vehicles.md": (
        ["ln -s {root}/tools tools"],  # the checkout's script, run by its path
        [
            skip(
                "pacc drive --binding toyota_nodsu --dbc "
                "toyota_nodsu_pt_generated.dbc",
                "the same drive as the recipe below, run there",
            ),
            skip("pacc ecu -i socketcan -c can0 --dbc car.dbc --binding car.binding.toml", VCAN + "tests/vehicles/test_toyota.py"),
            skip("pacc sim -i socketcan -c can0 --dbc car.dbc --binding car.binding.toml", VCAN + "tests/vehicles/test_toyota.py"),
            skip(
                "pacc study --dbc car.dbc --binding car.binding.toml --trials 1",
                "car.dbc is a placeholder; tests/vehicles/test_toyota.py runs a study drive on Toyota's",
            ),
            skip("pip install opendbc", "the network; opendbc is a dev dependency"),
            run(
                "python tools/opendbc_toyota.py -o toyota_nodsu_pt_generated.dbc",
                r"toyota_nodsu_pt_generated\.dbc",
            ),
            short(
                TOYOTA_DRIVE,
                TOYOTA_DRIVE + " --duration 20",
                r"collisions     0",
                "20 s of the 300-s drive",
            ),
            skip(
                "python -m can_remote -i virtual -c pacc -H 127.0.0.1 -p 54701 &",
                "a fixed port; tests/sim_bus/test_two_processes.py runs these three on a free one",
            ),
            skip(
                "pacc ecu -i remote -c ws://127.0.0.1:54701/ --set-speed 40 --duration 60 &",
                "tests/sim_bus/test_two_processes.py",
            ),
            skip(
                "pacc sim -i remote -c ws://127.0.0.1:54701/ --duration 60",
                "tests/sim_bus/test_two_processes.py",
            ),
        ],
    ),
}  # fmt: skip


def test_every_printed_command_has_a_plan_and_every_plan_a_command() -> None:
    for doc in DOCS:
        printed = doc_commands((ROOT / doc).read_text(encoding="utf-8"))
        planned = [plan.command for plan in PLANS.get(doc, ([], []))[1]]
        assert printed == planned, (
            f"{doc}: the printed commands and the plans differ:\n"
            f"printed only: {[c for c in printed if c not in planned]}\n"
            f"planned only: {[c for c in planned if c not in printed]}"
        )
    for doc, (_, plans) in PLANS.items():
        for plan in plans:
            assert plan.kind in ("run", "short", "skip")
            assert plan.check or plan.kind == "skip", plan
            assert plan.why or plan.kind == "run", plan
            for path, name in re.findall(r"(tests/[\w/]+\.py)(?:::(\w+))?", plan.why):
                assert (ROOT / path).is_file(), f"{doc}: {plan.command}: no {path}"
                source = (ROOT / path).read_text(encoding="utf-8")
                assert not name or f"def {name}(" in source, f"{doc}: no {path}::{name}"
        assert doc in DOCS


def test_the_parser_joins_continuations_and_drops_comments() -> None:
    text = "```sh\n# a comment\npacc a --x 1 \\\n       --y 2   # said\n   # more\npacc b\n```\n"
    assert doc_commands(text) == ["pacc a --x 1 --y 2", "pacc b"]


def _shell(command: str) -> str:
    """``command`` with ``python`` as this interpreter's (no PATH needed)."""
    return re.sub(r"(^|&& )python ", rf"\1{sys.executable} ", command)


def _run(command: str, cwd: Path, capfd: pytest.CaptureFixture[str]) -> tuple[int, str]:
    """Run ``command`` as sh would, its ``&&``-joined parts in order up to the first failure:
    ``pacc ARGS`` in this interpreter (ARGS split and globbed as sh does), any other part in
    a shell; the exit status and what it printed."""
    code, said = 0, ""
    for part in command.split(" && "):
        if part.startswith("pacc "):
            argv = [w for word in shlex.split(part)[1:] for w in _globbed(word, cwd)]
            try:
                code = cli.main(argv)
            except SystemExit as exc:  # argparse's usage error
                code = exc.code if isinstance(exc.code, int) else 1
        else:
            code = subprocess.run(_shell(part), shell=True, cwd=cwd, check=False).returncode
        out = capfd.readouterr()
        said += out.out + out.err
        if code != 0:
            break
    return code, said


def _globbed(word: str, cwd: Path) -> list[str]:
    """``word`` as sh expands it in ``cwd``: a pattern's sorted matches (none: the pattern)."""
    if not set(word) & set("*?["):
        return [word]
    return sorted(str(p.relative_to(cwd)) for p in cwd.glob(word)) or [word]


@pytest.mark.slow
@pytest.mark.parametrize("doc", [d for d, (_, plans) in PLANS.items() if any(
    p.kind != "skip" for p in plans)])  # fmt: skip
def test_recipes_run_as_printed(
    doc: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capfd: pytest.CaptureFixture[str],
) -> None:
    setup, plans = PLANS[doc]
    if doc == "docs/vehicles.md" and shutil.which("true") and not _has_opendbc():
        pytest.skip("opendbc (a dev dependency) is not installed")
    monkeypatch.setenv("PYTHONPATH", str(ROOT))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    monkeypatch.chdir(tmp_path)
    for step in setup:
        subprocess.run(step.replace("{root}", str(ROOT)), shell=True, check=True, cwd=tmp_path)
    for plan in plans:
        if plan.kind == "skip":
            continue
        command = plan.instead if plan.kind == "short" else plan.command
        code, said = _run(command, tmp_path, capfd)
        assert code == 0, f"{doc}: {command}\n{said[-2000:]}"
        assert "Traceback" not in said, f"{doc}: {command}\n{said[-2000:]}"
        assert re.search(plan.check, said), (
            f"{doc}: {command}: no {plan.check!r} in\n{said[-2000:]}"
        )


def _has_opendbc() -> bool:
    try:
        import opendbc  # noqa: F401, PLC0415
    except ImportError:
        return False
    return True
