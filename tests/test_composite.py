"""Composition of view and caustic techniques, and the caustic-map contract of the surface shader."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from caustica.errors import TechniqueError
from caustica.passes.caustics.maps import CAUSTIC_PROJECTIVE, CausticMap
from caustica.render.frame import Channel, Pass
from caustica.scene import Camera, Diffuse, DirectionalLight, Scene, SceneObject, procedural_environment
from caustica.scene.shapes import plane
from caustica.scene.transform import look_at_view_from_world, orthographic_clip_from_view
from caustica.techniques import get_technique
from caustica.techniques.composite import CausticTechnique, Composite
from caustica.techniques.env_map import ShadowedParams

CAUSTIC_E = 2.0  # irradiance the fake map delivers, W/m^2


class ConstantCausticMap(Pass):
    """A square of constant caustic irradiance, x and z in [-0.5, 0.5], seen from a light overhead."""

    reads = ("light_samples",)
    writes = (Channel("caustic_maps", "rgba32f + host[light]", "one map per light"),)

    def run(self, frame):
        light = frame.read("light_samples")[0]
        n = 64
        view = look_at_view_from_world(light.position, light.position + light.direction, [0.0, 0.0, -1.0])
        clip = orthographic_clip_from_view(1.0, 1.0, 0.01, 100.0) @ view
        distance = float(np.dot(np.zeros(3) - light.position, light.direction))
        data = np.zeros((n, n, 4), dtype="f4")
        data[n // 4: 3 * n // 4, n // 4: 3 * n // 4] = (CAUSTIC_E, CAUSTIC_E, CAUSTIC_E, distance)
        texture = frame.own(frame.gpu.ctx.texture((n, n), 4, data.tobytes(), dtype="f4"))
        frame.write("caustic_maps", [CausticMap(texture, CAUSTIC_PROJECTIVE, clip)])


@dataclass
class FakeParams(ShadowedParams):
    """Inherits shadow_map_size, so a composite shares it with the view."""


class FakeCaustics(CausticTechnique):
    Params = FakeParams

    def caustic_passes(self, params):
        return [ConstantCausticMap()]


def floor_scene():
    camera = Camera(position=[0.0, 3.0, 0.001], look_at=[0.0, 0.0, 0.0], up=[0, 0, -1], fov_y=60.0, size=(64, 64))
    floor = SceneObject("floor", plane((4.0, 4.0)), Diffuse([0.5, 0.5, 0.5]))
    light = DirectionalLight(direction=[0.0, -1.0, 0.0], intensity=[1.0, 1.0, 1.0])
    return Scene(camera=camera, objects=[floor], lights=[light], environment=procedural_environment("black"))


def test_caustic_map_adds_irradiance_where_it_lands(renderer):
    scene = floor_scene()
    technique = Composite(get_technique("env-map"), FakeCaustics())
    without = renderer.render(scene, "env-map")
    image = renderer.render(scene, technique)
    added = (image - without)[..., 0]
    # The floor point under the image centre is inside the square, a corner pixel is outside.
    assert added[32, 32] == pytest.approx(0.5 / np.pi * CAUSTIC_E, rel=1e-4)
    assert abs(added[2, 2]) < 1e-6
    # The lit square covers x, z in [-0.5, 0.5]: its share of the visible floor (3 tan 30 deg each side).
    half_width = 3.0 * np.tan(np.radians(30.0))
    expected = (1.0 / (2 * half_width)) ** 2
    assert (added > 0.01).mean() == pytest.approx(expected, abs=0.03)


def test_composite_names_and_parameters():
    with pytest.raises(TechniqueError, match="view\\+caustics"):
        get_technique("env-map+")
    with pytest.raises(TechniqueError, match="makes no caustics"):
        get_technique("env-map+depth-search")
    with pytest.raises(TechniqueError, match="cannot show the camera view"):
        get_technique("exact+env-map")
    composite = Composite(get_technique("env-map"), FakeCaustics())
    view_params, caustic_params = composite.make_params(shadow_map_size=512)
    assert view_params.shadow_map_size == 512 and caustic_params.shadow_map_size == 512
    with pytest.raises(TechniqueError, match="no parameter 'shadow_map_sise'"):
        composite.make_params(shadow_map_sise=512)


def test_parameters_both_halves_have_must_be_qualified():
    """depth-search and caustic-mapping both have 'iterations' (different meanings): unqualified is refused."""
    composite = get_technique("depth-search+caustic-mapping")
    with pytest.raises(TechniqueError, match="depth-search.iterations or caustic-mapping.iterations"):
        composite.make_params(iterations=3)
    view, caustics = composite.make_params(**{"caustic-mapping.iterations": 3, "depth_search.iterations": 2})
    assert (view.iterations, caustics.iterations) == (2, 3)
    with pytest.raises(TechniqueError, match="not part of"):
        composite.make_params(**{"image-space.use_dn": False})


def test_caustic_technique_alone_keeps_the_view_defaults():
    """Named alone, a caustic technique's own 'iterations' must not leak into depth-search's."""
    from caustica.techniques.composite import _shared_params

    caustics = get_technique("caustic-mapping")
    view_params = _shared_params(get_technique("depth-search"), caustics,
                                 caustics.make_params(iterations=1, shadow_map_size=256))
    assert view_params.iterations == get_technique("depth-search").make_params().iterations
    assert view_params.shadow_map_size == 256
