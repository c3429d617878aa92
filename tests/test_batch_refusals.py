"""Refused and interrupted batches leave nothing behind and say why; sweep output templates, the
EGL device variable, environment files and technique names are checked in one line before any work."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import caustica
from caustica.cli import main

FAST = dict(size=(32, 24), spp=1, technique="plain")
PLAIN = ["--size", "32x24", "-t", "plain"]


def one_line_error(args: list[str], capsys) -> str:
    """The one stderr line of a command that must exit 2."""
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("caustica: ") and "Traceback" not in err, err
    return err


def stop_after(frames: int):
    """A progress callback that presses Ctrl-C once ``frames`` frames are rendered."""
    def callback(state):
        if state.rendered == frames:
            raise KeyboardInterrupt
    return callback


def test_a_dead_ray_cluster_fails_within_seconds_and_leaves_nothing(tmp_path, capsys):
    out = tmp_path / "new" / "out"
    start = time.monotonic()
    err = one_line_error(["batch", "glass-sphere", "-o", str(out), *PLAIN, "--ray", "127.0.0.1:1"], capsys)
    assert time.monotonic() - start < 10
    assert "cannot reach the Ray cluster at '127.0.0.1:1'" in err and "ray start --head" in err
    assert list(tmp_path.iterdir()) == []  # neither out nor the parent it would have made


def test_a_ray_address_ray_refuses_leaves_no_records(tmp_path, capsys):
    pytest.importorskip("ray", reason="Ray is not installed (pip install 'caustica[batch]')")
    out = tmp_path / "out"
    err = one_line_error(["batch", "glass-sphere", "-o", str(out), *PLAIN, "--ray", "garbage://x"], capsys)
    assert "garbage://x" in err
    assert not out.exists()


def test_a_refused_folder_keeps_exactly_what_it_held(tmp_path, capsys):
    out = tmp_path / "out"
    caustica.batch("glass-sphere", out, 1, **FAST)
    (out / ".batch.lock").unlink()  # as a folder copied from elsewhere holds it
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    err = one_line_error(["batch", "glass-sphere", "-o", str(out), *PLAIN, "--frames", "2"], capsys)
    assert "another job" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before  # no .batch.lock, nothing rewritten


def test_an_interrupted_run_says_what_it_kept(tmp_path):
    out = tmp_path / "out"

    with pytest.raises(KeyboardInterrupt, match=f"interrupted: kept 3 of 8 frames in {out}.*the other 5"):
        caustica.batch("glass-sphere", out, 8, orbit=90, progress=stop_after(3), **FAST)
    assert len((out / "manifest.jsonl").read_text().splitlines()) == 3


def test_an_interrupt_before_the_first_frame_leaves_no_folder(tmp_path, monkeypatch):
    from caustica.batch import workers

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt  # Ctrl-C while the workers start

    monkeypatch.setattr(workers, "render_frames", interrupted)
    with pytest.raises(KeyboardInterrupt, match="kept 0 of 4 frames"):
        caustica.batch("glass-sphere", tmp_path / "new" / "out", 4, **FAST)
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_on_the_command_line_reports_the_frames_kept(tmp_path):
    out = tmp_path / "out"
    command = [sys.executable, "-m", "caustica.cli", "batch", "glass-sphere", "-o", str(out), "--frames", "5000",
               "--orbit", "360", *PLAIN, "--workers", "2", "--no-progress"]
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    manifest = out / "manifest.jsonl"
    while time.monotonic() < deadline and not (manifest.exists() and manifest.read_text().count("\n") >= 2):
        time.sleep(0.02)
    child.send_signal(signal.SIGINT)
    _, err = child.communicate(timeout=60)
    kept = len([line for line in manifest.read_text().splitlines() if "error" not in json.loads(line)])
    assert child.returncode == 130, err
    assert err.strip().splitlines() == [f"caustica: interrupted: kept {kept} of 5000 frames in {out} (manifest.jsonl); "
                                        f"run the same command again to render the other {5000 - kept}"]


BAD_OUTPUTS = [
    ("f{index:1000000000d}", "pads the frame number to 1000000000 characters"),
    ("f{index:c}", "{index:c} is not an integer format"),
    ("f{index!r}", "{index!r} is not an integer format"),
    ("f{index:.3f}", "{index:.3f} is not an integer format"),
    ("f{index:{index}}", "{index:{index}} is not an integer format"),
    ("f{index:,x}", "is not a format string"),
    ("x" * 250 + "{index}", "makes names of up to 257 bytes"),
    ("a/" * 500 + "{index}", "makes names of up to 1007 bytes"),
    ("\u00e9" * 120 + "{index}", "makes names of up to 247 bytes"),
    ("f{index", "is not a format string"),
    ("frame", "must use {index}"),
    ("../{index}", "outside the output folder"),
]


@pytest.mark.parametrize("pattern, problem", BAD_OUTPUTS, ids=[p[:24] for p, _ in BAD_OUTPUTS])
def test_bad_output_templates_are_refused_before_formatting(pattern, problem):
    from caustica.batch.sweep import check_output

    start = time.monotonic()
    with pytest.raises(caustica.CausticaError) as caught:
        check_output(pattern)
    assert problem in str(caught.value) and "\n" not in str(caught.value)
    assert time.monotonic() - start < 1.0


@pytest.mark.parametrize("pattern", ["frame_{index:06d}", "{index}", "shots/{index:x}", "f{index:_>8}",
                                     "{index:0>8,d}", "a{index:b}b{index:04o}"])
def test_sane_output_templates_are_kept(pattern):
    from caustica.batch.sweep import check_output

    assert check_output(pattern) == pattern


def test_a_sweep_without_scene_says_so(tmp_path, capsys):
    sweep = tmp_path / "sweep.toml"
    sweep.write_text("frames = 3\nseed = 4\n[camera]\norbit = 90\n")
    err = one_line_error(["batch", str(sweep), "-o", str(tmp_path / "out"), *PLAIN], capsys)
    assert "sweep.toml: a sweep needs scene = ... at its top" in err and "'frames, seed'" in err
    assert "unknown key" not in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("value, problem", [("abc", "'abc' must be an EGL device index"),
                                            ("-1", "'-1' must be an EGL device index"),
                                            ("", "'' must be an EGL device index"),
                                            ("99", "'99': there is no EGL device 99 on this machine (EGL lists")])
@pytest.mark.parametrize("command", ["render", "batch"])
def test_the_egl_device_variable_is_one_line(value, problem, command, tmp_path, capsys, monkeypatch):
    from caustica.gpu import context
    from caustica.gpu.egl_devices import ENV, egl_devices

    if value == "99" and not egl_devices():
        pytest.skip("EGL lists no devices here: no range to check")
    monkeypatch.setattr(context, "_shared_context", None)  # this process's context is made again, from the variable
    monkeypatch.setenv(ENV, value)
    out = tmp_path / ("x.png" if command == "render" else "out")
    err = one_line_error([command, "glass-sphere", "-o", str(out), *PLAIN], capsys)
    assert f"CAUSTICA_EGL_DEVICE={problem}" in err and "apt-get" not in err
    assert "unset it" in err and not out.exists()


def test_env_device_parser(monkeypatch):
    from caustica.errors import DeviceError
    from caustica.gpu.egl_devices import ENV, EglDevice, checked_env_device, env_device

    monkeypatch.delenv(ENV, raising=False)
    assert env_device() is None and checked_env_device([]) is None
    monkeypatch.setenv(ENV, " 1 ")
    assert env_device() == 1 and checked_env_device([EglDevice(0), EglDevice(1)]) == 1
    with pytest.raises(DeviceError, match=r"EGL lists 1, index 0: 0 software \(llvmpipe\)"):
        checked_env_device([EglDevice(0, frozenset({"EGL_MESA_device_software"}))])
    for bad in ("1.0", "0x1", "\u0661", "1e3"):  # not plain decimal digits (\u0661: an Arabic-Indic one)
        monkeypatch.setenv(ENV, bad)
        with pytest.raises(DeviceError, match="must be an EGL device index"):
            env_device()


def test_negative_environment_radiance_is_refused():
    from caustica.scene.environment import Environment

    image = np.ones((4, 8, 3), np.float32)
    image[2, 5, 0] = -0.1
    image[3, 1] = -2.0
    with pytest.raises(caustica.CausticaError, match=r"negative radiance in 2 pixels \(the first at row 2, column "
                                                     r"5: \[-0\.1.*clamp the image at 0"):
        Environment(image, source="test")
    Environment(np.maximum(image, 0.0), source="test")  # the fix works
    Environment(-np.zeros((4, 8, 3), np.float32), source="test")  # -0.0 is no negative radiance


def test_environment_paths_that_are_not_files_say_what_they_are(tmp_path):
    from caustica.scene.environment import environment_option

    (tmp_path / "folder.exr").mkdir()
    os.mkfifo(tmp_path / "pipe.hdr")
    (tmp_path / "zero.exr").symlink_to("/dev/zero")
    (tmp_path / "gone.exr").symlink_to(tmp_path / "nowhere.exr")
    cases = {"folder.exr": "folder.exr is a directory, not an image file",
             "pipe.hdr": "pipe.hdr is a named pipe (FIFO), not an image file",
             "zero.exr": "zero.exr links to /dev/zero, a character device, not an image file",
             "gone.exr": "environment file not found"}
    for name, problem in cases.items():
        start = time.monotonic()
        with pytest.raises(caustica.CausticaError) as caught:
            environment_option(str(tmp_path / name))
        assert problem in str(caught.value), (name, str(caught.value))
        assert time.monotonic() - start < 2.0  # the FIFO was never opened (that would block)


def test_technique_names_suggest_the_right_case(capsys):
    from caustica.errors import closest_name
    from caustica.techniques import get_technique

    with pytest.raises(caustica.CausticaError, match=r"unknown technique 'EXACT' \(did you mean 'exact'\?\)"):
        get_technique("EXACT")
    with pytest.raises(caustica.CausticaError, match=r"'Env-Map' \(did you mean 'env-map'\?\)"):
        get_technique("Env-Map+caustic-mapping")
    assert closest_name("Glass-Sphere", ["glass-sphere", "glass-spheres"]) == " (did you mean 'glass-sphere'?)"
    assert closest_name("zzz", ["exact"]) == ""
    assert get_technique("exact").name == "exact"  # names themselves stay case-sensitive: only the hint folds


def test_a_resumed_folder_keeps_its_records_when_the_run_fails(tmp_path, capsys):
    """A run of the folder's own job that fails before its next frame (a dead cluster) removes nothing."""
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        caustica.batch("glass-sphere", out, 3, orbit=30, progress=stop_after(2), **FAST)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    err = one_line_error(["batch", "glass-sphere", "-o", str(out), *PLAIN, "--frames", "3", "--orbit", "30",
                          "--ray", "127.0.0.1:1"], capsys)
    assert "cannot reach the Ray cluster" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_a_run_refused_by_the_lock_leaves_the_other_runs_records(tmp_path, monkeypatch):
    from caustica.batch.manifest import Manifest

    held = Manifest(tmp_path / "out")
    (tmp_path / "out").mkdir()
    held.lock()
    lock = Manifest.lock

    def other_run_writes_first(self):
        """The other run writes its fresh folder's records just before this one asks for the lock."""
        (self.dir / "job.json").write_text('{"key": "other"}')
        (self.dir / "manifest.jsonl").write_text("")
        lock(self)

    monkeypatch.setattr(Manifest, "lock", other_run_writes_first)
    try:
        with pytest.raises(caustica.OutputError, match="another caustica batch is writing"):
            caustica.batch("glass-sphere", tmp_path / "out", 1, **FAST)
        assert sorted(p.name for p in (tmp_path / "out").iterdir()) == [".batch.lock", "job.json", "manifest.jsonl"]
    finally:
        held.unlock()
