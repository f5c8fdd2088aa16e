"""The one atomic-write helper: a failed write leaves the previous file and no temporary."""
import pytest

from torsal.core.atomic import atomic_path


def test_failed_write_leaves_previous_file_and_no_temporary(tmp_path):
    target = tmp_path / "sheet01.dxf"
    target.write_text("previous")

    with pytest.raises(RuntimeError, match="mid-write"):
        with atomic_path(target) as tmp:
            assert tmp.parent == tmp_path and tmp.suffix == ".dxf"  # writers pick format by suffix
            tmp.write_text("half")
            raise RuntimeError("writer failed mid-write")

    assert target.read_text() == "previous"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet01.dxf"]

    with pytest.raises(RuntimeError):
        with atomic_path(tmp_path / "new.csv") as tmp:
            tmp.write_text("half")
            raise RuntimeError("writer failed mid-write")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sheet01.dxf"]
