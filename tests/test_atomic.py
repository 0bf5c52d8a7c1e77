"""hpcgfmd.atomic: a replaced file is its old or its whole new content, never a part."""

import os

import pytest

from hpcgfmd import atomic


def test_replacing_keeps_old_content_on_error(tmp_path):
    path = tmp_path / "table.csv"
    path.write_text("old\n")
    with pytest.raises(RuntimeError), atomic.replacing(path) as temporary:
        with open(temporary, "w") as fh:
            fh.write("half a ta")
        raise RuntimeError("killed")
    assert path.read_text() == "old\n"
    assert os.listdir(tmp_path) == ["table.csv"]  # no temporary left


def test_write_text_and_csv(tmp_path):
    atomic.write_text(tmp_path / "a.txt", "one\ntwo\n", durable=True)
    assert (tmp_path / "a.txt").read_text() == "one\ntwo\n"
    atomic.write_csv(tmp_path / "b.csv", ["x", "y"], [{"x": 1, "y": 2, "z": 3}, {"x": 4}])
    assert (tmp_path / "b.csv").read_text().splitlines() == ["x,y", "1,2", "4,"]
    atomic.write_csv(tmp_path / "c.csv", ["x", "y"], [(1, 2)])
    assert (tmp_path / "c.csv").read_text().splitlines() == ["x,y", "1,2"]
    assert sorted(os.listdir(tmp_path)) == ["a.txt", "b.csv", "c.csv"]


def test_save_figure_keeps_the_format(tmp_path):
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    ax.plot([0, 1], [1, 0])
    atomic.save_figure(fig, tmp_path / "f.png", dpi=50)
    plt.close(fig)
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
