"""Honest measurement in compare and bench (issue 43): the reference's own noise floor from two halves of its
samples, --reference-floor's sample count, the glints a path-traced reference cannot contain, and timing figures
that exclude warm-ups and never show an end-to-end time below the render's (fake clocks, not real timing)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import caustica
from caustica.cli import main
from caustica.metrics.floor import (FLOOR_MARGIN_DB, at_floor, combine_halves, halves_factor, measured_slope,
                                    noise_floor, spp_for_floor, split_spp)
from caustica.metrics.images import psnr_linear, psnr_srgb


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path / "cache"))


def noisy_halves(truth, sigma_per_sample, n_a, n_b, seed=3):
    """Two independent Monte Carlo halves of n_a and n_b samples of ``truth`` (Gaussian per-sample noise)."""
    rng = np.random.default_rng(seed)
    half = [truth + rng.normal(0.0, sigma_per_sample / math.sqrt(n), truth.shape) for n in (n_a, n_b)]
    return [h.astype(np.float32) for h in half]


@pytest.mark.parametrize("n_a, n_b", [(128, 128), (3, 1), (17, 16)])
def test_the_floor_from_halves_is_the_whole_references_own_error(n_a, n_b):
    """The floor estimated from the halves alone matches the combined reference's PSNR against the noise-free
    image (what a perfect technique would score), within 0.1 dB; the halves' own PSNR is 6 dB lower for equal
    halves: a half's error is 3 dB under the halves' difference, and the whole has twice a half's samples."""
    truth = np.full((256, 256, 3), 0.4)
    half_a, half_b = noisy_halves(truth, 0.05, n_a, n_b)  # small against the signal: no clipping, sRGB near linear
    whole = combine_halves(half_a, half_b, n_a, n_b)
    floor = noise_floor(half_a, half_b, n_a, n_b)["all"]
    assert floor["psnr_linear"] == pytest.approx(psnr_linear(whole, truth), abs=0.1)
    assert floor["psnr_srgb"] == pytest.approx(psnr_srgb(whole, truth), abs=0.1)
    gap = floor["psnr_linear"] - psnr_linear(half_a, half_b)
    assert gap == pytest.approx(-10 * math.log10(halves_factor(n_a, n_b)))
    if n_a == n_b:
        assert gap == pytest.approx(6.02, abs=0.01)


def test_split_spp_and_combine_weigh_by_sample_count():
    assert split_spp(256) == (128, 128) and split_spp(5) == (3, 2)
    whole = combine_halves(np.ones((2, 2, 3)), np.zeros((2, 2, 3)), 3, 1)
    assert np.allclose(whole, 0.75)


def test_spp_for_a_floor_follows_one_over_spp():
    """+3 dB per doubling: 6 dB above a 32 spp pilot's floor needs 4 x 32 (127.4, rounded up to an even 128);
    a floor the pilot already beats keeps the pilot's count; odd estimates round up to even (two equal halves)."""
    assert spp_for_floor(32, 30.0, 36.0) == 128
    assert spp_for_floor(32, 30.0, 20.0) == 32
    assert spp_for_floor(32, 30.0, 30.0 + 10 * math.log10(101 / 32)) == 102
    assert spp_for_floor(32, math.inf, 50.0) == 32
    # A floor that grew half as fast as 1/spp predicts: the next count follows the growth seen.
    assert measured_slope(32, 30.0, 128, 36.02) == pytest.approx(1.0, abs=1e-3)
    assert measured_slope(32, 30.0, 128, 33.01) == pytest.approx(0.5, abs=1e-3)
    assert spp_for_floor(32, 30.0, 36.0, slope=0.5) == 2 * math.ceil(32 * 10 ** 1.2 / 2)


def test_at_floor_flags_only_figures_within_3_db_of_the_floor():
    floor = {"psnr_linear": 30.0, "psnr_srgb": 28.0, "relmse": 0.01}
    near = {"psnr_linear": 30.0 - FLOOR_MARGIN_DB + 0.01, "psnr_srgb": 28.0 - FLOOR_MARGIN_DB - 0.5, "relmse": 0.019}
    assert at_floor(near, floor) == ["psnr_linear", "relmse"]
    far = {"psnr_linear": 20.0, "psnr_srgb": 20.0, "relmse": 0.05}
    assert at_floor(far, floor) == []
    assert at_floor({**far, "psnr_srgb": math.nan}, {**floor, "relmse": math.nan}) == []


def fake_halves(monkeypatch, sigma, tail=0.0):
    """reference_halves that returns Gaussian noise of ``sigma`` per sample around grey (no Mitsuba), recording
    the spp it was asked for; ``tail`` > 0 grows the per-sample noise as (spp / 32)^tail, as a heavy-tailed
    estimator's measured noise does when more samples catch more of its rare bright paths."""
    from caustica.bench import compare as compare_module

    asked = []

    def halves(scene, size, spp, progress=None):
        asked.append(spp)
        n_a, n_b = split_spp(spp)
        a, b = noisy_halves(np.full((size[1], size[0], 3), 0.3), sigma * (spp / 32) ** tail, n_a, n_b,
                            seed=len(asked))
        return combine_halves(a, b, n_a, n_b), (a, b, n_a, n_b)

    monkeypatch.setattr(compare_module, "reference_halves", halves)
    return asked


def test_reference_floor_picks_the_spp_from_a_pilot_and_says_when_capped(monkeypatch):
    from caustica.bench import compare as compare_module
    from caustica.bench.compare import PILOT_SPP, spp_for_reference_floor

    scene = caustica.load_scene("caustic-sphere")
    asked = fake_halves(monkeypatch, sigma=0.2)
    spp, note = spp_for_reference_floor(scene, (64, 64), 38.0)
    assert spp > 4 * PILOT_SPP and asked == [PILOT_SPP, spp]  # the pilot, then one render at the predicted count, which reaches it
    # The predicted count reaches the floor: the same noise at that count measures 38 dB, within 0.3.
    _, (a, b, n_a, n_b) = compare_module.reference_halves(scene, (64, 64), spp)
    assert noise_floor(a, b, n_a, n_b)["all"]["psnr_srgb"] == pytest.approx(38.0, abs=0.3)
    assert f"{spp} spp for a 38 dB floor" in note and "cap" not in note
    spp, note = spp_for_reference_floor(scene, (64, 64), 70.0, cap=256)
    assert spp == 256 and "more than the cap of 256" in note and "lower --reference-floor" in note


def test_reference_floor_corrects_a_pilot_that_saw_too_little_noise(monkeypatch):
    """Where the measured noise falls slower than 1/spp (the pilot missed rare bright paths), the render at the
    pilot's count falls short; the next, predicted from that render, reaches the floor within 0.25 dB."""
    from caustica.bench import compare as compare_module
    from caustica.bench.compare import FLOOR_TOLERANCE_DB, PILOT_SPP, spp_for_reference_floor

    scene = caustica.load_scene("caustic-sphere")
    asked = fake_halves(monkeypatch, sigma=0.2, tail=0.2)
    spp, note = spp_for_reference_floor(scene, (64, 64), 40.0)
    assert asked[0] == PILOT_SPP and len(asked) >= 3 and asked[-1] == spp and asked[1] < spp
    _, halves = compare_module.reference_halves(scene, (64, 64), spp)
    assert noise_floor(*halves)["all"]["psnr_srgb"] >= 40.0 - FLOOR_TOLERANCE_DB - 0.2
    assert note.count(" dB") >= 3  # the pilot's and each render's floor


def test_compare_reports_the_floor_in_the_table_json_and_sheet(tmp_path, capsys):
    """The floor row in every region's block, its line in the head, and the JSON: its spp, halves, per-region
    figures, and each technique's flagged figures (all within 3 dB of the floor, none far from it)."""
    pytest.importorskip("mitsuba", reason="the reference extra is not installed")
    pytest.importorskip("flip_evaluator", reason="the metrics extra is not installed")
    out, sheet = tmp_path / "c.json", tmp_path / "c.png"
    assert main(["compare", "caustic-sphere", "--size", "32x24", "--spp", "1", "--reference-spp", "9",
                 "--timing-frames", "1", "--techniques", "env-map", "--json", str(out), "--sheet", str(sheet)]) == 0
    table = capsys.readouterr().out
    assert table.count("(reference floor)") == 4 and "reference noise floor (from two independent halves of its 5+4" \
        in table
    data = json.loads(out.read_text())
    floor = data["reference_floor"]
    assert floor["spp"] == 9 and floor["halves"] == [5, 4] and set(floor["regions"]) == {"all", "refractor",
                                                                                        "caustic", "rest"}
    entry = data["techniques"][0]
    for region, flagged in entry["at_reference_floor"].items():
        for key in ("psnr_linear", "psnr_srgb"):
            near = float(entry["regions"][region][key]) >= float(floor["regions"][region][key]) - FLOOR_MARGIN_DB
            assert (key in flagged) == near
    assert sheet.stat().st_size > 0


def test_compare_sheet_title_names_the_floor():
    from caustica.bench.compare import CompareResult, ReferenceFloor
    from caustica.bench.sheet import sheet_title, technique_caption

    floor = ReferenceFloor(256, (128, 128), {"all": {"psnr_linear": 31.0, "psnr_srgb": 30.04, "relmse": 0.01}})
    result = CompareResult("s", (128, 96), 4, "mitsuba (256 spp, x)", "llvmpipe", {}, [], None, floor)
    assert "reference: mitsuba at 256 spp  noise floor 30.04 dB" in sheet_title(result)
    entry = {"ms_per_frame": 1.0, "regions": {"all": {"psnr_srgb": 29.5, "flip": 0.1}},
             "at_reference_floor": {"all": ["psnr_srgb"]}}
    assert "PSNR 29.50 dB*" in technique_caption(entry)


# Timing ---------------------------------------------------------------------------------------------------


class RecordingRenderer:
    """A Renderer stand-in: records (size, call, technique); the n-th timed frame takes ``frames[n]`` ms."""

    log: list = []

    def __init__(self, size, frames=(5.0, 7.0, 6.0)):
        self.size, self.frames, self.timed = size, list(frames), 0

    def camera_for(self, scene):
        return scene.camera.with_size(*self.size)

    def render(self, scene, technique, spp, **params):
        RecordingRenderer.log.append((self.size, "warm-up", technique))

    def render_timed(self, scene, technique, spp, **params):
        RecordingRenderer.log.append((self.size, "timed", technique))
        self.timed += 1
        return None, self.frames[self.timed - 1]


@pytest.mark.parametrize("technique, warm_size, timed", [("env-map", (256, 128), 3), ("exact", (16, 8), 1)])
def test_timed_render_warms_up_untimed_and_times_only_frames(technique, warm_size, timed):
    """Every technique gets an untimed warm-up (the per-scene setup that made exact's first size 2.7x slower than
    its second): GPU ones at the renderer's size, CPU ones in a 16-pixel frame; the figure is the frames' median."""
    from caustica.bench.timing import timed_render

    RecordingRenderer.log = []
    renderer = RecordingRenderer((256, 128))
    _, ms = timed_render(renderer, caustica.load_scene("glass-sphere"), technique, 1, 3)
    assert RecordingRenderer.log == [(warm_size, "warm-up", technique)] + [((256, 128), "timed", technique)] * timed
    assert ms == (6.0 if timed == 3 else 5.0)


class FakeClock:
    """perf_counter stand-in: each call returns the next of ``times``."""

    def __init__(self, times):
        self.times = iter(times)

    def __call__(self):
        return next(self.times)


def test_first_and_fastest_keeps_the_compiling_call_apart():
    from caustica.reference.render import first_and_fastest

    calls = iter(range(10))
    result, first, fastest = first_and_fastest(lambda: next(calls), 2, FakeClock([0.0, 5.0, 5.0, 6.5, 6.5, 7.7]))
    assert (result, first, fastest) == (2, 5.0, pytest.approx(1.2))


def test_end_to_end_is_setup_plus_first_call_and_never_below_the_render():
    from caustica.bench.timing import end_to_end_seconds

    assert end_to_end_seconds(0.3, [2.0], [1.2]) == pytest.approx(2.3)
    assert end_to_end_seconds(0.3, [1.0], [1.52]) == pytest.approx(1.82)  # a first call undercut by noise
    assert end_to_end_seconds(0.5, [0.1, 3.0], [1.0, 2.0]) == pytest.approx(4.5)  # render by render


class FakeMitsuba:
    """mi stand-in: render returns a constant image."""

    def render(self, loaded, spp, seed):
        return np.full((2, 3, 3), float(loaded))


def test_loaded_reference_render_times_the_warm_call_and_records_the_first():
    """Per render: the timed figure is the call after the first (which compiles at a new spp), the first call's
    seconds are kept in last_first_seconds; the seconds of one render key add up over dispersion channels."""
    from caustica.reference.render import LoadedReference

    loaded = object.__new__(LoadedReference)
    loaded.mi, loaded.channels = FakeMitsuba(), [None]
    loaded.renders = [("path", "lights"), ("ptracer", "lights")]
    loaded.scenes = {(None, "path", "lights"): 1.0, (None, "ptracer", "lights"): 2.0}
    loaded.weights = {("path", "lights"): 0.25, ("ptracer", "lights"): 0.75}
    loaded.camera = caustica.load_scene("glass-sphere").camera.with_size(3, 2)
    # path: first call 0 -> 4, timed 4 -> 5; ptracer: first 10 -> 13, timed 13 -> 15
    loaded.clock = FakeClock([0.0, 4.0, 4.0, 5.0, 10.0, 13.0, 13.0, 15.0])
    image, seconds = loaded.render(8)
    assert np.allclose(image, 0.25 * 1.0 + 0.75 * 2.0)
    assert seconds == {("path", "lights"): 1.0, ("ptracer", "lights"): 2.0}
    assert loaded.last_first_seconds == {("path", "lights"): 4.0, ("ptracer", "lights"): 3.0}


def test_mitsuba_curve_labels_render_and_end_to_end_and_orders_them(monkeypatch):
    """The curve's points: render seconds (warm calls), end to end (setup + first calls) >= render even where a
    first call was faster, the caustic region's renders apart; every printed figure says which it is."""
    from caustica.bench import harness
    from caustica.reference import render as render_module

    class FakeLoaded:
        def __init__(self, scene, size):
            self.weights = {("path", "lights"): np.array([[1.0, 0.0]]), ("ptracer", "lights"): np.array([[0.0, 1.0]])}
            self.renders = list(self.weights)
            self.setup_seconds = 0.5

        def render(self, spp, seed=1, repeats=1):
            self.last_first_seconds = {("path", "lights"): 0.1 * spp, ("ptracer", "lights"): 3.0 * spp}
            return np.zeros((1, 2, 3)), {("path", "lights"): 1.0 * spp, ("ptracer", "lights"): 2.0 * spp}

    monkeypatch.setattr(render_module, "LoadedReference", FakeLoaded)
    lines = []
    curve = harness.mitsuba_curve(caustica.load_scene("glass-sphere"), (2, 1), lambda image: {"relmse": 1.0},
                                  np.array([[False, True]]), 2, log=lines.append)
    assert [c["spp"] for c in curve] == [1, 2]
    one = curve[0]
    assert one["seconds"] == 3.0 and one["end_to_end_seconds"] == pytest.approx(0.5 + 1.0 + 3.0)
    assert one["seconds_caustic"] == 2.0 and one["end_to_end_seconds_caustic"] == pytest.approx(0.5 + 3.0)
    assert all(c["end_to_end_seconds"] >= c["seconds"] for c in curve)
    assert "render 3.00 s (loaded and compiled), end to end 4.50 s (export, load and compile included)" in lines[0]
    assert "caustic region's renders: render 2.00 s" in lines[0]


def test_speed_against_mitsuba_reads_right_under_one():
    from caustica.bench.harness import speed_text

    assert [speed_text(r) for r in (219.4, 3.24, 0.315, 0.01)] == ["x219 faster", "x3.2 faster", "x3.2 slower",
                                                                   "x100 slower"]


# Glints --------------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def ball_over_floor():
    scene = caustica.load_scene("caustic-sphere")
    return scene, scene.camera.with_size(64, 48)


def test_glints_are_where_a_lights_caustic_is_seen_in_or_through_glass(ball_over_floor):
    """caustic_through_glass holds glass pixels only (the ball's), some of them; a technique much brighter than
    the reference everywhere shows glints only there; one equal to it, or within half its value, none."""
    from caustica.metrics import region_masks
    from caustica.metrics.regions import caustic_through_glass, glint_mask

    scene, camera = ball_over_floor
    seen = caustic_through_glass(scene, camera)
    regions = region_masks(scene, camera, spp=4)
    assert 0 < seen.sum() < regions["refractor"].sum()
    assert not (seen & ~regions["refractor"] & ~_touches(regions["refractor"])).any()
    reference = np.full((48, 64, 3), 0.3, np.float32)
    assert not glint_mask(scene, camera, [reference], reference, seen).any()
    assert not glint_mask(scene, camera, [reference * 1.4], reference, seen).any()
    assert (glint_mask(scene, camera, [reference, reference * 4.0], reference, seen) == seen).all()


def _touches(mask):
    """Pixels next to ``mask`` (a footprint partly on glass counts where any of its samples is)."""
    grown = mask.copy()
    grown[1:] |= mask[:-1]
    grown[:-1] |= mask[1:]
    grown[:, 1:] |= mask[:, :-1]
    grown[:, :-1] |= mask[:, 1:]
    return grown


def test_no_light_no_glint(ball_over_floor):
    from dataclasses import replace

    from caustica.metrics.regions import caustic_through_glass

    scene, camera = ball_over_floor
    assert not caustic_through_glass(replace(scene, lights=[]), camera).any()


def test_bench_reports_regions_glints_floor_and_labelled_times(tmp_path, capsys):
    """time_to_quality's JSON: relMSE per region with the glints apart, Mitsuba's needed spp from the pixels the
    reference can contain, the reference's floor per region, every curve point's end to end >= its render."""
    pytest.importorskip("mitsuba", reason="the reference extra is not installed")
    out = tmp_path / "b.json"
    assert main(["bench", "--scenes", "caustic-sphere", "--techniques", "env-map", "--sizes", "24",
                 "--timing-frames", "1", "--quality-size", "32", "--reference-spp", "8", "--max-spp", "2",
                 "--json", str(out)]) == 0
    quality = json.loads(out.read_text())["time_to_quality"][0]
    assert quality["needed_spp_from"] == "contained_relmse"
    assert {"all", "contained", "refractor", "rest"} <= set(quality["regions"])
    entry = quality["techniques"]["env-map"]
    assert {"relmse", "contained_relmse", "refractor_relmse", "rest_relmse", "at_reference_floor"} <= set(entry)
    assert set(quality["reference_floor"]) >= {"relmse", "contained_relmse"}
    for point in quality["mitsuba_curve"]:
        assert point["end_to_end_seconds"] >= point["seconds"] > 0
