"""caustica render --labels: the label layers written beside the image (docs/labels.md)."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.cli import main
from caustica.images import read_exr_channels, read_image
from caustica.labels import read_labels

ARGS = ["render", "caustic-sphere", "--size", "32x32", "-t", "env-map", "--timing-frames", "1"]


def test_labels_land_beside_the_image_and_keep_it_unchanged(tmp_path, capsys):
    assert main([*ARGS, "-o", str(tmp_path / "plain.exr")]) == 0
    assert main([*ARGS, "-o", str(tmp_path / "out.exr"), "--labels", "glass,id,depth"]) == 0
    assert "labels id, depth, glass in" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.exr", "out.labels.exr", "plain.exr"]
    assert np.array_equal(read_image(tmp_path / "out.exr"), read_image(tmp_path / "plain.exr"))
    assert set(read_exr_channels(tmp_path / "out.labels.exr")) == {"id.V", "depth.Z", "glass.V"}
    layers = read_labels(tmp_path / "out.labels.exr")
    ids, glass, depth = layers["id"], layers["glass"], layers["depth"]
    assert set(np.unique(ids)) == {-1, 0, 1}  # the sky, the ball, the floor
    assert glass[10, 16] == 1 and glass.sum() > 50 and np.array_equal(glass == 1, ids == 0)  # the ball is the glass
    assert np.isinf(depth[ids < 0]).all() and np.isfinite(depth[ids >= 0]).all()


def test_npz_labels(tmp_path):
    assert main([*ARGS, "-o", str(tmp_path / "out.png"), "--labels", "alpha,normal", "--labels-format", "npz"]) == 0
    layers = read_labels(tmp_path / "out.labels.npz")
    assert sorted(layers) == ["alpha", "normal"] and layers["normal"].shape == (32, 32, 3)


@pytest.mark.parametrize("extra, message", [
    (["--labels", "id,dpeth"], "unknown label 'dpeth' (did you mean 'depth'?)"),
    (["--labels-format", "npz"], "--labels-format needs --labels"),
    (["--labels", "id", "--labels-format", "tiff"], "invalid choice: 'tiff'"),
])
def test_bad_labels_are_one_line_and_write_nothing(tmp_path, capsys, extra, message):
    assert main([*ARGS, "-o", str(tmp_path / "out.png"), *extra]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
    assert list(tmp_path.iterdir()) == []
