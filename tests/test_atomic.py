"""The one atomic writer (``mjsuff.atomic``): a file appears whole, or not at all."""

import pandas as pd
import pytest

from mjsuff.atomic import FILE_MODE, atomic_write, atomic_write_parquet, atomic_write_text


def test_a_failing_writer_leaves_neither_the_file_nor_its_temporary(tmp_path):
    target = tmp_path / "out.bin"

    def half(handle):
        handle.write(b"half of it")
        raise RuntimeError("disk went away")

    with pytest.raises(RuntimeError):
        atomic_write(target, half)
    assert list(tmp_path.iterdir()) == []


def test_an_existing_file_is_replaced_only_when_the_new_one_is_whole(tmp_path):
    target = tmp_path / "summary.json"
    atomic_write_text(target, "old")

    def interrupted(handle):
        handle.write(b"new, partly")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(target, interrupted)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["summary.json"]
    atomic_write_text(target, "new")
    assert target.read_text() == "new" and target.stat().st_mode & 0o777 == FILE_MODE


def test_parquet_round_trips(tmp_path):
    frame = pd.DataFrame({"step": [1, 2], "bound": [0.5, float("nan")], "rule": ["nevd", "piob"]})
    atomic_write_parquet(tmp_path / "steps.parquet", frame)
    pd.testing.assert_frame_equal(pd.read_parquet(tmp_path / "steps.parquet"), frame)
