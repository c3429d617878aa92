"""docs/which-technique.md is what the auto planner gives now (it cannot drift from caustica.plan or
docs/auto.md's table); docs/gallery.md is what scripts/make_gallery.py writes from its figures."""
from __future__ import annotations

import importlib.util
import json
import re
from pathlib import Path

import pytest

from caustica.docs_techniques import WHICH_PATH, plan_rules, technique_limits, which_technique_markdown
from caustica.scene.preset_parts import shared_data_dir

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "docs" / "images" / "gallery"


def test_which_technique_md_is_current():
    models = shared_data_dir() / "models"
    if not all((models / name).is_file() for name in ("stanford-bunny.obj", "teapot.obj")):
        pytest.skip(f"the bunny and teapot presets need the shared data ({models})")
    assert WHICH_PATH.read_text(encoding="utf-8") == which_technique_markdown(), (
        "docs/which-technique.md is stale: run python -m caustica.docs_techniques --which-technique")


def test_every_rule_and_its_techniques_are_on_the_page():
    page = WHICH_PATH.read_text(encoding="utf-8")
    rules = plan_rules()
    assert len(rules) >= 10 and all(f"| {kind} | `{technique}` |" in page for kind, technique in rules)
    for technique in {part for _, technique in rules for part in technique.split("+")}:
        assert f"### `{technique}`" in page.split("## The techniques auto picks")[1].split("## The other")[0]


def test_limits_come_from_each_techniques_module():
    assert technique_limits("env-map")[0].startswith("Limits: one interface")
    assert technique_limits("plain") == []  # its module documents env-map
    exact = technique_limits("exact")
    assert exact[0] == "Limits:" and exact[1].startswith("- ") and "``" not in "".join(exact)


def _gallery():
    spec = importlib.util.spec_from_file_location("make_gallery", ROOT / "scripts" / "make_gallery.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_gallery_page_is_its_figures_and_its_images_exist():
    data = json.loads((GALLERY / "gallery.json").read_text())
    page = (ROOT / "docs" / "gallery.md").read_text(encoding="utf-8")
    assert page == _gallery().gallery_markdown(data)
    images = re.findall(r"\]\((images/gallery/[^)]+\.png)\)", page)
    assert len(images) == len(data["rows"]) and all((ROOT / "docs" / path).is_file() for path in images)
    assert sum(p.stat().st_size for p in GALLERY.iterdir()) < 3_000_000
