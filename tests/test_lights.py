"""Diffuse receivers: env-map's shadow maps and light units agree with the ray-traced oracle for every light type."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.scene import (Camera, Diffuse, DirectionalLight, LineLight, PointLight, Scene, SceneObject, SpotLight,
                            Transform, procedural_environment)
from caustica.scene.shapes import box, plane

LIGHTS = {
    "point": PointLight(position=[0.5, 3.0, 0.5], intensity=[6.0, 6.0, 6.0]),
    "directional": DirectionalLight(direction=[-0.3, -1.0, -0.4], intensity=[1.5, 1.5, 1.5]),
    "spot": SpotLight(position=[0.0, 3.0, 1.0], direction=[0.0, -1.0, -0.3], intensity=[8.0, 8.0, 8.0],
                      inner_angle=25.0, outer_angle=35.0),
    "line": LineLight(start=[-1.0, 3.0, 0.0], end=[1.0, 3.0, 0.0], intensity=[8.0, 8.0, 8.0], samples=4),
}


def shadow_scene(light):
    camera = Camera(position=[0.0, 4.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=(96, 96))
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse([0.7, 0.7, 0.7]))
    block = SceneObject("block", box((0.8, 0.8, 0.8)), Diffuse([0.6, 0.3, 0.2]), Transform(position=[0.0, 0.6, 0.0]))
    return Scene(camera=camera, objects=[floor, block], lights=[light], environment=procedural_environment("black"))


@pytest.mark.parametrize("kind", sorted(LIGHTS))
def test_shadowed_diffuse_agrees_with_exact(kind, renderer):
    """Same irradiance and the same shadow: PSNR >= 30 dB, and fewer than 3% of pixels differ by more than 0.05.

    The residual is the shadow-map edge (3x3 PCF against the oracle's hard shadow rays).
    """
    scene = shadow_scene(LIGHTS[kind])
    raster = renderer.render(scene, "env-map")
    exact = renderer.render(scene, "exact")
    mse = np.mean((np.clip(raster, 0, 1) - np.clip(exact, 0, 1)) ** 2)
    assert 10 * np.log10(1.0 / mse) >= 30.0
    assert (np.abs(raster - exact).max(axis=2) > 0.05).mean() < 0.03
    assert exact.max() > 0.1  # the scene is lit


def test_point_light_irradiance_is_inverse_square():
    """Directly below a 4 W/sr point light at height 2 on a white floor: L = (1/pi) 4 / 2^2."""
    from caustica.renderer import Renderer

    camera = Camera(position=[0.0, 1.0, 0.0001], look_at=[0.0, 0.0, 0.0], up=[0, 0, -1], fov_y=10.0, size=(33, 33))
    scene = Scene(camera=camera, objects=[SceneObject("floor", plane((4.0, 4.0)), Diffuse([1.0, 1.0, 1.0]))],
                  lights=[PointLight(position=[0.0, 2.0, 0.0], intensity=[4.0, 4.0, 4.0])],
                  environment=procedural_environment("black"))
    for technique in ("env-map", "exact"):
        centre = Renderer().render(scene, technique)[16, 16]
        assert centre == pytest.approx(np.full(3, 1.0 / np.pi), rel=2e-3), technique


def test_state_keys_tell_lights_and_materials_apart():
    """Per-frame caches (shadow maps, impostor textures, caustic maps) key on state_key: equal for
    equal values, different when any number changes, hashable."""
    from caustica.cache import state_key
    from caustica.scene import Glass, PointLight

    light = PointLight(position=[1.0, 2.0, 3.0], intensity=[5.0, 5.0, 5.0])
    same = PointLight(position=[1.0, 2.0, 3.0], intensity=[5.0, 5.0, 5.0])
    moved = PointLight(position=[1.0, 2.0, 3.0 + 1e-12], intensity=[5.0, 5.0, 5.0])
    assert state_key(light) == state_key(same) and hash(state_key(light)) == hash(state_key(same))
    assert state_key(light) != state_key(moved)
    assert state_key(Glass(ior=1.5)) != state_key(Glass(ior=1.5, abbe=40.0))
    assert {state_key(Glass(ior=1.5)): 1}[state_key(Glass(ior=1.5))] == 1
