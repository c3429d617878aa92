"""Shared fixtures: one GL renderer per session, the shared data folder, golden-image regeneration."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

# set_uniform fails on a uniform name the program's shaders do not declare (a misspelling).
os.environ.setdefault("CAUSTICA_STRICT_UNIFORMS", "1")

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


def pytest_addoption(parser):
    parser.addoption("--regen-golden", action="store_true", help="rewrite tests/golden/* from the current renderer")


@pytest.fixture(scope="session")
def regen_golden(request) -> bool:
    return request.config.getoption("--regen-golden") or os.environ.get("CAUSTICA_REGEN_GOLDEN") == "1"


@pytest.fixture(scope="session")
def renderer():
    from caustica.renderer import Renderer

    return Renderer()


@pytest.fixture(scope="session")
def reference_cache() -> Path:
    """The persistent folder of Mitsuba references ($CAUSTICA_CACHE or ~/.cache/caustica, reference/): an entry
    is keyed by what the image depends on (scene content, camera, spp, variant, REFERENCE_VERSION), so a
    machine renders each test's reference once; tests of the cache itself use a folder of their own."""
    from caustica.reference.render import default_cache_dir

    return default_cache_dir()


@pytest.fixture(scope="session")
def data_dir() -> Path:
    if not DATA.is_dir():
        pytest.skip(f"shared data not found at {DATA}")
    return DATA
