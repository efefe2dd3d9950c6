"""tools/compile.py: the generated codec module says what MessageCodec says, compiled or not."""

from __future__ import annotations

import hashlib
import importlib.util
import os
import random
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dbc import message
from dbc.codec import load_codec
from dbc.errors import DecodeError, EncodeError
from ecu.buslog.reader import read_canlog
from tools.compile import _SIGNATURES, codec_module_source, typed

ROOT = Path(__file__).resolve().parents[2]
_ANNOTATION = re.compile(r"^(\s+\w+): (?:int|bytes) = ")


def test_typed_only_adds_annotations() -> None:
    """The compiled functions are the generated ones with types: strip them and the source
    comes back line for line."""
    back = {v: k for k, v in _SIGNATURES.items()}
    for mc in load_codec().by_id.values():
        lines = [back.get(ln, _ANNOTATION.sub(r"\1 = ", ln)) for ln in typed(mc.source())]
        assert lines == mc.source().splitlines()
        assert any(": int = " in ln for ln in typed(mc.source()))


def _frames(mc: message.MessageCodec, rng: random.Random, n: int) -> list[bytes]:
    """Payloads of ``mc``: ``n`` encoded from random in-range values (each also with one bit
    flipped: a CRC error), ``n`` random bytes, one of a wrong length."""
    out = []
    for i in range(n):
        values = {}
        for key in mc.fields:
            lo, hi = mc.bounds(key)
            values[key] = rng.uniform(lo, hi)
        good = mc.encode(values, i % max(mc.counter_modulo, 1))
        bit = rng.randrange(8 * mc.length)
        flipped = bytearray(good)
        flipped[bit // 8] ^= 1 << (bit % 8)
        out += [good, bytes(flipped)]
    out += [bytes(rng.getrandbits(8) for _ in range(mc.length)) for _ in range(n)]
    out.append(bytes(mc.length + 1))
    return out


def _outcome(f: Any, *args: Any) -> Any:
    try:
        return f(*args)
    except (DecodeError, EncodeError) as exc:
        return type(exc), str(exc)


def test_the_generated_module_gives_the_codecs_results() -> None:
    """Run as plain Python, each factory of the generated module gives the encode/decode
    results (values, errors and their messages) of the codec MessageCodec builds."""
    ns: dict[str, Any] = {}
    exec(compile(codec_module_source(), "<generated>", "exec"), ns)  # noqa: S102
    rng = random.Random(23)
    for mc in load_codec().by_id.values():
        encode, decode = ns["FACTORIES"][mc.source()](mc.namespace())
        decoded = 0
        for data in _frames(mc, rng, 300):
            assert _outcome(decode, data) == _outcome(mc.decode, data)
            assert _outcome(decode, bytearray(data)) == _outcome(mc.decode, bytearray(data))
            got = _outcome(mc.decode, data)
            if isinstance(got, message.Decoded):
                decoded += 1
                assert encode(got.values, 3) == mc.encode(got.values, 3)
        assert decoded >= 300  # the good frames at least
        bad = dict.fromkeys(mc.fields, float("nan"))
        assert _outcome(encode, bad, 0) == _outcome(mc.encode, bad, 0)
        assert _outcome(encode, {}, 0) == _outcome(mc.encode, {}, 0)


def _compiler() -> str | None:
    """Why a mypyc build cannot run here (None: it can)."""
    cc = (sysconfig.get_config_var("CC") or "cc").split()[0]
    if shutil.which(cc) is None:
        return "no C compiler"
    if not (Path(sysconfig.get_paths()["include"]) / "Python.h").is_file():
        return "no Python.h (Python's headers)"
    if importlib.util.find_spec("setuptools") is None:  # venvs of Python >= 3.12 lack it
        return "no setuptools in this environment"
    return None


_DRIVE = """
import sys
from pathlib import Path
from sim_bus.drivers import BUILTIN_DRIVERS
from pacc.study.drive import DriveConfig, predefined_table, run_drive
import types
from dbc.codec import load_codec
try:
    import dbc._compiled_codecs as m
    print(m.__file__)
except ImportError:
    print("pure")
parts = load_codec().by_id.values()
print(sum(not isinstance(f, types.FunctionType) for p in parts for f in (p.encode, p.decode)),
      "of", 2 * len(parts), "codec functions compiled")
d = BUILTIN_DRIVERS["d3"]
cfg = DriveConfig(scenario="cutin", driver_id="d3", controller="predefined+oa", seed=5,
                  duration_s=20.0)
r = run_drive(cfg, d, predefined_table(d), can_log=Path(sys.argv[1]))
print(sorted(r.metrics.as_dict().items()), r.frames_sent, r.summary.frames_out)
"""


def _drive(tmp: Path, name: str, pythonpath: str) -> tuple[str, str]:
    """A 20-s drive in a fresh interpreter on ``pythonpath``: its printed lines and a hash of
    the recording's frames and decoded signals."""
    log = tmp / f"{name}.mcap"
    env = {**os.environ, "PYTHONPATH": pythonpath}
    done = subprocess.run(  # cwd: not the repository, whose packages would come first
        [sys.executable, "-c", _DRIVE, str(log)],
        env=env,
        cwd=tmp,
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    rec = read_canlog(log)
    h = hashlib.sha256()
    for k in ("t_s", "id", "dlc"):
        h.update(np.ascontiguousarray(getattr(rec.frames, k)).tobytes())
    h.update(repr(rec.frames.data).encode())
    for m in sorted(rec.decoded):
        for s in sorted(rec.decoded[m]):
            h.update(np.ascontiguousarray(rec.decoded[m][s]).tobytes())
    return done.stdout, h.hexdigest()


def _compiled_copy(config: pytest.Config, tmp_path: Path) -> Path:
    """The packages with the codec module compiled (:func:`tools.compile.build`). Its
    extensions are kept in pytest's cache and reused while what they are built from is the
    same (the generated module imports nothing of pacc): that module, the tool, Python, mypy
    and the compiler; the packages around them are copied afresh."""
    import mypy.version  # noqa: PLC0415 - only where a compiler is

    from tools import compile as tool  # noqa: PLC0415

    made = [tool.codec_module_source(), Path(tool.__file__).read_text(encoding="utf-8")]
    made += [sys.version, mypy.version.__version__, str(sysconfig.get_config_var("CC"))]
    key = hashlib.sha256("\0".join(made).encode()).hexdigest()[:16]
    cache = getattr(config, "cache", None)  # None: -p no:cacheprovider
    kept = None if cache is None else Path(cache.mkdir("compiled-codecs")) / key
    out = tmp_path / "compiled"
    if kept is not None and list(kept.glob("_compiled_codecs*.so")):
        for pkg in tool.PACKAGES:
            shutil.copytree(
                ROOT / pkg, out / pkg, ignore=shutil.ignore_patterns("__pycache__", "*.so")
            )
        for so in kept.glob("_compiled_codecs*.so"):
            shutil.copy2(so, out / "dbc")
        return out
    tool.build(out, modules=("dbc/_compiled_codecs.py",))
    if kept is not None:  # written whole, then named: an interrupted copy is never reused
        shutil.rmtree(kept.parent)
        part = kept.with_suffix(".part")
        part.mkdir(parents=True)
        for so in (out / "dbc").glob("_compiled_codecs*.so"):
            shutil.copy2(so, part)
        part.rename(kept)
    return out


@pytest.mark.slow
def test_the_compiled_codecs_give_the_same_drive(
    tmp_path: Path, pytestconfig: pytest.Config
) -> None:
    """The codec module compiled with mypyc (about 10 s of gcc, once per change of the
    codecs): a drive on it records the same frames and decoded signals, and gives the same
    metrics, as on the pure codecs."""
    why = _compiler()
    if why is not None:
        pytest.skip(f"mypyc needs a C compiler and Python's headers: {why}")
    out = _compiled_copy(pytestconfig, tmp_path)
    assert list((out / "dbc").glob("_compiled_codecs*.so"))
    pure_out, pure_hash = _drive(tmp_path, "pure", str(ROOT))
    out_lines, out_hash = _drive(tmp_path, "compiled", str(out))
    first, used, *rest = out_lines.splitlines()
    assert first.endswith(".so")  # the compiled module loaded,
    n = int(used.split()[2])
    assert used == f"{n} of {n} codec functions compiled" and n > 0  # and every codec used it
    assert pure_out.splitlines()[1] == f"0 of {n} codec functions compiled"
    assert rest == pure_out.splitlines()[2:]
    assert out_hash == pure_hash
