"""The built wheel is complete: it ships every shader and renders a GPU technique outside the source tree.

``make`` installs the package editable, which reads shaders from ``src/`` and so hides files missing
from the wheel. Here the wheel is built from a copy of the sources, unpacked into an empty folder and
imported from there alone, by a process whose working directory is outside the repository.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SHADERS = ROOT / "src" / "caustica" / "shaders"

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a clean copy of pyproject.toml, README.md and src/ (no stale build/ folder)."""
    pytest.importorskip("setuptools", minversion="77")
    source = tmp_path_factory.mktemp("source")
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    out = tmp_path_factory.mktemp("wheel")
    done = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                           "-w", str(out), str(source)], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    wheels = list(out.glob("caustica-*.whl"))
    assert len(wheels) == 1, wheels
    return wheels[0]


def test_wheel_ships_every_shader_file(wheel):
    in_source = {p.relative_to(ROOT / "src").as_posix() for p in SHADERS.rglob("*") if p.is_file()}
    assert len(in_source) >= 38
    with zipfile.ZipFile(wheel) as archive:
        in_wheel = {name for name in archive.namelist() if name.startswith("caustica/shaders/")}
    assert in_source - in_wheel == set()


def test_wheel_metadata_has_version_urls_and_classifiers(wheel):
    import caustica

    with zipfile.ZipFile(wheel) as archive:
        metadata = next(archive.read(n).decode() for n in archive.namelist() if n.endswith(".dist-info/METADATA"))
    assert f"Version: {caustica.__version__}" in metadata
    assert "Project-URL: Source," in metadata
    assert "Classifier: Topic :: Multimedia :: Graphics :: 3D Rendering" in metadata


def test_wheel_has_the_command_and_python_dash_m(wheel):
    """The ``caustica`` script's entry point and ``caustica/__main__.py`` (``python -m caustica``) ship."""
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
        entry_points = next(archive.read(n).decode() for n in names if n.endswith(".dist-info/entry_points.txt"))
    assert "caustica/__main__.py" in names
    assert "caustica = caustica.cli:main" in entry_points


RENDER_FROM_WHEEL = """
import sys
from pathlib import Path
import caustica
from caustica.cli import main
here = Path(caustica.__file__).resolve()
assert here.is_relative_to(Path(sys.argv[1]).resolve()), f"imported from {here}, not from the unpacked wheel"
sys.exit(main(["render", "caustic-sphere", "-t", "depth-search+caustic-mapping", "--size", "48x48",
               "--frames", "1", "-o", sys.argv[2]]))
"""


def test_unpacked_wheel_renders_a_gpu_technique(wheel, tmp_path):
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        archive.extractall(site)
    out = tmp_path / "ball.png"
    # The unpacked wheel comes first on sys.path, before the editable install of the source tree.
    env = {**os.environ, "PYTHONPATH": str(site), "PYTHONNOUSERSITE": "1"}
    done = subprocess.run([sys.executable, "-c", RENDER_FROM_WHEEL, str(site), str(out)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    assert "wrote" in done.stdout and out.stat().st_size > 0


def test_version_flag(capsys):
    import caustica
    from caustica.cli import main

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"caustica {caustica.__version__}"
