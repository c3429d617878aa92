"""``per-object``: a view technique per glass object, in one image."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.errors import TechniqueError
from caustica.passes.shading.surfaces import ShadeBackground, ShadeSurfaces
from caustica.scene import Camera, Diffuse, Glass, PointLight, Scene, SceneObject, Transform, procedural_environment
from caustica.scene.shapes import plane, sphere
from caustica.techniques import get_technique

SIZE = (128, 64)


def two_spheres() -> Scene:
    """Two glass spheres side by side over a floor: 'left' fills the left half of the image, 'right' the right half."""
    balls = [SceneObject(name, sphere(0.5, subdivisions=4), Glass(ior=1.5), Transform(position=[x, 0.5, 0.0]))
             for name, x in (("left", -0.65), ("right", 0.65))]
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse(color=[0.6, 0.6, 0.6]))
    return Scene(camera=Camera(position=[0.0, 0.9, 3.2], look_at=[0.0, 0.45, 0.0], fov_y=40.0, size=SIZE),
                 objects=[*balls, floor], lights=[PointLight(position=[1.0, 4.0, 2.0], intensity=[15.0] * 3)],
                 environment=procedural_environment("sky-checker"), name="two-spheres")


@pytest.fixture(scope="module")
def scene():
    return two_spheres()


def test_each_sphere_shows_its_own_technique(renderer, scene):
    mixed = renderer.render(scene, "per-object", techniques={"left": "env-map", "right": "depth-search"})
    env_map, depth_search = renderer.render(scene, "env-map"), renderer.render(scene, "depth-search")
    half = SIZE[0] // 2
    # The techniques differ on each sphere, so the comparison below tells them apart.
    assert np.abs(env_map[:, :half] - depth_search[:, :half]).max() > 0.1
    assert np.abs(env_map[:, half:] - depth_search[:, half:]).max() > 0.1
    # The left sphere (and the floor and sky around it) as env-map draws them, the right one as depth-search.
    np.testing.assert_allclose(mixed[:, :half], env_map[:, :half], atol=1e-5)
    np.testing.assert_allclose(mixed[:, half:], depth_search[:, half:], atol=1e-5)


def test_env_map_default_does_not_starve_depth_search(renderer, scene):
    """env-map alone skips its back faces when no glass absorbs; merged with depth-search, which
    reads them, the full buffer is made whichever technique comes first."""
    mixed = renderer.render(scene, "per-object", default="env-map", techniques={"right": "depth-search"})
    depth_search = renderer.render(scene, "depth-search")
    half = SIZE[0] // 2
    np.testing.assert_allclose(mixed[:, half:], depth_search[:, half:], atol=1e-5)


@pytest.mark.parametrize("technique", ["env-map", "image-space", "depth-search"])
def test_every_object_on_one_technique_is_that_technique(renderer, scene, technique):
    expected = renderer.render(scene, technique)
    named = renderer.render(scene, "per-object", techniques={"left": technique, "right": technique})
    np.testing.assert_allclose(named, expected, atol=1e-5)
    by_default = renderer.render(scene, "per-object", default=technique)
    np.testing.assert_allclose(by_default, expected, atol=1e-5)


def test_unknown_objects_and_techniques_are_named(renderer, scene):
    with pytest.raises(TechniqueError, match=r"'lefty' is not a glass object.*did you mean 'left'.*left, right"):
        renderer.render(scene, "per-object", techniques={"lefty": "env-map"})
    with pytest.raises(TechniqueError, match=r"'floor' is not a glass object"):
        renderer.render(scene, "per-object", techniques={"floor": "env-map"})
    with pytest.raises(TechniqueError, match=r"must be one of env-map, image-space, depth-search"):
        renderer.render(scene, "per-object", techniques={"left": "exact"})
    with pytest.raises(TechniqueError, match=r"default 'plain' must be one of env-map, image-space, depth-search"):
        renderer.render(scene, "per-object", default="plain")


def test_mapping_from_the_command_line_form():
    params = get_technique("per-object").make_params(techniques="left=env-map, right=image-space")
    assert params.techniques == {"left": "env-map", "right": "image-space"}
    with pytest.raises(TechniqueError, match="object=technique"):
        get_technique("per-object").make_params(techniques="left")


def test_buffers_are_made_once_and_one_run_draws_the_background():
    technique = get_technique("per-object")
    passes = technique.build_passes(technique.make_params(techniques={"left": "env-map", "right": "image-space"}))
    outputs = [tuple(c.name for c in p.writes) for p in passes if not isinstance(p, ShadeSurfaces) and p.writes]
    assert len(outputs) == len(set(outputs))
    assert ("front_dn",) in outputs and ("front_surface",) in outputs and ("back_surface",) in outputs
    shades = [p for p in passes if isinstance(p, ShadeSurfaces)]
    assert [p.background for p in shades] == [True, False, False]
    assert len({p.label for p in shades}) == 3  # each run timed on its own
    assert [isinstance(p, ShadeBackground) for p in passes].count(True) == 1 and isinstance(passes[-1], ShadeBackground)


def test_composes_with_caustics(renderer, scene):
    """Caustic passes go before the first shading run; every run then adds the caustic maps."""
    mixed = renderer.render(scene, "per-object+caustic-mapping", techniques={"left": "env-map"})
    env_map = renderer.render(scene, "env-map+caustic-mapping")
    depth_search = renderer.render(scene, "depth-search+caustic-mapping")
    half = SIZE[0] // 2
    np.testing.assert_allclose(mixed[:, :half], env_map[:, :half], atol=1e-4)
    np.testing.assert_allclose(mixed[:, half:], depth_search[:, half:], atol=1e-4)
    assert np.abs(mixed - renderer.render(scene, "per-object", techniques={"left": "env-map"})).max() > 1e-3


def test_each_technique_takes_its_own_parameters(renderer, scene):
    """``image-space.tir_mode`` and ``depth-search.iterations`` reach only their technique: each sphere
    equals the full render of its technique with those parameters, and differs from the defaults."""
    params = {"techniques": {"left": "image-space", "right": "depth-search"},
              "image-space.tir_mode": "reflect", "depth-search.iterations": 0}
    mixed = renderer.render(scene, "per-object", **params)
    half = SIZE[0] // 2
    image_space = renderer.render(scene, "image-space", tir_mode="reflect")
    depth_search = renderer.render(scene, "depth-search", iterations=0)
    np.testing.assert_allclose(mixed[:, :half], image_space[:, :half], atol=1e-5)
    np.testing.assert_allclose(mixed[:, half:], depth_search[:, half:], atol=1e-5)
    assert np.abs(depth_search[:, half:] - renderer.render(scene, "depth-search")[:, half:]).max() > 0.05
    composed = renderer.render(scene, "per-object+caustic-mapping", **params, **{"caustic-mapping.map_size": 64})
    assert composed.shape == mixed.shape


@pytest.mark.parametrize("bad", [{"depth-search.iterationz": 2}, {"mirror.iterations": 1},
                                 {"depth-search.iterations": -3}, {"env-map.shadow_map_size": 64}])
def test_bad_technique_parameters_are_named(renderer, scene, bad):
    with pytest.raises(TechniqueError) as info:
        renderer.render(scene, "per-object", **bad)
    assert "\n" not in str(info.value)
