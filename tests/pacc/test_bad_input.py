"""Every sub-command against bad input: a clean refusal, nothing else.

Each case runs ``pacc.cli.main`` in-process (the error boundary included) in a scratch
folder and checks: a non-zero exit; on stderr one line ``pacc <cmd>: error: ...`` and no
traceback; every input file byte for byte as it was; nothing written outside ``out/``.

The inputs: missing, directory, truncated, corrupt and foreign files for every file option;
NaN, infinity, negative and huge numbers for every numeric option; names with a trailing
newline or bytes that are not UTF-8; outputs that cannot be written. :data:`CASES` is the
table; ``python -m tests.pacc.test_bad_input`` prints the counts for the issue's note.
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import os
import re
import shutil
import tempfile
import traceback
from collections.abc import Iterator
from pathlib import Path

import pytest

from pacc import cli

#: a name that is not UTF-8 as Python sees it from the command line (surrogate escape)
NOT_UTF8 = os.fsdecode(b"car\xff")
#: an output nobody can write: a folder under /proc
UNWRITABLE = "/proc/pacc-no/out"

NUMBERS = ("nan", "inf", "-inf", "-1", "1e308", "1099511627776")

#: option -> the command prefix it belongs to (numbers that need no files to reach parsing)
NUMERIC_OPTIONS: list[tuple[list[str], str, tuple[str, ...]]] = [
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0"], "--headway", NUMBERS),
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0"], "--standstill", NUMBERS),
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0"], "--set-speed", NUMBERS),
    (["ecu", "-i", "virtual", "-c", "bad"], "--duration", NUMBERS),
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0"], "--sync-every", NUMBERS),
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0"], "-b", NUMBERS),
    (["sim", "-i", "virtual", "-c", "bad", "--duration", "1"], "--seed", NUMBERS),
    (["sim", "-i", "virtual", "-c", "bad"], "--duration", NUMBERS),
    (["sim", "-i", "virtual", "-c", "bad", "--duration", "1"], "--condition-factor", NUMBERS),
    (["sim", "-i", "virtual", "-c", "bad", "--duration", "1"], "-b", NUMBERS),
    (["drive", "--duration", "1"], "--seed", NUMBERS),
    (["drive"], "--duration", NUMBERS),
    (["drive", "--duration", "1"], "--condition-factor", NUMBERS),
    (["study", "--out", "out/s", "-q"], "--trials", (*NUMBERS, "0")),
    (["study", "--out", "out/s", "-q"], "--seed", NUMBERS),
    (["study", "--out", "out/s", "-q"], "--duration", (*NUMBERS, "0")),
    (["study", "--out", "out/s", "-q"], "--workers", (*NUMBERS, "0")),
    (["study", "--out", "out/s", "-q"], "--incremental", (*NUMBERS, "0")),
    (["study", "--out", "out/s", "-q"], "--population", (*NUMBERS, "0")),
    (["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "in/token"],
     "--quota-mb", (*NUMBERS, "0")),
    (["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "in/token"],
     "--retry-s", NUMBERS),
    (["cloud", "serve", "--data", "out/c"], "--port", (*NUMBERS, "0", "65536")),
    (["cloud", "serve", "--data", "out/c"], "--workers", (*NUMBERS, "0")),
    (["cloud", "serve", "--data", "out/c"], "--max-upload-mb", (*NUMBERS, "0")),
    (["cloud", "serve", "--data", "out/c"], "--seed", NUMBERS),
    (["cloud", "learn", "--demos", "in/trip.mcap", "--driver", "d1", "-o", "out/d.json"],
     "--seed", NUMBERS),
    (["cloud", "learn", "--demos", "in/trip.mcap", "--driver", "d1", "-o", "out/d.json"],
     "--takeover-weight", NUMBERS),
    (["plot", "in/rec.mcap", "-o", "out/p.png"], "--dpi", (*NUMBERS, "0")),
    (["replay", "in/rec.mcap", "-i", "virtual", "-c", "bad"], "-b", NUMBERS),
    (["hil", "--out", "out/h"], "--port", (*NUMBERS, "65536")),
    (["hil", "--out", "out/h"], "--seed", NUMBERS),
    (["hil", "--out", "out/h"], "--short", (*NUMBERS, "0")),
    (["hil", "--out", "out/h", "--participant", "P01", "--protocol", "paper"],
     "--incremental", NUMBERS),
    (["bench", "--out", "out/b"], "--seeds", (*NUMBERS, "0")),
    (["bench", "--out", "out/b"], "--drivers-per-seed", (*NUMBERS, "0")),
    (["bench", "--out", "out/b"], "--duration", (*NUMBERS, "0")),
    (["bench", "--out", "out/b"], "--trials", (*NUMBERS, "0")),
    (["bench", "--out", "out/b"], "--workers", (*NUMBERS, "0")),
    (["demos", "extract", "in/rec.mcap", "-o", "out/t"], "--min-s", NUMBERS),
]  # fmt: skip

BAD_FILES = ("missing", "dir", "truncated", "corrupt", "foreign")

#: (command with ``{f}`` for the bad file, the kinds of bad file it gets)
FILE_OPTIONS: list[tuple[list[str], tuple[str, ...]]] = [
    (["replay", "{f}", "--ecu"], BAD_FILES),
    (["export", "{f}", "out/x.blf"], BAD_FILES),
    (["plot", "{f}", "-o", "out/p.png"], BAD_FILES),
    (["drive", "--scenario", "{f}.csv"], BAD_FILES),
    (["drive", "--driver", "{f}.toml"], BAD_FILES),
    (["drive", "--controller", "irl", "--profile", "{f}.json"], BAD_FILES),
    (["sim", "-i", "virtual", "-c", "bad", "--scenario", "{f}.csv"], BAD_FILES),
    (["sim", "-i", "virtual", "-c", "bad", "--driver", "{f}.toml"], BAD_FILES),
    (["ecu", "-i", "virtual", "-c", "bad", "--duration", "0", "--binding", "{f}.toml"],
     BAD_FILES),
    (["study", "--out", "out/s", "-q", "--drivers", "{f}.toml"], BAD_FILES),
    (["cloud", "learn", "--demos", "{f}", "--driver", "d1", "-o", "out/d.json", "-q"],
     BAD_FILES),
    (["cloud", "learn", "--demos", "in/trip.mcap", "--init", "{f}.json", "--driver", "d1",
      "-o", "out/d.json", "-q"], BAD_FILES),
    (["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "in/token",
      "--add", "{f}"], BAD_FILES),
    (["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "{f}"],
     ("missing", "dir", "corrupt")),
]  # fmt: skip

#: names: a trailing newline, not UTF-8, empty, a path
NAME_CASES: list[list[str]] = [
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", "car\n"],
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", NOT_UTF8],
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", ""],
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", "../car"],
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", "car",
     "--driver", "d9\n"],
    ["cloud", "register", "--data", "out/c", "--token-file", "out/t", "--vehicle", "car",
     "--driver", NOT_UTF8],
    ["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "in/token",
     "--fetch", "../x", "--trust", "in/token"],
    ["cloud", "sync", "--spool", "out/sp", "--cloud", "out/c", "--token-file", "in/token",
     "--fetch", "d1", "--condition", "default\n", "--trust", "in/token"],
    ["cloud", "learn", "--demos", "in/trip.mcap", "--driver", "d1\n", "-o", "out/d.json"],
    ["cloud", "learn", "--demos", "in/trip.mcap", "--driver", "d1", "--condition", "../x",
     "-o", "out/d.json"],
    ["study", "--out", "out/s", "-q", "--drivers", ""],
    ["study", "--out", "out/s", "-q", "--scenarios", ""],
    ["study", "--out", "out/s", "-q", "--controllers", ","],
    ["drive", "--driver", "d1\n", "--duration", "1"],
    ["drive", "--scenario", "A\n", "--duration", "1"],
]  # fmt: skip

#: outputs that cannot be written (and two outputs on one file)
OUTPUT_CASES: list[list[str]] = [
    ["drive", "--duration", "1", "--log", f"{UNWRITABLE}.mcap"],
    ["drive", "--duration", "1", "--can-log", f"{UNWRITABLE}.mcap"],
    ["drive", "--duration", "1", "--log", "out"],
    ["sim", "-i", "virtual", "-c", "bad", "--duration", "1", "--log", f"{UNWRITABLE}.mcap"],
    ["sim", "-i", "virtual", "-c", "bad", "--duration", "1", "--can-log", f"{UNWRITABLE}.mcap"],
    ["ecu", "-i", "virtual", "-c", "bad", "--duration", "0", "--can-log", f"{UNWRITABLE}.mcap"],
    ["ecu", "-i", "virtual", "-c", "bad", "--duration", "0", "--save-profile",
     f"{UNWRITABLE}.json"],
    ["ecu", "-i", "virtual", "-c", "bad", "--duration", "0", "--takeovers", UNWRITABLE],
    ["ecu", "-i", "virtual", "-c", "bad", "--duration", "0", "--can-log", "out/x.mcap",
     "--save-profile", "out/x.mcap"],
    ["export", "in/rec.mcap", f"{UNWRITABLE}.blf"],
    ["export", "in/rec.mcap", "in/rec.mcap"],
    ["export", "in/rec.mcap", "out/x.mf4"],
    ["plot", "in/rec.mcap", "-o", f"{UNWRITABLE}.png"],
    ["plot", "in/rec.mcap", "-o", "out/p.xyz"],
    ["cloud", "learn", "--demos", "in/trip.mcap", "--driver", "d1", "-o", f"{UNWRITABLE}.json"],
    ["cloud", "register", "--data", "out/c", "--vehicle", "car", "--token-file", UNWRITABLE],
    ["cloud", "register", "--data", UNWRITABLE, "--vehicle", "car", "--token-file", "out/t"],
    ["cloud", "sync", "--spool", UNWRITABLE, "--cloud", "out/c", "--token-file", "in/token"],
    ["study", "--out", UNWRITABLE, "-q", "--drivers", "d1", "--trials", "1"],
]  # fmt: skip


def _cases() -> Iterator[tuple[str, list[str]]]:
    for prefix, option, values in NUMERIC_OPTIONS:
        for value in values:
            yield f"{' '.join(prefix[:2])} {option} {value}", [*prefix, option, value]
    for template, kinds in FILE_OPTIONS:
        for kind in kinds:
            argv = [a.replace("{f}", f"in/{kind}") for a in template]
            yield f"{' '.join(template[:2])} {kind}", argv
    for argv in NAME_CASES:
        yield f"names: {' '.join(map(repr, argv[:2]))} {argv[-1]!r}", argv
    for argv in OUTPUT_CASES:
        yield f"outputs: {' '.join(argv[:2])} {argv[-1]}", argv


CASES = list(_cases())

#: cases whose run is a whole drive or learning step before the refusal: slow
SLOW = {"study"}


def make_inputs(root: Path) -> Path:
    """A real trip log and bus recording, a token, and every bad file kind for each suffix,
    in ``root``."""
    trip, rec = root / "trip.mcap", root / "rec.mcap"
    assert cli.main(["drive", "--duration", "3", "--log", str(trip), "--can-log", str(rec)]) == 0
    (root / "token").write_text("not-a-registered-token\n")
    good = rec.read_bytes()
    for suffix in ("", ".csv", ".toml", ".json"):
        (root / f"dir{suffix}").mkdir()
        (root / f"truncated{suffix}").write_bytes(good[: len(good) // 3])
        corrupt = bytearray(good)
        corrupt[len(corrupt) // 2 : len(corrupt) // 2 + 64] = b"\xff" * 64
        corrupt[:8] = b"\x89MCAPXX\n"
        (root / f"corrupt{suffix}").write_bytes(bytes(corrupt))
        (root / f"foreign{suffix}").write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(256)))
    return root


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """:func:`make_inputs` once for the module."""
    return make_inputs(tmp_path_factory.mktemp("bad-input-inputs"))


def _snapshot(root: Path) -> dict[str, str]:
    """Every file under ``root`` but ``out/``: its SHA-256 (folders as 'dir')."""
    seen: dict[str, str] = {}
    for path in sorted(root.rglob("*")):
        rel = path.relative_to(root)
        if rel.parts[0] == "out" or "__pycache__" in rel.parts:
            continue
        seen[str(rel)] = "dir" if path.is_dir() else hashlib.sha256(path.read_bytes()).hexdigest()
    return seen


def run_case(argv: list[str], work: Path) -> tuple[int, str, str]:
    """Run ``pacc argv`` in-process with ``work`` as the current folder; (exit, out, err).
    A traceback that escapes the command is caught here and reported as exit -1."""
    out, err = io.StringIO(), io.StringIO()
    old = Path.cwd()
    os.chdir(work)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = cli.main(argv)
            except SystemExit as exc:  # argparse's usage error
                code = exc.code if isinstance(exc.code, int) else 1
            except Exception:  # a traceback: what this test exists to catch
                traceback.print_exc(file=err)
                code = -1
    finally:
        os.chdir(old)
    return code, out.getvalue(), err.getvalue()


def _prepare(inputs: Path, work: Path) -> None:
    shutil.copytree(inputs, work / "in", symlinks=True)
    (work / "out").mkdir()


def verdict(code: int, err: str, prog: str) -> str | None:
    """None if the refusal is clean, else what is wrong."""
    lines = [line for line in err.splitlines() if line.strip()]
    if "Traceback" in err or code == -1:
        return "traceback"
    if code == 0:
        return "accepted"
    # the command, or one of its own sub-commands (``pacc demos extract: error: ...``)
    errors = [line for line in lines if re.match(rf"{re.escape(prog)}( [a-z]+)?: error:", line)]
    if len(errors) != 1:
        return f"no single error line: {lines[-3:]}"
    return None


@pytest.mark.parametrize(
    ("label", "argv"),
    [
        pytest.param(label, argv, id=label, marks=[pytest.mark.slow] if argv[0] in SLOW else [])
        for label, argv in CASES
    ],
)
def test_bad_input_is_refused_cleanly(
    label: str, argv: list[str], inputs: Path, tmp_path: Path
) -> None:
    _prepare(inputs, tmp_path)
    before = _snapshot(tmp_path)
    code, out, err = run_case(argv, tmp_path)
    prog = f"pacc {argv[0]}" + (f" {argv[1]}" if argv[0] == "cloud" else "")
    problem = verdict(code, err, prog)
    assert problem is None, f"{label}: {problem}\nexit {code}\nstdout {out[-500:]}\nstderr {err}"
    after = _snapshot(tmp_path)
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    assert not changed, f"{label}: inputs changed or files written outside out/: {changed}"


def main() -> None:
    """Print the table's counts (runs, tracebacks, accepted bad inputs, other faults)."""
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        (root / "inputs").mkdir()
        made = make_inputs(root / "inputs")
        counts: dict[str, int] = {"runs": 0, "traceback": 0, "accepted": 0, "other": 0}
        for i, (label, argv) in enumerate(CASES):
            work = root / f"w{i}"
            work.mkdir()
            _prepare(made, work)
            code, _, err = run_case(argv, work)
            prog = f"pacc {argv[0]}" + (f" {argv[1]}" if argv[0] == "cloud" else "")
            problem = verdict(code, err, prog)
            counts["runs"] += 1
            if problem is not None:
                counts[problem if problem in counts else "other"] += 1
                print(f"{problem:10s} {label}", flush=True)
        print(counts)


if __name__ == "__main__":
    main()


@pytest.mark.slow
@pytest.mark.parametrize(
    "argv",
    [
        ["sim", "-i", "virtual", "-c", "full-disk", "--duration", "2", "--quiet"],
        ["ecu", "-i", "virtual", "-c", "full-disk", "--duration", "1"],
        ["drive", "--duration", "5"],
    ],
)
def test_a_full_disk_under_can_log_is_one_error_line(argv: list[str], tmp_path: Path) -> None:
    """``--can-log`` onto a disk that fills up (a file-size limit of 8 KiB: the same OSError
    path as ENOSPC, EFBIG): a non-zero exit and one error line, no traceback."""
    import resource  # noqa: PLC0415
    import subprocess  # noqa: PLC0415
    import sys  # noqa: PLC0415

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (8192, 8192))

    done = subprocess.run(
        [sys.executable, "-m", "pacc", *argv, "--can-log", "bus.mcap"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        preexec_fn=limit,  # noqa: PLW1509 - a resource limit for the child only
        check=False,
    )
    assert done.returncode != 0, done.stdout
    assert "Traceback" not in done.stderr, done.stderr
    assert verdict(done.returncode, done.stderr, f"pacc {argv[0]}") is None, done.stderr
