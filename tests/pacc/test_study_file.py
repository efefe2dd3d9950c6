"""Study files: parsing and validation; a run with entry-point plug-ins in-process and on
Dask with identical rows; the manifest reproduces the run; a stopped run resumes."""

from __future__ import annotations

import json
from concurrent.futures import Executor
from dataclasses import replace
from pathlib import Path

import pytest

from cloud_sync.engine import InlineExecutor
from pacc.commands.study import main as study_main
from pacc.study.pipeline import ROWS, run
from pacc.study.spec import (
    StudyFileError,
    expand_methods,
    load_study_file,
    resolve,
    spec_of,
)
from sim_bus.errors import SimError

STUDY = """
seed = 4
trials = 1
duration_s = 4.0
workers = 1

[drivers]
builtin = ["d3"]
population = [{ n = 1, seed = 21 }]

[scenarios]
names = ["B"]
csv = ["lead.csv"]

[[methods]]
table = "test-timegap"
adaptation = ["none", "test-halfstep"]
controller = "test-timegap"
controller_args = { k_gap = 0.25 }

[[methods]]
name = "pid-timegap"
table = "predefined"
adaptation = "timegap"
"""


def _study(folder: Path) -> Path:
    (folder / "lead.csv").write_text(
        "t_s,v_lead_mps\n" + "".join(f"{t},{20 + (t % 4)}\n" for t in range(0, 12)),
        encoding="utf-8",
    )
    path = folder / "study.toml"
    path.write_text(STUDY, encoding="utf-8")
    return path


def test_combinations_expand_and_name_themselves() -> None:
    methods = expand_methods(
        [{"table": ["predefined", "gp"], "adaptation": ["none", "bayes"]}, {"name": "x"}]
    )
    assert [m.name for m in methods] == [
        "predefined", "predefined+bayes", "gp", "gp+bayes", "x",
    ]  # fmt: skip
    assert methods[3].table == "gp" and methods[3].adaptation == "bayes"


@pytest.mark.parametrize(
    ("raw", "message"),
    [
        ({"methods": [{}], "colour": 1}, "unknown keys"),
        ({"methods": []}, "at least one"),
        ({"methods": [{"table": "svm"}]}, "no learner 'svm'"),
        ({"methods": [{"adaptation": "magic"}]}, "no adaptation 'magic'"),
        ({"methods": [{"controller": "pid", "controller_args": {"kq": 1}}]}, "refused"),
        ({"methods": [{"name": "a", "table": ["predefined", "gp"]}]}, "names one"),
        ({"methods": [{}, {}]}, "two methods named"),
        ({"methods": [{}], "drivers": {"builtin": ["d9"]}}, "unknown built-in"),
        ({"methods": [{}], "drivers": {"population": [{"n": 0, "seed": 1}]}}, "n >= 1"),
        ({"methods": [{}], "scenarios": {"names": ["Z"]}}, "unknown scenarios"),
        ({"methods": [{}], "scenarios": {"csv": ["nope.csv"]}}, "not found"),
        ({"methods": [{}], "trials": 0}, "trials >= 1"),
    ],
)
def test_bad_study_files_are_refused_before_anything_runs(
    raw: dict[str, object], message: str, tmp_path: Path
) -> None:
    with pytest.raises(StudyFileError, match=message):
        resolve(raw, tmp_path)


def test_an_unreadable_study_file_is_a_clean_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "s.toml"
    bad.write_text("seed = [", encoding="utf-8")
    assert study_main(["--config", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert "cannot read the study file" in capsys.readouterr().err


@pytest.mark.slow
def test_a_study_file_runs_alike_in_process_on_dask_and_from_its_manifest(
    tmp_path: Path, dask_cluster: Executor
) -> None:
    config = load_study_file(_study(tmp_path))
    assert study_main(["--config", str(_study(tmp_path)), "--out", str(tmp_path / "inline"),
                       "--workers", "1", "-q"]) == 0  # fmt: skip
    inline_csv = (tmp_path / "inline" / "drives.csv").read_text(encoding="utf-8")
    rows = run(spec_of(config), tmp_path / "dask", progress=False, executor=dask_cluster)
    assert len(rows) == 2 * 2 * 3  # drivers x scenarios x methods
    assert {r["method"] for r in rows} == {
        "test-timegap@test-timegap", "test-timegap+test-halfstep@test-timegap", "pid-timegap",
    }  # fmt: skip
    assert {r["scenario"] for r in rows} == {"B", "lead"}
    assert all(r["plugin_faults"] == "" and not r["collision"] for r in rows)
    assert (tmp_path / "dask" / "drives.csv").read_text(encoding="utf-8") == inline_csv
    assert "test-timegap" in inline_csv.splitlines()[1]  # the gap controller's column
    manifest = json.loads((tmp_path / "inline" / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["seeds"] == {"study": 4, "trials": [4], "populations": [21]}
    assert manifest["config"]["methods"][0]["controller_args"] == {"k_gap": 0.25}
    assert {"python", "system", "machine", "numpy"} <= set(manifest["platform"])
    again = tmp_path / "again"
    code = study_main(["--config", str(tmp_path / "inline" / "manifest.json"), "--out",
                       str(again), "-q"])  # fmt: skip
    assert code == 0
    assert (again / "drives.csv").read_text(encoding="utf-8") == inline_csv
    # resumable: a run with a drive's record gone runs that drive only
    lines = (again / ROWS).read_text(encoding="utf-8").splitlines()
    (again / ROWS).write_text("\n".join(lines[:-1]) + "\n", encoding="utf-8")
    spec = spec_of(config)
    resumed = run(spec, again, progress=False, executor=InlineExecutor())
    assert [{**r, "wall_s": 0} for r in resumed] == [{**r, "wall_s": 0} for r in rows]
    assert len((again / ROWS).read_text(encoding="utf-8").splitlines()) == len(lines)
    with pytest.raises(SimError, match="holds another study"):
        run(replace(spec, seed=5), again, progress=False, executor=InlineExecutor())
