"""Local reflection probes of glossy Principled receivers (passes/shading/reflection_probes.py): a rough metal ball
on a lit floor in a black world reflects the floor as `exact` does, a probe of an empty scene is the environment,
and the probes are shared past MAX_REFLECTION_PROBES and absent without glossy receivers. 64x64 frames."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.passes.shading import surfaces
from caustica.render.bindings import MAX_REFLECTION_PROBES
from caustica.renderer import Renderer
from caustica.scene import Camera, Diffuse, PointLight, Scene, SceneObject, Transform, procedural_environment
from caustica.scene.materials import Principled
from caustica.scene.shapes import plane, sphere

SIZE = (64, 64)
GOLD = [1.0, 0.78, 0.34]


def ball_on_floor(roughness: float = 0.3) -> Scene:
    """A gold ball (radius 0.5) standing on a bright diffuse floor under a point light, in a black world."""
    camera = Camera(position=[0.0, 1.2, 3.0], look_at=[0.0, 0.5, 0.0], fov_y=35.0, size=SIZE)
    ball = SceneObject("ball", sphere(0.5), Principled(base_color=GOLD, metallic=1.0, roughness=roughness),
                       Transform(position=[0.0, 0.5, 0.0]))
    floor = SceneObject("floor", plane((10.0, 10.0)), Diffuse(color=[0.8] * 3))
    return Scene(camera=camera, objects=[ball, floor], lights=[PointLight([1.5, 3.0, 1.5], [20.0] * 3)],
                 environment=procedural_environment("black"))


def lower_half_of_ball(camera: Camera, centre, radius: float) -> np.ndarray:
    """(H, W) bool: the pixels whose ray meets the ball first between 0.1 and 0.9 radii above its bottom (its
    lower half, which reflects the floor)."""
    origin, direction = (a[:, :, 0] for a in camera.primary_rays())
    offset = origin - np.asarray(centre)
    b = (offset * direction).sum(-1)
    disc = b * b - ((offset * offset).sum(-1) - radius * radius)
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    height = (origin + t[..., None] * direction)[..., 1] - (centre[1] - radius)
    return (disc > 0) & (height > 0.1 * radius) & (height < 0.9 * radius)


def test_rough_gold_ball_reflects_the_lit_floor_as_exact_does(renderer, monkeypatch):
    """The lower half of a rough gold ball (roughness 0.3) on a lit floor in a black world shows the floor: its
    mean is within 25 % of exact's (64 spp: the mean over ~250 pixels is within 2 % of converged) on the same
    pixels. The tolerance holds what the split sum and the prefilter's n = v = r lobe leave out and the light
    exact bounces off the ball onto the floor (the raster floor has no interreflection); measured, -19 %.
    Without the probe (the prefiltered black environment) the same pixels are near black: under 2 % of exact's."""
    scene = ball_on_floor()
    mask = lower_half_of_ball(scene.camera, [0.0, 0.5, 0.0], 0.5)
    assert mask.sum() > 150
    exact = renderer.render(scene, "exact", spp=64)[mask].mean()
    probed = renderer.render(scene, "plain")[mask].mean()
    assert abs(probed - exact) < 0.25 * exact, (probed, exact)
    monkeypatch.setattr(surfaces, "probe_defines", lambda frame, features: {})
    distant = renderer.render(scene, "plain")[mask].mean()
    assert distant < 0.02 * exact, (distant, exact)


@pytest.mark.parametrize("material", [dict(metallic=1.0, roughness=0.3), dict(metallic=0.0, roughness=0.15)],
                         ids=["metal", "plastic"])
def test_probe_of_an_empty_scene_is_the_environment(renderer, monkeypatch, material):
    """A glossy ball alone in a white furnace: its probe sees nothing but the environment, so the image is the
    one drawn with the prefiltered environment itself, within 1e-2 (relative to the environment's radiance)."""
    camera = Camera(position=[0.0, 0.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    ball = SceneObject("ball", sphere(0.8), Principled(base_color=[0.9, 0.6, 0.3], **material))
    scene = Scene(camera=camera, objects=[ball], lights=[], environment=procedural_environment("white"))
    probed = renderer.render(scene, "plain")
    monkeypatch.setattr(surfaces, "probe_defines", lambda frame, features: {})
    distant = renderer.render(scene, "plain")
    white = procedural_environment("white").image.mean()
    assert np.abs(probed - distant).max() < 1e-2 * white


def test_probes_are_shared_past_the_limit_and_absent_without_glossy_receivers():
    """Six glossy balls in a row get MAX_REFLECTION_PROBES probes, the largest balls their own; each smaller one
    reads the probe whose centre is nearest; the glossy floor, planar, gets none. A scene whose receivers are all
    diffuse has no probes."""
    camera = Camera(position=[0.0, 2.0, 8.0], look_at=[0.0, 0.0, 0.0], fov_y=50.0, size=(32, 32))
    radii, xs = [0.2, 0.6, 0.5, 0.3, 0.45, 0.4], [-4.0, -2.5, -1.0, 0.0, 1.5, 3.0]
    balls = [SceneObject(f"ball{i}", sphere(r), Principled(base_color=GOLD, metallic=1.0, roughness=0.4),
                         Transform(position=[x, r, 0.0])) for i, (r, x) in enumerate(zip(radii, xs))]
    glossy_floor = SceneObject("floor", plane((12.0, 12.0)), Principled(base_color=[0.5] * 3, roughness=0.3))
    floor = SceneObject("floor", plane((12.0, 12.0)), Diffuse(color=[0.5] * 3))
    light = PointLight([0.0, 4.0, 2.0], [20.0] * 3)
    with Renderer(size=(32, 32), keep_channels=True) as own:
        own.render(Scene(camera=camera, objects=[*balls, glossy_floor], lights=[light],
                         environment=procedural_environment("black")), "plain")
        probes = own.channels["reflection_probes"]
        assert len(probes.probes) == MAX_REFLECTION_PROBES
        owners = [1, 2, 4, 5]  # the four largest radii
        assert [probes.probe_of_object[i] for i in owners] == [0, 1, 2, 3]
        assert probes.probe_of_object[0] == 0 and probes.probe_of_object[3] == 1  # ball1's and ball2's, nearest
        assert probes.probe_of_object[-1] == -1  # the glossy floor is planar: it keeps the environment's atlas
        np.testing.assert_allclose(probes.probes[0].centre, [-2.5, 0.6, 0.0], atol=1e-6)
        own.render(Scene(camera=camera, objects=[floor, SceneObject("ball", sphere(0.5), Diffuse())], lights=[light],
                         environment=procedural_environment("black")), "plain")
        assert own.channels["reflection_probes"] is None
