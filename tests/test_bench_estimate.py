"""bench says how long it will take before it starts, and how far it is as it goes (issue 43: the README's
bench ran about 14 minutes unannounced), and benches auto by default."""
from __future__ import annotations

import sys

import caustica.bench.estimate as estimate
import caustica.bench.harness as harness
from caustica.cli import build_parser, main


def test_bench_estimates_up_front_and_reports_each_part(monkeypatch, capsys):
    calls = []

    def fake_speed_rows(scene, techniques, sizes, frames, log=print):
        calls.append(("speed", scene.name, tuple(techniques)))
        print("ROW", file=sys.stderr)
        return []

    monkeypatch.setattr(harness, "speed_rows", fake_speed_rows)
    monkeypatch.setenv("CAUSTICA_PROGRESS", "1")
    assert main(["bench", "--sizes", "64", "--no-mitsuba"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert calls == [("speed", "glass-sphere", ("auto", "env-map", "exact")),
                     ("speed", "caustic-sphere", ("auto", "env-map", "exact"))]
    assert err[0].startswith("caustica: bench: about ") and "speed caustic-sphere ~" in err[0], err
    assert err.index("ROW") > 0  # the estimate came before the first render
    assert [line.split(" parts done")[0] for line in err if "parts done" in line] == \
        ["caustica: bench: 1/2", "caustica: bench: 2/2"]
    assert "left" in next(line for line in err if "1/2 parts done" in line)


def test_the_readme_bench_is_estimated_at_minutes_and_exact_dominates_its_speed_rows():
    """The README's `bench --sizes 256,512`: the model puts it at 5 to 30 minutes (it ran about 14), most of
    the speed rows in exact on the scene with a diffuse floor."""
    import caustica

    args = build_parser().parse_args(["bench", "--sizes", "256,512"])
    ball = caustica.load_scene("caustic-sphere")
    speed = estimate.speed_seconds(ball, args.techniques, args.sizes, args.timing_frames)
    exact_only = estimate.speed_seconds(ball, ["exact"], args.sizes, args.timing_frames)
    quality = estimate.quality_seconds(ball, args.techniques, args.quality_size, args.reference_spp,
                                       args.max_spp, args.timing_frames)
    glass = caustica.load_scene("glass-sphere")
    total = speed + quality + estimate.speed_seconds(glass, args.techniques, args.sizes, args.timing_frames) \
        + estimate.quality_seconds(glass, args.techniques, args.quality_size, args.reference_spp, args.max_spp,
                                   args.timing_frames)
    assert 5 * 60 < total < 30 * 60
    assert exact_only > 0.5 * speed


def test_pace_scales_what_is_left_by_the_finished_parts(monkeypatch, capsys):
    now = [0.0]
    monkeypatch.setattr(estimate, "clock", lambda: now[0])
    monkeypatch.setenv("CAUSTICA_PROGRESS", "1")
    pace = estimate.Pace([("a", 10.0), ("b", 30.0)])
    pace.start()
    now[0] = 20.0  # the first part took twice its estimate: the second is expected to as well
    pace.done()
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == "caustica: bench: about 40 s in all on this machine's model (llvmpipe, 2 cores): a ~10 s, b ~30 s"
    assert lines[1] == "caustica: bench: 1/2 parts done (a) in 20 s, about 60 s left"
