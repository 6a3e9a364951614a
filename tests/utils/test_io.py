from pathlib import Path

import pytest

from bimanualshift.utils.io import atomic_write_text, atomic_writer


def test_interrupted_write_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "bank.json"
    atomic_write_text(target, "old")
    with pytest.raises(RuntimeError), atomic_writer(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("killed mid-write")
    assert target.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["bank.json"]


def test_temporary_name_keeps_the_suffix(tmp_path: Path) -> None:
    with atomic_writer(tmp_path / "video.mp4") as tmp:
        assert tmp.suffix == ".mp4"
        tmp.write_bytes(b"x")
    assert (tmp_path / "video.mp4").read_bytes() == b"x"
