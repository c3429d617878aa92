"""The caustics presets: each loads, renders with env-map, and the photon oracle puts a caustic on a receiver."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.errors import SceneError
from caustica.raytrace.photons import irradiance_histogram, trace_photons
from caustica.scene import Scene
from caustica.scene.presets import PRESETS, pool_scene

CAUSTIC_PRESETS = sorted(name for name in PRESETS if name.startswith("caustics-"))


def load(name: str) -> Scene:
    """The preset, or a skip when it needs the shared data and that is missing."""
    try:
        return PRESETS[name]()
    except SceneError as exc:
        pytest.skip(str(exc))


def test_every_caustics_preset_is_listed():
    assert CAUSTIC_PRESETS == ["caustics-bunny", "caustics-directional", "caustics-point", "caustics-pool",
                               "caustics-prism", "caustics-ring", "caustics-spot", "caustics-two-lights"]


@pytest.mark.parametrize("name", CAUSTIC_PRESETS)
def test_preset_renders_and_has_a_caustic(name, renderer):
    """64x64 env-map renders finitely; 20k photons leave flux on a diffuse receiver after a specular bounce."""
    scene = load(name)
    assert scene.name == name and scene.camera.size == (512, 512)
    assert scene.lights and any(o.material.kind in ("glass", "mirror") for o in scene.objects)
    scene.camera = scene.camera.with_size(64, 64)
    image = renderer.render(scene, "env-map")
    assert image.shape == (64, 64, 3) and np.all(np.isfinite(image)) and image.max() > 0
    hits = trace_photons(scene, count=20_000)
    assert len(hits) > 100 and np.all(hits.bounces >= 1)
    kinds = {scene.objects[i].material.kind for i in np.unique(hits.object_index)}
    assert kinds == {"diffuse"}
    assert np.all(hits.total_flux > 0)


def test_bunny_preset_names_the_missing_file(monkeypatch, tmp_path):
    monkeypatch.setenv("CAUSTICA_DATA", str(tmp_path))
    with pytest.raises(SceneError, match="stanford-bunny.obj"):
        PRESETS["caustics-bunny"]()


def test_prism_separates_the_colours():
    """Blue is deviated more than red: the blue centroid of the prism's caustic lies nearer the prism (x = 0)."""
    hits = trace_photons(load("caustics-prism"), count=20_000)
    centroid = [np.average(hits.position[:, 0], weights=hits.flux[:, c]) for c in range(3)]
    assert centroid[2] < centroid[1] < centroid[0]


def test_pool_water_moves_with_time():
    """pool_scene(t) changes the water surface and so the caustic; the preset is time 0."""
    still, later = pool_scene(0.0), pool_scene(0.5)
    assert np.array_equal(PRESETS["caustics-pool"]().objects[0].mesh.vertices, still.objects[0].mesh.vertices)
    assert not np.array_equal(still.objects[0].mesh.vertices, later.objects[0].mesh.vertices)
    maps = [irradiance_histogram(trace_photons(scene, count=20_000, seed=5), [0, 0, 0], [1, 0, 0], [0, 0, 1], 3.0, 16,
                                 tolerance=2.0, receiver=1) for scene in (still, later)]
    assert maps[0].sum() > 0 and np.abs(maps[0] - maps[1]).sum() > 0.1 * maps[0].sum()
