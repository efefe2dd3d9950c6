"""cloud_sync.durable: a file written whole or not at all, and no temporary file left behind
when the write or the rename fails."""

from __future__ import annotations

from pathlib import Path

import pytest

from cloud_sync.durable import write_atomic


def test_written_whole_with_no_temporary_file_left(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b.json"  # the folder is made
    write_atomic(target, b"one")
    write_atomic(target, b"two")  # replaced whole
    assert target.read_bytes() == b"two"
    assert sorted(p.name for p in target.parent.iterdir()) == ["b.json"]


def test_a_failed_rename_leaves_neither_file_nor_temporary(tmp_path: Path) -> None:
    target = tmp_path / "taken"
    target.mkdir()
    (target / "inside").write_text("a folder stands where the file would go")
    with pytest.raises(OSError):
        write_atomic(target, b"data")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["taken"]  # no .taken.*.part
    assert (target / "inside").is_file()
