"""A new user's first steps (issue 43): the quick start in a fresh folder, what `render` says it used, and
the listings' text."""
from __future__ import annotations

import os

import numpy as np

import pytest

from caustica.atomic import check_writable, folders_made, missing_folders
from caustica.cli import main
from caustica.errors import OutputError


def run(args, capsys):
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_render_makes_the_missing_output_folders_and_says_what_auto_planned(tmp_path, capsys, monkeypatch):
    """The README's first command, in an empty folder: out/ is made; the report names auto's plan."""
    monkeypatch.chdir(tmp_path)
    code, out, err = run(["render", "caustic-sphere", "-o", "out/deeper/ball.png", "--size", "32x24",
                          "--timing-frames", "1"], capsys)
    assert code == 0, err
    assert (tmp_path / "out" / "deeper" / "ball.png").stat().st_size > 0
    assert "(32x24, auto: impostors+caustic-mapping, 1 spp)" in out, out


def test_a_failed_render_leaves_no_folder(tmp_path, capsys):
    code, _, err = run(["render", "glass-sphere", "-o", tmp_path / "new" / "x.png", "--size", "16x16",
                        "-p", "shadow_map_size=100000"], capsys)
    assert code == 2 and "shadow_map_size" in err
    assert list(tmp_path.iterdir()) == []


def test_folders_made_removes_what_it_made_when_the_write_fails(tmp_path):
    target = tmp_path / "a" / "b" / "x.png"
    assert missing_folders(target) == [tmp_path / "a", tmp_path / "a" / "b"]
    assert check_writable(target, make_folders=True) == target
    with pytest.raises(RuntimeError):
        with folders_made(target):
            assert (tmp_path / "a" / "b").is_dir()
            raise RuntimeError("the write failed")
    assert list(tmp_path.iterdir()) == []
    with folders_made(target):
        target.write_bytes(b"x")
    assert target.read_bytes() == b"x"


def test_missing_folders_are_refused_up_front_where_they_cannot_be_made(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(OutputError, match="is a file, not a directory"):
        check_writable(tmp_path / "file" / "sub" / "x.png", make_folders=True)
    with pytest.raises(OutputError, match="does not exist"):  # the API's default is unchanged
        check_writable(tmp_path / "sub" / "x.png")
    if os.geteuid() != 0:  # root writes anywhere
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        with pytest.raises(OutputError, match="no permission"):
            check_writable(locked / "sub" / "x.png", make_folders=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "locked"][: 1 + (os.geteuid() != 0)]


def test_listings_print_plain_text_whole_sentences(capsys):
    """presets and graph print no RST markup, and each pass's description is its whole first paragraph."""
    code, presets, _ = run(["presets"], capsys)
    assert code == 0 and "`" not in presets
    assert "caustics-point under a directional light" in presets
    code, graph, _ = run(["graph", "depth-search+caustic-mapping"], capsys)
    assert code == 0 and "`" not in graph
    lobes = next(line for line in graph.splitlines() if line.startswith("2. EnvironmentLobeMaps"))
    assert "the occluders' bounce and the nearest distances" in lobes  # its paragraph's third line, not cut


def test_show_outside_a_notebook_says_so_up_front_and_returns_the_image(monkeypatch, capsys):
    """Plain Python (no Jupyter kernel): one note on stderr before the render, then a PIL image even where
    ipywidgets is installed (a widget could not show); in a notebook the widgets come back as before."""
    import sys
    import types

    import caustica.notebook as notebook
    import caustica.renderer

    class Instant:
        def __init__(self, size=None, progress=None):
            self.size, self.progress = size or (8, 6), progress

        def camera_for(self, scene):
            return scene.camera.with_size(*self.size)

        def render(self, scene, technique, spp=1, **params):
            assert "not in a notebook" in capsys.readouterr().err  # said before the render
            return np.full((self.size[1], self.size[0], 3), 0.25, np.float32)

    monkeypatch.setattr(caustica.renderer, "Renderer", Instant)
    monkeypatch.setitem(sys.modules, "ipywidgets", types.ModuleType("ipywidgets"))
    assert not notebook.in_notebook()
    image = caustica.show("glass-sphere")
    assert type(image).__module__.startswith("PIL") and image.size == (8, 6)


def test_in_notebook_recognises_a_jupyter_kernel(monkeypatch):
    import sys
    import types

    import caustica.notebook as notebook

    ipython = types.ModuleType("IPython")
    shells = {"terminal": type("TerminalInteractiveShell", (), {})(), "kernel": type("ZMQInteractiveShell", (), {})()}
    for where, expected in (("terminal", False), ("kernel", True)):
        ipython.get_ipython = lambda where=where: shells[where]
        monkeypatch.setitem(sys.modules, "IPython", ipython)
        assert notebook.in_notebook() is expected
