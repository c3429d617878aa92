"""The docs: every python block of docs/api.md runs, and the site builds with ``mkdocs build --strict``."""
import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

ROOT = Path(__file__).resolve().parents[1]
API = ROOT / "docs" / "api.md"


def python_blocks(path: Path) -> list[str]:
    """The bodies of the fenced ```python blocks in ``path``, in order."""
    return re.findall(r"^```python\n(.*?)^```$", path.read_text(encoding="utf-8"), flags=re.S | re.M)


def test_api_page_examples_run(tmp_path, monkeypatch):
    blocks = python_blocks(API)
    assert len(blocks) >= 4, "docs/api.md lost its examples"
    monkeypatch.chdir(tmp_path)
    for i, block in enumerate(blocks):
        exec(compile(block, f"{API.name} block {i}", "exec"), {"__name__": "__docs__"})
    frames = sorted((tmp_path / "turntable").glob("frame_*.png"))
    assert len(frames) == 36 and Image.open(frames[0]).size == (64, 64)
    assert Image.open(frames[0]).tobytes() != Image.open(frames[9]).tobytes()  # the camera moved


def test_docs_build_strict(tmp_path):
    missing = [m for m in ("mkdocs", "mkdocstrings", "mkdocstrings_handlers.python") if _absent(m)]
    if missing:
        pytest.skip(f"{', '.join(missing)} not installed: pip install -e '.[docs]' (make docs does it)")
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q", "-f", str(ROOT / "mkdocs.yml"),
                          "-d", str(tmp_path / "site")], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}{run.stderr}"
    assert (tmp_path / "site" / "api" / "index.html").is_file()


def _absent(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is None
    except ModuleNotFoundError:
        return True
