"""bench/gpu_suite.sh --quick on whatever GL is here (llvmpipe in CI): JSON and markdown with rows and the GL
renderer; the time budget stops the suite and keeps what it wrote."""
from __future__ import annotations

import importlib.util
import json
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _suite():
    spec = importlib.util.spec_from_file_location("gpu_suite", ROOT / "bench" / "gpu_suite.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_quick_suite_writes_rows_and_the_renderer(tmp_path):
    done = subprocess.run(["bash", str(ROOT / "bench" / "gpu_suite.sh"), "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    assert "renderer:" in done.stdout  # caustica info of the chosen EGL device
    data = json.loads((tmp_path / "results.json").read_text())
    assert data["renderer"] and not data["stopped_early"]
    measured = [row for row in data["rows"] if "ms" in row]
    assert {(row["technique"], row["scene"]) for row in measured} == {
        (t, s) for t in ("auto", "env-map") for s in ("glass-sphere", "caustic-sphere")}
    assert all(row["fps"] > 0 and row["pass_ms"] for row in measured)
    assert {row["planned"] for row in measured if row["technique"] == "auto"} == {
        "depth-search", "impostors+caustic-mapping"}
    page = (tmp_path / "results.md").read_text()
    assert data["renderer"] in page and page.count("| `auto` (") == 2 and "| `env-map` | `glass-sphere` | 64x64 |" in page
    assert (tmp_path / "system.txt").read_text().startswith("date:")


def test_the_budget_stops_the_suite_and_keeps_what_it_wrote(tmp_path):
    suite = _suite()
    device = {"device_index": 0, "is_software": True, "probes": []}
    data = suite.run_suite(tmp_path, ["env-map"], ["glass-sphere", "no-such-preset"], [(32, 24)], 1, 1, 0.0,
                           "test", device, log=lambda *a: None)
    assert data["stopped_early"] and not data["rows"] and "no-such-preset" in data["skipped_presets"]
    written = json.loads((tmp_path / "results.json").read_text())
    assert written["stopped_early"] and written["renderer"] == data["renderer"]
    assert "stopped by the budget" in (tmp_path / "results.md").read_text()
