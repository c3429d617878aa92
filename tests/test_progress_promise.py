"""Progress keeps docs/cli.md's promise off a terminal: a line each tenth of the work or every 10 s, whatever
the work's steps (issue 43: exact printed at 36 %, 72 % and 100 % with a 49 s gap); the API and
--timing-frames show it too."""
from __future__ import annotations

import io
import time

import numpy as np
import pytest

import caustica
import caustica.progress as progress_module
from caustica.cli import main
from caustica.progress import LINE_INTERVAL_S, _Lines


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def test_lines_come_every_interval_while_a_step_takes_long(monkeypatch):
    """exact's old steps on a fake clock: 36 % at 18 s, 72 % at 67 s, 100 % at 80 s; the heartbeat's ticks
    (each second here) fill the 49 s gap with lines at most LINE_INTERVAL_S apart."""
    clock = FakeClock()
    monkeypatch.setattr(progress_module, "clock", clock)
    out = io.StringIO()
    bar = _Lines(100, "exact", "rows", out, 0, 0.0, None, heartbeat=False)
    times = []
    steps = {18: 36, 67: 36, 80: 28}
    for second in range(1, 81):
        clock.now = float(second)
        before = out.getvalue().count("\n")
        if second in steps:
            bar.update(steps[second])
        bar.tick()
        times += [clock.now] * (out.getvalue().count("\n") - before)
    bar.close()
    gaps = np.diff([0.0, *times])
    assert gaps.max() <= LINE_INTERVAL_S, (times, out.getvalue())
    lines = out.getvalue().splitlines()
    assert lines[-1].startswith("exact: 100/100 rows (100%)")
    assert any(line.startswith("exact: 36/100 rows (36%), 58.0 s") for line in lines)  # still at 36 %, said so


def test_the_heartbeat_thread_writes_without_updates(monkeypatch):
    monkeypatch.setattr(progress_module, "LINE_INTERVAL_S", 0.05)
    out = io.StringIO()
    bar = _Lines(10, "slow", "steps", out, 0, 0.0, None)
    time.sleep(0.4)
    bar.close()
    assert out.getvalue().count("slow: 0/10 steps") >= 2, out.getvalue()
    written = out.getvalue()
    time.sleep(0.15)
    assert out.getvalue() == written  # closed: the thread stopped


def test_exact_moves_its_progress_in_twentieths_and_the_bands_do_not_change_the_image(monkeypatch):
    import caustica.techniques.exact as exact

    updates = []

    class Recorder(progress_module.Progress):
        def update(self, n=1):
            updates.append(n)

    monkeypatch.setattr(exact, "progress", lambda total, *a, **k: Recorder(None))
    scene = caustica.load_scene("caustic-sphere")
    params = {"caustic_photons": 0, "environment_samples": 2, "environment_light_samples": 1}
    with caustica.Renderer((16, 40)) as renderer:
        banded = renderer.render(scene, "exact", **params)
        assert len(updates) == 20 and max(updates) == 2
        monkeypatch.setattr(exact, "PROGRESS_BANDS", 1)
        updates.clear()
        whole = renderer.render(scene, "exact", **params)
    assert len(updates) == 1
    assert np.array_equal(banded, whole)


def test_the_api_shows_progress_off_a_terminal_when_asked(monkeypatch, capsys):
    """Renderer(progress=True): plain lines on a stderr that is no terminal (a notebook's); the default
    stays silent there (a library's convention)."""
    monkeypatch.setattr(progress_module, "DELAY_S", 0.0)
    monkeypatch.delenv(progress_module.ENV, raising=False)
    scene = caustica.load_scene("caustic-sphere")
    params = {"caustic_photons": 0, "environment_samples": 0}
    with caustica.Renderer((16, 12)) as quiet:
        quiet.render(scene, "exact", **params)
    assert "rows" not in capsys.readouterr().err
    with caustica.Renderer((16, 12), progress=True) as shown:
        shown.render(scene, "exact", **params)
    assert "exact caustic-sphere: 12/12 rows (100%)" in capsys.readouterr().err


def test_timing_frames_show_progress(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(progress_module.ENV, "1")
    code = main(["render", "glass-sphere", "-o", str(tmp_path / "x.png"), "--size", "16x16", "--timing-frames", "2"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "timing: 2/2 frames (100%)" in err


@pytest.mark.parametrize("args", [["-q"], ["--no-progress"]])
def test_quiet_and_no_progress_still_win(tmp_path, capsys, monkeypatch, args):
    monkeypatch.setenv(progress_module.ENV, "1")
    assert main([*args, "render", "glass-sphere", "-o", str(tmp_path / "x.png"), "--size", "16x16"]) == 0
    assert "timing" not in capsys.readouterr().err


def test_a_display_dropped_unclosed_stops_its_heartbeat(monkeypatch):
    import gc
    import threading

    monkeypatch.setattr(progress_module, "LINE_INTERVAL_S", 0.05)
    before = threading.active_count()
    out = io.StringIO()
    bar = _Lines(10, "dropped", "steps", out, 0, 0.0, None)
    assert threading.active_count() == before + 1
    del bar
    gc.collect()
    time.sleep(0.1)
    assert threading.active_count() == before
