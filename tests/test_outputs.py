"""Outputs: refused before the render when they cannot be written, written atomically, no temporary
file left by an error, Ctrl-C, SIGTERM or a killed run; cache names never escape their folder; the
samples per pixel that are asked for are the ones rendered; HDR decoding; the notebook's widgets."""
from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest

from caustica.atomic import STALE_SECONDS, check_writable, sweep_stale, temp_path, write_atomic
from caustica.cli import main
from caustica.errors import MissingExtraError, OutputError, TechniqueError
from caustica.images import write_image

ROOT = os.geteuid() == 0 if hasattr(os, "geteuid") else False


def image():
    return np.linspace(0.0, 1.0, 4 * 4 * 3, dtype=np.float32).reshape(4, 4, 3)


def one_line_error(code, err, *fragments):
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("caustica: ") and "Traceback" not in err, err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.fixture
def no_render(monkeypatch):
    """A render reached before an output is checked fails the test."""
    from caustica.renderer import Renderer

    def refuse(*args, **kwargs):
        raise AssertionError("rendered before the output was checked")

    monkeypatch.setattr(Renderer, "render_timed", refuse)
    monkeypatch.setattr(Renderer, "render", refuse)


# Unwritable outputs, refused up front ------------------------------------------------------------


def unwritable(tmp_path: Path, kind: str) -> tuple[str, str]:
    """An output path of one unwritable kind, and a fragment of the expected message."""
    if kind == "proc":
        return "/proc/caustica-test.png", "/proc"
    if kind == "sys":
        return "/sys/caustica-test.png", "/sys"
    if kind == "directory":
        (tmp_path / "out.png").mkdir()
        return str(tmp_path / "out.png"), "is a directory"
    if kind == "parent-is-file":
        (tmp_path / "afile").write_text("x")
        return str(tmp_path / "afile" / "out.png"), "is a file, not a directory"
    if kind == "name-too-long":
        return str(tmp_path / ("n" * 252 + ".png")), "longer than the 255"
    if kind == "missing-parent":  # missing folders are made (issue 43), but not below a file
        (tmp_path / "afile").write_text("x")
        return str(tmp_path / "afile" / "missing" / "out.png"), "is a file, not a directory"
    raise AssertionError(kind)


KINDS = ["proc", "sys", "directory", "parent-is-file", "name-too-long", "missing-parent"]


@pytest.mark.parametrize("kind", KINDS)
def test_render_refuses_unwritable_output_before_rendering(kind, tmp_path, capsys, no_render):
    if kind == "sys" and not Path("/sys").is_dir():
        pytest.skip("no /sys here")
    path, fragment = unwritable(tmp_path, kind)
    before = sorted(p.name for p in tmp_path.iterdir())
    code = main(["render", "glass-sphere", "-o", path, "--size", "8x8", "--frames", "1"])
    one_line_error(code, capsys.readouterr().err, fragment)
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert not os.path.isfile(path)


@pytest.mark.parametrize("argv", [
    ["compare", "glass-sphere", "--json", "{out}.json"],
    ["compare", "glass-sphere", "--sheet", "{out}.png"],
    ["bench", "--scenes", "glass-sphere", "--json", "{out}.json"],
    ["bench", "--scenes", "glass-sphere", "--plot", "{out}.png"],
    ["precompute", "mesh.obj", "--ior", "1.5", "-o", "{out}.npz"],
])
def test_every_command_checks_its_outputs(argv, tmp_path, capsys, monkeypatch, no_render):
    import caustica.atomic as atomic

    monkeypatch.setattr(atomic, "_name_max", lambda directory: 20)  # "a name too long" on any file system
    out = str(tmp_path / ("x" * 30))
    code = main([a.format(out=out) for a in argv])
    one_line_error(code, capsys.readouterr().err, "longer than the 20")
    assert list(tmp_path.iterdir()) == []


def test_api_refuses_a_device_or_a_directory_as_target(tmp_path):
    with pytest.raises(OutputError, match="not a regular file"):
        check_writable("/dev/null")
    (tmp_path / "d.exr").mkdir()
    with pytest.raises(OutputError, match="is a directory"):
        check_writable(tmp_path / "d.exr")
    with pytest.raises(OutputError, match="directory"):
        write_image(tmp_path / "d.exr", image())
    assert [p.name for p in tmp_path.iterdir()] == ["d.exr"] and not any((tmp_path / "d.exr").iterdir())


@pytest.mark.skipif(ROOT, reason="root ignores directory permissions (the read-only mount test covers it)")
def test_read_only_directory_refused_before_rendering(tmp_path, capsys, no_render):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        code = main(["render", "glass-sphere", "-o", str(folder / "out.png"), "--size", "8x8"])
        one_line_error(code, capsys.readouterr().err, "no permission")
        assert list(folder.iterdir()) == []
    finally:
        folder.chmod(0o755)


def _private_mounts() -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = subprocess.run(["unshare", "-m", "sh", "-c", "mount -t tmpfs -o ro,size=64k none /mnt"],
                           capture_output=True, timeout=30)
    return probe.returncode == 0


def test_read_only_file_system_refused_before_rendering(tmp_path):
    # A read-only tmpfs in a private mount namespace: seen by this command only, gone when it ends.
    if not _private_mounts():
        pytest.skip("cannot mount a private read-only tmpfs here (needs unshare and CAP_SYS_ADMIN)")
    folder = tmp_path / "ro"
    folder.mkdir()
    command = (f"mount -t tmpfs -o ro,size=64k none {folder} && exec {sys.executable} -m caustica.cli "
               f"render glass-sphere -o {folder}/out.png --size 8x8 --frames 1")
    done = subprocess.run(["unshare", "-m", "sh", "-c", command], capture_output=True, text=True, timeout=300)
    one_line_error(done.returncode, done.stderr, "read-only file system")
    assert list(folder.iterdir()) == []


# Temporary names ----------------------------------------------------------------------------------


def test_temporary_names_fit_the_name_limit(tmp_path):
    for name in ["a.png", "n" * 251 + ".png", "é" * 125 + ".exr"]:  # 5, 255 and 254 bytes
        tmp = temp_path(tmp_path / name)
        assert len(os.fsencode(tmp.name)) <= 255 and tmp.name.startswith(".") and tmp.name.endswith(".tmp")
        assert check_writable(tmp_path / name) == tmp_path / name
        write_image(tmp_path / name, image())
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["a.png", "n" * 251 + ".png", "é" * 125 + ".exr"])
    assert temp_path(tmp_path / "a.png").name.startswith(f".a.png.{os.getpid()}.")


def test_keyboard_interrupt_during_write_leaves_no_temporary(tmp_path, monkeypatch):
    import caustica.images as images

    def interrupted(tmp, pixels):
        Path(tmp).write_bytes(b"half")
        raise KeyboardInterrupt

    monkeypatch.setattr(images, "_write_exr", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_image(tmp_path / "out.exr", image())
    assert list(tmp_path.iterdir()) == []


def test_cache_writes_share_the_atomic_writer(tmp_path, monkeypatch):
    from caustica.cache import atomic_write_bytes, store_array

    target = tmp_path / "sub" / "a.npy"
    assert store_array(target, np.arange(3.0))
    assert [p.name for p in target.parent.iterdir()] == ["a.npy"]
    (tmp_path / "ro.npy").mkdir()  # a directory in the way: OutputError, an OSError, nothing left
    with pytest.raises(OutputError, match="a directory is in the way"):
        atomic_write_bytes(tmp_path / "ro.npy", b"x")
    assert not store_array(tmp_path / "ro.npy", np.arange(3.0))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ro.npy", "sub"]


SLOW_WRITE = """
import sys, time
import caustica.images as images
real = images._write_exr
def slow(tmp, image):
    real(tmp, image)
    print("writing", flush=True)
    time.sleep(120)
images._write_exr = slow
from caustica.cli import main
sys.exit(main(["render", "glass-sphere", "-o", sys.argv[1], "--size", "8x8", "--frames", "1"]))
"""


@pytest.mark.parametrize("signum, code, message", [
    (signal.SIGTERM, 128 + signal.SIGTERM, "terminated by SIGTERM"),
    (signal.SIGINT, 130, "interrupted"),
])
def test_signal_during_write_leaves_no_temporary(signum, code, message, tmp_path):
    # The writer holds the temporary (complete, not yet renamed) until the signal comes.
    out = tmp_path / "out.exr"
    child = subprocess.Popen([sys.executable, "-c", SLOW_WRITE, str(out)], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True)
    try:
        assert child.stdout.readline().strip() == "writing", child.communicate(timeout=60)
        assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
        child.send_signal(signum)
        _, err = child.communicate(timeout=60)
    finally:
        child.kill()
        child.wait()
    assert child.returncode == code, err
    assert err.strip() == f"caustica: {message}"
    assert list(tmp_path.iterdir()) == []


def test_sigterm_while_rendering_exits_cleanly(tmp_path):
    # Through the installed command: a terminated run exits non-zero and leaves nothing.
    out = tmp_path / "out.exr"
    child = subprocess.Popen([sys.executable, "-m", "caustica.cli", "render", "glass-sphere", "-o", str(out),
                              "--size", "16x16", "--frames", "100000"],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(3.0)
    child.send_signal(signal.SIGTERM)
    _, err = child.communicate(timeout=120)
    assert child.returncode != 0 and "Traceback" not in err, err
    assert not any(p.name.endswith(".tmp") for p in tmp_path.iterdir())


def test_stale_temporaries_are_swept_on_the_next_write(tmp_path):
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    hexes = iter(f"{i:012x}" for i in range(100))
    names = {
        "dead_pid": f".out.exr.{dead.pid}.{next(hexes)}.tmp",
        "old_live": f".out.exr.{os.getpid()}.{next(hexes)}.tmp",
        "old_legacy": f".out.exr.{next(hexes)}.tmp",
        "fresh_live": f".out.exr.{os.getpid()}.{next(hexes)}.tmp",
        "fresh_legacy": f".out.exr.{next(hexes)}.tmp",
        "other_target": f".other.exr.{dead.pid}.{next(hexes)}.tmp",
        "not_ours": ".out.exr.notes.tmp",
    }
    for key, name in names.items():
        (tmp_path / name).write_bytes(b"x")
        if key.startswith("old"):
            stamp = time.time() - STALE_SECONDS - 60
            os.utime(tmp_path / name, (stamp, stamp))
    write_image(tmp_path / "out.exr", image())
    left = {p.name for p in tmp_path.iterdir()}
    assert left == {"out.exr"} | {names[k] for k in ("fresh_live", "fresh_legacy", "other_target", "not_ours")}
    assert sweep_stale(tmp_path / "other.exr") == [tmp_path / names["other_target"]]


def test_stale_temporaries_of_shortened_names_are_swept(tmp_path):
    target = tmp_path / ("n" * 251 + ".png")
    leftover = temp_path(target)
    leftover.write_bytes(b"x")
    stamp = time.time() - STALE_SECONDS - 60
    os.utime(leftover, (stamp, stamp))
    write_atomic(target, lambda tmp: Path(tmp).write_bytes(b"done"))
    assert [p.name for p in tmp_path.iterdir()] == [target.name]


# Names never become paths --------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["../../x", "/etc/passwd", "a/../../b", "..", "", "x\0y", "é" * 300, "ok" * 100])
def test_reference_cache_file_stays_in_its_folder(name, tmp_path):
    from caustica.reference.render import reference_file_name
    from caustica import load_scene as load_preset

    scene = load_preset("glass-sphere")
    scene.name = name
    file_name = reference_file_name(scene, scene.camera, 4, 0, "0123456789abcdef")
    assert "/" not in file_name and "\0" not in file_name and not file_name.startswith(".")
    assert len(file_name) < 120
    assert (tmp_path / file_name).resolve().parent == tmp_path.resolve()


def test_preset_reference_names_are_unchanged():
    from caustica.reference.render import reference_file_name
    from caustica import load_scene as load_preset

    scene = load_preset("glass-sphere")
    assert reference_file_name(scene, scene.camera.with_size(32, 24), 8, 1, "k") == "glass-sphere-32x24-8spp-seed1-k.npy"


def test_compare_with_an_escaping_scene_name_writes_inside_the_cache(tmp_path, monkeypatch):
    pytest.importorskip("mitsuba")
    from caustica.reference.render import render_reference
    from caustica import load_scene as load_preset

    scene = load_preset("glass-sphere")
    scene.name = "../../escaped"
    cache = tmp_path / "cache" / "reference"
    render_reference(scene, size=(8, 8), spp=1, cache_dir=cache, progress=False)
    written = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert written and all(cache.resolve() in p.resolve().parents for p in written), written
    assert not (tmp_path / "escaped-8x8-1spp").exists() and not list(tmp_path.glob("escaped*"))


# Samples per pixel -----------------------------------------------------------------------------------


@pytest.mark.parametrize("technique, spp", [("env-map", 2), ("env-map", 3), ("exact", 2), ("exact", 8),
                                            ("depth-search+caustic-mapping", 5)])
def test_non_square_spp_is_refused(technique, spp):
    from caustica.renderer import Renderer
    from caustica import load_scene as load_preset

    with pytest.raises(TechniqueError, match=f"spp {spp} is not a square.*k x k"):
        Renderer((8, 8)).render(load_preset("glass-sphere"), technique, spp=spp)


def test_spp_rule_names_the_nearest_squares_and_spares_mitsuba():
    from caustica.techniques import get_technique
    from caustica.techniques.base import check_spp

    with pytest.raises(TechniqueError, match="use 1 or 4"):
        check_spp(get_technique("env-map"), 3)
    with pytest.raises(TechniqueError, match="use 9 or 16"):
        check_spp(get_technique("exact"), 10)
    for spp in (1, 4, 9, 16, 4096):
        check_spp(get_technique("env-map"), spp)
    for spp in (2, 3, 8, 100):  # Mitsuba's sampler renders any count
        check_spp(get_technique("mitsuba"), spp)


@pytest.mark.parametrize("argv", [
    ["render", "glass-sphere", "-o", "{tmp}/a.png", "--spp", "3"],
    ["compare", "glass-sphere", "--techniques", "env-map,exact", "--spp", "2"],
])
def test_cli_refuses_non_square_spp_before_rendering(argv, tmp_path, capsys, no_render):
    code = main([a.format(tmp=tmp_path) for a in argv])
    one_line_error(code, capsys.readouterr().err, "is not a square")
    assert list(tmp_path.iterdir()) == []


# The notebook's widgets -------------------------------------------------------------------------------


class _Widget:
    def __init__(self, *children, **kwargs):
        self.children = list(children[0]) if children else []
        self.__dict__.update(kwargs)
        self.observers = []

    def observe(self, callback, names=None):
        self.observers.append(callback)


def fake_ipywidgets() -> types.ModuleType:
    module = types.ModuleType("ipywidgets")
    for name in ("Image", "Label", "Dropdown", "FloatSlider", "IntSlider", "Checkbox", "IntText", "FloatText",
                 "VBox", "HBox"):
        setattr(module, name, type(name, (_Widget,), {}))
    return module


class FakeRenderer:
    def __init__(self, size=None, progress=None):
        self.size = size or (8, 8)

    def camera_for(self, scene):
        return scene.camera.with_size(*self.size)

    def render_timed(self, scene, technique, spp=1, **params):
        return np.full((self.size[1], self.size[0], 3), 0.5, np.float32), 1.0

    def render(self, scene, technique, spp=1, **params):
        return self.render_timed(scene, technique, spp, **params)[0]


def test_show_uses_ipywidgets_when_installed(monkeypatch):
    import caustica.renderer
    from caustica.notebook import show

    monkeypatch.setattr(caustica.renderer, "Renderer", FakeRenderer)
    monkeypatch.setitem(sys.modules, "ipywidgets", fake_ipywidgets())
    monkeypatch.setattr("caustica.notebook.in_notebook", lambda: True)  # outside one: test_first_steps.py
    view = show("glass-sphere")  # widgets=None: on, since ipywidgets imports
    assert type(view).__name__ == "HBox"
    picture = view.children[0].children[0]
    assert type(picture).__name__ == "Image" and picture.value.startswith(b"\x89PNG")
    assert type(show("glass-sphere", widgets=False)).__module__.startswith("PIL")


def test_show_without_ipywidgets(monkeypatch):
    import caustica.renderer
    from caustica.notebook import show

    monkeypatch.setattr(caustica.renderer, "Renderer", FakeRenderer)
    monkeypatch.setitem(sys.modules, "ipywidgets", None)  # import raises ImportError
    assert type(show("glass-sphere")).__module__.startswith("PIL")
    with pytest.raises(MissingExtraError, match=r"caustica\[notebook\]"):
        show("glass-sphere", widgets=True)


def test_notebook_extra_is_declared():
    import tomllib

    project = tomllib.loads((Path(__file__).resolve().parents[1] / "pyproject.toml").read_text())["project"]
    assert project["optional-dependencies"]["notebook"] == ["ipywidgets>=8"]

