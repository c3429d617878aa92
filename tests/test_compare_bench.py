"""``caustica compare`` and ``caustica bench`` produce valid JSON with every column, and a contact sheet."""
from __future__ import annotations

import json

import numpy as np
import pytest

from caustica.cli import main

METRIC_KEYS = {"psnr_linear", "psnr_srgb", "relmse", "ssim", "flip"}


@pytest.fixture(autouse=True)
def private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path / "cache"))


def test_compare_writes_json_with_every_column_and_a_sheet(tmp_path, capsys):
    out, sheet = tmp_path / "c.json", tmp_path / "c.png"
    code = main(["compare", "caustic-sphere", "--size", "48x48", "--spp", "1", "--reference-spp", "8",
                 "--frames", "1", "--json", str(out), "--sheet", str(sheet), "--techniques", "env-map,exact"])
    assert code == 0
    table = capsys.readouterr().out
    assert "[caustic]" in table and "env-map" in table and "exact" in table
    data = json.loads(out.read_text())
    assert data["size"] == [48, 48] and data["renderer"] and data["reference"]
    assert set(data["region_pixels"]) == {"refractor", "caustic", "rest"}
    assert sum(data["region_pixels"].values()) == 48 * 48
    names = [t["technique"] for t in data["techniques"]]
    assert names == ["env-map", "exact"]
    for entry in data["techniques"]:
        assert entry["ms_per_frame"] > 0
        assert set(entry["regions"]) == {"all", "refractor", "caustic", "rest"}
        for region in entry["regions"].values():
            assert set(region) == METRIC_KEYS
        assert set(entry["angular_error"]) == {"mean_deg", "p95_deg", "count"}
    env_map = data["techniques"][0]
    assert env_map["angular_error"]["count"] > 0 and float(env_map["angular_error"]["mean_deg"]) > 1.0
    from PIL import Image

    from caustica.bench.sheet import MIN_COLUMN

    with Image.open(sheet) as image:
        # The reference and the FLIP colour bar once, then each technique's image and error map.
        assert image.size[0] == 2 * MIN_COLUMN and image.size[1] > 3 * 48


def test_compare_rejects_bad_output_before_working(tmp_path, capsys):
    (tmp_path / "file").write_text("")  # a missing folder is made; one below a file cannot be
    code = main(["compare", "glass-sphere", "--json", str(tmp_path / "file" / "missing" / "x.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert "is a file, not a directory" in err and len(err.strip().splitlines()) == 1


def test_bench_writes_json_with_every_column(tmp_path, capsys):
    pytest.importorskip("matplotlib", reason="the plots extra is not installed")
    out, plot = tmp_path / "b.json", tmp_path / "b.png"
    args = ["bench", "--scenes", "glass-sphere", "--techniques", "env-map", "--sizes", "32,48", "--frames", "1",
            "--quality-size", "32", "--reference-spp", "16", "--max-spp", "4", "--json", str(out), "--plot", str(plot)]
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        args.append("--no-mitsuba")
    assert main(args) == 0
    data = json.loads(out.read_text())
    assert len(data["frames"]) == 2
    for row in data["frames"]:
        assert {"scene", "size", "technique", "ms", "plain_ms", "ratio_to_plain", "pass_ms", "triangles",
                "renderer"} <= set(row)
        assert row["ms"] > 0 and row["triangles"] > 0 and set(row["pass_ms"]) >= {"ShadeSurfaces"}
    if "--no-mitsuba" not in args:
        quality = data["time_to_quality"][0]
        assert [c["spp"] for c in quality["mitsuba_curve"]] == [1, 2, 4]
        assert {"ms", "relmse", "mitsuba_spp", "mitsuba_seconds", "mitsuba_end_to_end_seconds",
                "speed_ratio"} <= set(quality["techniques"]["env-map"])
        # Mitsuba's render-only time (loaded, warmed scenes) and its end-to-end time, both labelled.
        assert all(c["seconds"] > 0 and c["end_to_end_seconds"] > 0 for c in quality["mitsuba_curve"])
    assert plot.stat().st_size > 1000


class FakeRenderer:
    """Stands in for a Renderer in the timing helpers' tests: records its calls; the n-th timed frame of a
    technique takes frames[technique][n] ms."""

    def __init__(self, frames: dict):
        self.frames, self.calls = frames, []

    def render(self, scene, technique, spp, **params):
        self.calls.append(("warm-up", technique))

    def render_timed(self, scene, technique, spp, **params):
        self.calls.append(("timed", technique))
        return None, self.frames[technique][sum(c == ("timed", technique) for c in self.calls) - 1]


def test_timed_in_turns_takes_the_median_of_same_round_ratios():
    """Frames of each variant alternate round by round after one warm-up each, and a ratio is the
    median of each round's frame over the baseline's in that round (here 1, not the 1.5 that a ratio
    of the two medians would give)."""
    from caustica.bench.timing import timed_in_turns

    frames = {"base": [10.0, 40.0, 20.0], "other": [30.0, 40.0, 20.0]}  # ms per round

    renderer = FakeRenderer(frames)
    timed = timed_in_turns(renderer, None, {"base": ("base", {}), "other": ("other", {"k": 1})}, 1, 3, "base")
    assert renderer.calls == [("warm-up", "base"), ("warm-up", "other")] + [("timed", "base"), ("timed", "other")] * 3
    assert timed["other"]["ratio"] == pytest.approx(1.0) and timed["base"]["ratio"] == pytest.approx(1.0)
    assert timed["other"]["ms"] == 30.0 and timed["other"]["fastest"] == 20.0



def test_fastest_in_blocks_warms_each_block_and_keeps_the_fastest_frame():
    """Each round runs a variant's warm-up frame, untimed (it refills the passes the other variant's frame
    evicted), then its frames; the answer is each variant's fastest timed frame, never a warm-up's."""
    from caustica.bench.timing import fastest_in_blocks

    frames = {"a": [9.0, 7.0, 8.0, 6.5], "b": [3.0, 2.0, 4.0, 5.0]}

    renderer = FakeRenderer(frames)
    fastest = fastest_in_blocks(renderer, None, {"a": ("a", {}), "b": ("b", {})}, 1, rounds=2, frames=2)
    block = lambda t: [("warm-up", t), ("timed", t), ("timed", t)]  # noqa: E731
    assert renderer.calls == (block("a") + block("b")) * 2
    assert {name: f["wall"] for name, f in fastest.items()} == {"a": 6.5, "b": 2.0}
    assert all(0.0 <= f["cpu"] < 1000.0 for f in fastest.values())  # the fake renders cost no CPU to speak of

def _old_to_rgb8(image, exposure=0.0):
    """The contact sheet's own encoder before it used images.to_srgb8 (kept here to prove nothing moved)."""
    from caustica.images import linear_to_srgb

    encoded = linear_to_srgb(np.clip(image * 2.0**exposure, 0.0, 1.0))
    return (encoded * 255.0 + 0.5).astype(np.uint8)


def _sheet_inputs():
    rng = np.random.default_rng(19)
    ramp = np.linspace(-0.1, 30.0, 64 * 48 * 3, dtype=np.float32).reshape(48, 64, 3)
    noisy = (rng.random((48, 64, 3), dtype=np.float32) * 3.0).astype(np.float32)
    reference = (rng.random((48, 64, 3), dtype=np.float32) ** 3 * 20.0).astype(np.float32)
    rows = [("ramp", ramp, None), ("noise", noisy, rng.random((48, 64, 3)).astype(np.float32))]
    return rows, reference


def test_contact_sheet_with_clip_is_bit_identical_to_its_old_encoder(monkeypatch):
    """The sheet encodes with images.to_srgb8 now; with clip (the default) its pixels are exactly the old
    ``(srgb * 255 + 0.5)`` floor ones: the encoders agree on a sweep of float32 values in [0, 1]."""
    from caustica.bench import sheet as sheet_module
    from caustica.images import to_srgb8

    bits = np.arange(0, np.float32(1.0).view(np.uint32) + 1, 257, dtype=np.uint32)  # ~4M float32s in [0, 1]
    values = np.append(bits.view(np.float32), np.float32(1.0))
    np.testing.assert_array_equal(to_srgb8(values), _old_to_rgb8(values))
    rows, reference = _sheet_inputs()
    now = np.asarray(sheet_module.contact_sheet(rows, reference, "reference: x"))
    assert np.array_equal(now, np.asarray(sheet_module.contact_sheet(rows, reference, "reference: x", tonemap="clip")))
    monkeypatch.setattr(sheet_module, "to_srgb8", lambda image, exposure=0.0, tonemap="clip": _old_to_rgb8(image, exposure))
    before = np.asarray(sheet_module.contact_sheet(rows, reference, "reference: x"))
    assert now.dtype == before.dtype and np.array_equal(now, before)


def test_contact_sheet_with_filmic_keeps_a_bright_region_distinct():
    """Values from 1x to 30x white are all code 255 on a clip sheet; through filmic they keep distinct codes,
    increasing with the value, and the tiles are images.to_srgb8(..., tonemap="filmic")."""
    from caustica.bench.sheet import compose, contact_sheet, sheet_grid
    from caustica.images import to_srgb8

    rows, reference = _sheet_inputs()
    clip = np.asarray(contact_sheet(rows, reference, tonemap="clip"))
    filmic = np.asarray(contact_sheet(rows, reference, tonemap="filmic"))
    places = compose(sheet_grid(rows, reference, tonemap="filmic"))[1]
    (x, y), (rx, ry) = places[1][0], places[0][0]  # the first row's image; the reference, above the rows
    ramp = rows[0][1]
    bright = (ramp >= 1.0).all(axis=2)
    clip_tile, filmic_tile = (s[y:y + 48, x:x + 64] for s in (clip, filmic))
    assert (clip_tile[bright] == 255).all()
    assert len(np.unique(filmic_tile[bright])) > 25 and filmic_tile[bright].max() < 255
    assert (np.diff(filmic_tile[..., 0].astype(int).ravel()) >= 0).all()  # the ramp's codes never go down
    np.testing.assert_array_equal(filmic_tile, to_srgb8(ramp, tonemap="filmic"))
    reference_tile = filmic[ry:ry + 48, rx:rx + 64]
    np.testing.assert_array_equal(reference_tile, to_srgb8(reference, tonemap="filmic"))


def test_compare_tonemap_filmic_sheet_and_bad_value(tmp_path, capsys):
    sheet = tmp_path / "f.png"
    code = main(["compare", "caustic-sphere", "--size", "32x32", "--spp", "1", "--reference-spp", "4", "--frames", "1",
                 "--sheet", str(sheet), "--techniques", "env-map", "--tonemap", "filmic"])
    assert code == 0 and sheet.stat().st_size > 0
    capsys.readouterr()
    assert main(["compare", "glass-sphere", "--tonemap", "aces", "--sheet", str(tmp_path / "x.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--tonemap" in err and "'aces'" in err and "clip" in err and "filmic" in err
    assert not (tmp_path / "x.png").exists()
