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


# Slowest modules first: each module's test time from the last run is kept in pytest's cache, and the next
# run collects the modules longest first (with `make test`'s --dist loadscope every module goes whole to one
# worker, so its module fixtures are built once, and no long module is left to run alone at the end).
MODULE_SECONDS = "caustica/module_seconds"


def _module_of(nodeid: str) -> str:
    return nodeid.split("::", 1)[0]


def _last_seconds(config) -> dict:
    cache = getattr(config, "cache", None)
    return cache.get(MODULE_SECONDS, {}) if cache is not None else {}


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """pytest-xdist's controller hands each worker the same times, so that every worker collects one order."""
    node.workerinput[MODULE_SECONDS] = _last_seconds(node.config)


def pytest_collection_modifyitems(config, items):
    worker = getattr(config, "workerinput", None)
    seconds = worker.get(MODULE_SECONDS, {}) if worker is not None else _last_seconds(config)
    if seconds:
        items.sort(key=lambda item: -seconds.get(_module_of(item.nodeid), 0.0))  # stable: in-module order kept


def pytest_runtest_logreport(report):
    _module_seconds[_module_of(report.nodeid)] = _module_seconds.get(_module_of(report.nodeid), 0.0) + report.duration


def pytest_sessionfinish(session):
    cache = getattr(session.config, "cache", None)
    if cache is None or not _module_seconds or hasattr(session.config, "workerinput"):
        return  # an xdist worker: the controller, which sees every report, writes them
    cache.set(MODULE_SECONDS, {**cache.get(MODULE_SECONDS, {}), **{k: round(v, 2) for k, v in _module_seconds.items()}})


_module_seconds: dict[str, float] = {}
