"""``caustica compare`` and ``caustica bench`` produce valid JSON with every column, and a contact sheet."""
from __future__ import annotations

import json

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

    with Image.open(sheet) as image:
        assert image.size[0] == 3 * 48 and image.size[1] > 2 * 48  # image, error map, reference; two rows


def test_compare_rejects_bad_output_before_working(tmp_path, capsys):
    code = main(["compare", "glass-sphere", "--json", str(tmp_path / "missing" / "x.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and len(err.strip().splitlines()) == 1


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
        assert {"ms", "relmse", "mitsuba_spp", "mitsuba_seconds", "speed_ratio"} <= set(quality["techniques"]["env-map"])
    assert plot.stat().st_size > 1000


def test_timed_in_turns_takes_the_median_of_same_round_ratios():
    """Frames of each variant alternate round by round after one warm-up each, and a ratio is the
    median of each round's frame over the baseline's in that round (here 1, not the 1.5 that a ratio
    of the two medians would give)."""
    from caustica.bench.timing import timed_in_turns

    frames = {"base": [10.0, 40.0, 20.0], "other": [30.0, 40.0, 20.0]}  # ms per round

    class FakeRenderer:
        def __init__(self):
            self.calls = []

        def render(self, scene, technique, spp, **params):
            self.calls.append(("warm-up", technique))

        def render_timed(self, scene, technique, spp, **params):
            self.calls.append(("timed", technique))
            return None, frames[technique][sum(c == ("timed", technique) for c in self.calls) - 1]

    renderer = FakeRenderer()
    timed = timed_in_turns(renderer, None, {"base": ("base", {}), "other": ("other", {"k": 1})}, 1, 3, "base")
    assert renderer.calls == [("warm-up", "base"), ("warm-up", "other")] + [("timed", "base"), ("timed", "other")] * 3
    assert timed["other"]["ratio"] == pytest.approx(1.0) and timed["base"]["ratio"] == pytest.approx(1.0)
    assert timed["other"]["ms"] == 30.0 and timed["other"]["fastest"] == 20.0
