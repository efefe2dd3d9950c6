"""DGPT: construction, lookup, JSON round trip and the validation of bad files."""

from __future__ import annotations

import json
import os
import threading
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbc.vocab import FormatError
from dbc.vocab.dgpt import Dgpt, DgptError, SafetyBounds, clamp_to_bounds, predefined, speed_axis
from dbc.vocab.dgpt_file import MAX_DGPT_BYTES, load_dgpt, save_dgpt


def test_predefined_paper_headways() -> None:
    for headway in (1.0, 3.0, 4.0):
        t = predefined(headway)
        assert t.source == "predefined"
        assert t.speed_mps[0] == 0.0 and t.speed_mps[-1] == 40.0
        assert t.step_mps == pytest.approx(0.5)
        assert t.lookup(0.0) == pytest.approx(4.0)
        assert t.lookup(20.0) == pytest.approx(4.0 + 20.0 * headway)
        assert t.meta["headway_s"] == headway


def test_predefined_outside_bounds_refused() -> None:
    with pytest.raises(DgptError, match="outside the safety bounds"):
        predefined(0.5)
    with pytest.raises(DgptError, match="outside the safety bounds"):
        predefined(6.0)


def test_lookup_interpolates_and_holds_ends() -> None:
    t = predefined(1.5, standstill_m=5.0)
    assert t.lookup(10.25) == pytest.approx(5.0 + 1.5 * 10.25)
    assert t.lookup(-3.0) == pytest.approx(5.0)
    assert t.lookup(55.0) == pytest.approx(5.0 + 60.0)
    assert np.isnan(t.lookup(float("nan")))
    arr = t.lookup(np.array([[0.0, 1.25], [39.9, 80.0]]))
    assert arr.shape == (2, 2)
    np.testing.assert_allclose(arr, [[5.0, 5.0 + 1.875], [5.0 + 1.5 * 39.9, 65.0]])
    assert t.slope(12.3) == pytest.approx(1.5)
    assert t.slope(45.0) == 0.0


@given(st.floats(min_value=-10.0, max_value=60.0, allow_nan=False))
def test_scalar_lookup_matches_numpy(v: float) -> None:
    speed = speed_axis(0.25)
    gap = 6.0 + 1.2 * speed + 2.0 * np.sin(speed / 3.0)
    t = Dgpt(speed_mps=speed, gap_m=gap, source="irl")
    assert t.lookup(v) == pytest.approx(float(np.interp(v, speed, gap)), abs=1e-9)


def test_arrays_are_read_only_and_with_gaps_bumps_version() -> None:
    t = predefined(2.0)
    with pytest.raises(ValueError):
        t.gap_m[3] = 1.0
    new = t.with_gaps(t.gap_m + 1.0, created_utc="2026-01-01T00:00:00Z")
    assert new.version == t.version + 1
    assert new.source == "adapted"
    assert new.lookup(0.0) == pytest.approx(5.0)
    assert t.lookup(0.0) == pytest.approx(4.0)


def test_json_round_trip(tmp_path: Path) -> None:
    speed = speed_axis(0.5)
    t = Dgpt(
        speed_mps=speed,
        gap_m=5.0 + 1.7 * speed,
        version=7,
        driver_id="driver3",
        condition="rain",
        source="irl",
        created_utc="2026-05-01T12:00:00Z",
        meta={"coverage": [1, 2, 3]},
    )
    path = tmp_path / "d.json"
    save_dgpt(t, path)
    back = load_dgpt(path)
    assert back.to_json_dict() == t.to_json_dict()
    assert json.loads(path.read_text())["format"] == "pacc.dgpt/1"


@pytest.mark.parametrize("step", [1 / 3, 1 / 7, 0.4, 0.1])
def test_save_load_round_trip_at_the_bounds(tmp_path: Path, step: float) -> None:
    """A valid table whose gaps sit exactly on a safety bound (what clamping produces) loads
    back after saving, whatever speed step divides 40 m/s."""
    for headway, standstill in ((5.0, 10.0), (0.8, 2.0)):
        t = predefined(headway, standstill, step_mps=step)
        path = tmp_path / "t.json"
        save_dgpt(t, path)
        back = load_dgpt(path)
        assert back.lookup(17.3) == pytest.approx(t.lookup(17.3))


def _write(tmp_path: Path, obj: object) -> Path:
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(obj) if not isinstance(obj, str) else obj)
    return path


def _good() -> dict[str, object]:
    return predefined(1.5, created_utc="2026-01-01T00:00:00Z").to_json_dict()


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda d: d.update(format="pacc.dgpt/0"), "format tag"),
        (lambda d: d.pop("gap_m"), "missing key"),
        (lambda d: d.update(gap_m=d["gap_m"][:-1]), "differ in length"),
        (lambda d: d.update(speed_mps=list(reversed(d["speed_mps"]))), "strictly increasing"),
        (lambda d: d.update(speed_mps=[x * 0.5 for x in d["speed_mps"]]), "span 0..40"),
        (lambda d: d.update(speed_mps=[i * 1.0 for i in range(41)], gap_m=[5.0] * 41), "coarser"),
        (lambda d: d["gap_m"].__setitem__(10, float("nan")), "not finite"),
        (lambda d: d["gap_m"].__setitem__(10, 1.0), "outside the safety bounds"),
        (lambda d: d["gap_m"].__setitem__(80, 500.0), "outside the safety bounds"),
        (lambda d: d.update(source="guess"), "source must be"),
        (lambda d: d.update(version=-1), "version"),
        (lambda d: d.update(version=2**70), "version must be 0 to 65535"),
        (lambda d: d.update(version=65536), "version must be 0 to 65535"),
        (lambda d: d.update(driver_id="../../x"), "driver_id '../../x' is not a plain name"),
        (lambda d: d.update(driver_id="d1\ud800"), r"driver_id 'd1\\ud800' is not a plain"),
        (lambda d: d.update(condition="../x"), "condition '../x' is not a plain name"),
        (lambda d: d.update(gap_m=["a"] * 81), "list of numbers"),
    ],
)
def test_invalid_files_refused_with_clear_message(
    tmp_path: Path, mutate: object, message: str
) -> None:
    d = _good()
    mutate(d)  # type: ignore[operator]
    path = _write(tmp_path, d)
    with pytest.raises(DgptError, match=message) as info:
        load_dgpt(path)
    assert str(path) in str(info.value)
    assert isinstance(info.value, FormatError)


def test_only_a_bounded_regular_file_is_read(tmp_path: Path) -> None:
    """A FIFO (whose open would block), a device that never ends and a file over the size
    limit are refused without being read."""
    fifo = tmp_path / "fifo.json"
    os.mkfifo(fifo)
    zero = tmp_path / "zero.json"
    zero.symlink_to("/dev/zero")
    huge = tmp_path / "huge.json"
    with huge.open("wb") as fh:
        fh.truncate(MAX_DGPT_BYTES + 1)
    for path, message in ((fifo, "not a regular file"), (zero, "not a regular file")):
        with pytest.raises(DgptError, match=message):
            load_dgpt(path)
    with pytest.raises(DgptError, match="larger than"):
        load_dgpt(huge)


def test_unreadable_and_non_json(tmp_path: Path) -> None:
    with pytest.raises(DgptError, match="cannot read"):
        load_dgpt(tmp_path / "missing.json")
    with pytest.raises(DgptError, match="not valid JSON"):
        load_dgpt(_write(tmp_path, "{not json"))
    with pytest.raises(DgptError, match="not a JSON object"):
        load_dgpt(_write(tmp_path, "[1, 2]"))


def _good_text() -> str:
    return json.dumps(_good())


@pytest.mark.parametrize(
    "text",
    [
        _good_text().replace('"version": 0', '"version": ' + "9" * 5000),  # > 4300 digits
        _good_text().replace('"gap_m": [4.0', '"gap_m": [1' + "0" * 400),  # int beyond float
        '{"format": "pacc.dgpt/1", "meta": ' + "[" * 100_000 + "]" * 100_000 + "}",
    ],
    ids=["huge-int-literal", "int-overflows-float", "deep-nesting"],
)
def test_corrupt_numbers_and_nesting_refused_not_raised(tmp_path: Path, text: str) -> None:
    """A corrupt profile must give DgptError (the runtime catches only that), not
    ValueError / OverflowError / RecursionError escaping into the control loop."""
    path = _write(tmp_path, text)
    with pytest.raises(DgptError) as info:
        load_dgpt(path)
    assert str(path) in str(info.value)


def test_binary_file_refused(tmp_path: Path) -> None:
    path = tmp_path / "profile_1.json"
    path.write_bytes(b"\xff\xfe\x00garbage\x80")
    with pytest.raises(DgptError, match="not valid JSON") as info:
        load_dgpt(path)
    assert str(path) in str(info.value)


def test_non_uniform_axis_refused() -> None:
    speed = speed_axis(0.5).copy()
    speed[5] += 0.1
    with pytest.raises(DgptError, match="uniformly"):
        Dgpt(speed_mps=speed, gap_m=5.0 + speed)


def test_bounds_and_clamp() -> None:
    b = SafetyBounds()
    assert b.lower_m(10.0) == pytest.approx(2.0 + 8.0)
    assert b.upper_m(10.0) == pytest.approx(10.0 + 50.0)
    v = np.array([0.0, 10.0, 20.0])
    out = clamp_to_bounds(v, np.array([0.0, 30.0, 1000.0]), b)
    np.testing.assert_allclose(out, [2.0, 30.0, 110.0])
    with pytest.raises(DgptError):
        SafetyBounds(headway_min_s=3.0, headway_max_s=2.0)


def test_save_leaves_no_temp_file_and_writers_do_not_share_one(tmp_path: Path) -> None:
    target = tmp_path / "t.json"
    tables = [predefined(1.0 + 0.5 * i) for i in range(4)]
    errors: list[BaseException] = []

    def write(t: object) -> None:
        try:
            for _ in range(25):
                save_dgpt(t, target)  # type: ignore[arg-type]
        except BaseException as exc:  # noqa: BLE001 - collected and asserted below
            errors.append(exc)

    threads = [threading.Thread(target=write, args=(t,)) for t in tables]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    assert errors == []
    assert load_dgpt(target).gap_m.tolist() in [t.gap_m.tolist() for t in tables]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.json"]
