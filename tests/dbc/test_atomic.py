"""dbc.atomic: a file written whole or not at all; a failed write (the writer raises, the disk
fills up, an unwritable place, a failed rename) leaves the target as it was and no temporary
file behind."""

from __future__ import annotations

import resource
import signal
from pathlib import Path

import pytest

from dbc.atomic import atomic_writer, write_bytes_atomic
from dbc.vocab.dgpt import DgptError, predefined
from dbc.vocab.dgpt_file import save_dgpt

OLD = b"the old file\n"


def names(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


@pytest.mark.parametrize("durable", [False, True])
def test_written_whole_and_exact_with_no_temporary_file_left(tmp_path: Path, durable: bool) -> None:
    target = tmp_path / "a" / "b.bin"
    if not durable:
        target.parent.mkdir()  # durable: the folder is made
    data = bytes(range(256)) * 1000
    write_bytes_atomic(target, OLD, durable=durable)
    write_bytes_atomic(target, data, durable=durable)  # replaced whole
    assert target.read_bytes() == data
    assert names(target.parent) == ["b.bin"]


def test_a_writer_that_raises_midway_leaves_the_target_intact(tmp_path: Path) -> None:
    target = tmp_path / "t.bin"
    target.write_bytes(OLD)
    with pytest.raises(RuntimeError, match="midway"), atomic_writer(target) as stream:
        stream.write(b"half of the new")
        stream.flush()
        raise RuntimeError("midway")
    assert target.read_bytes() == OLD
    assert names(tmp_path) == ["t.bin"]


def test_a_full_disk_leaves_the_target_intact(tmp_path: Path) -> None:
    """A file-size limit (EFBIG: the same OSError path as ENOSPC) stops the write midway."""
    target = tmp_path / "t.bin"
    target.write_bytes(OLD)
    soft, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
    handler = signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (1 << 20, hard))
    try:
        with pytest.raises(OSError, match="File too large"):
            write_bytes_atomic(target, bytes(2 << 20))
    finally:
        resource.setrlimit(resource.RLIMIT_FSIZE, (soft, hard))
        signal.signal(signal.SIGXFSZ, handler)
    assert target.read_bytes() == OLD
    assert names(tmp_path) == ["t.bin"]


def test_a_failed_rename_leaves_neither_file_nor_temporary(tmp_path: Path) -> None:
    target = tmp_path / "taken"
    target.mkdir()
    (target / "inside").write_text("a folder stands where the file would go")
    with pytest.raises(OSError):
        write_bytes_atomic(target, b"data", durable=True)
    assert names(tmp_path) == ["taken"]  # no .taken.*.part
    assert (target / "inside").is_file()


def test_an_unwritable_place_is_a_clear_error_for_a_table(tmp_path: Path) -> None:
    """A file where the folder should be: DgptError naming the path; the old table stays."""
    good = tmp_path / "t.json"
    save_dgpt(predefined(1.5), good)
    saved = good.read_bytes()
    (tmp_path / "file").write_bytes(OLD)
    with pytest.raises(DgptError, match=r"file/t\.json: cannot write: Not a directory"):
        save_dgpt(predefined(2.0), tmp_path / "file" / "t.json")
    assert good.read_bytes() == saved
    assert names(tmp_path) == ["file", "t.json"]
