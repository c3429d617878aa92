"""Scenes are scale-free (DESIGN.md: every distance in scene units): the same scene in millimetres or
kilometres gives the same image. The photon passes' surface offsets and tolerances were absolute
(1e-4 scene units), so a glass ball of 0.06 mm radius lost its caustic; they are now fractions of the
casters' size (passes/caustics/casters.py, length_unit).
"""
from __future__ import annotations

import dataclasses

import pytest

import caustica.metrics
from caustica import load_scene


def scaled(scene, s: float):
    """``scene`` with every length times ``s``; point-light intensities times s^2 keep the irradiance."""
    objects = [o.moved(dataclasses.replace(o.transform, position=o.transform.position * s,
                                           scale=o.transform.scale * s)) for o in scene.objects]
    lights = [dataclasses.replace(light, position=light.position * s, intensity=light.intensity * s * s)
              if hasattr(light, "position") else light for light in scene.lights]
    c = scene.camera
    camera = dataclasses.replace(c, position=c.position * s, look_at=c.look_at * s, near=c.near * s, far=c.far * s)
    return dataclasses.replace(scene, objects=objects, lights=lights, camera=camera)


def psnr_against_unscaled(renderer, preset: str, technique: str, s: float) -> float:
    """PSNR of ``preset`` at 96x96 scaled by ``s`` against the same render unscaled."""
    scene = load_scene(preset)
    scene.camera = scene.camera.with_size(96, 96)
    reference = renderer.render(scene, technique)
    return caustica.metrics.psnr_linear(renderer.render(scaled(scene, s), technique), reference)


# Measured on llvmpipe, 96x96, PSNR of caustic-sphere scaled by s against s = 1 (depth-search alone:
# 50.1 dB at every s): caustic-mapping at s = 1e-4 28.9 dB before (the caustic gone), 1e-3 38.4, 1e-2 49.5;
# after 50.0, 50.1, 50.1; at s = 100 and 1000 53.8 dB before and after. photon-splats: 24.9 and 37.2 dB
# at 1e-4 and 1e-3 before, 50.0 and 50.1 after.
@pytest.mark.parametrize("technique", ["depth-search+caustic-mapping", "depth-search+photon-splats"])
@pytest.mark.parametrize("s", [1e-4, 1e-3, 1e3])
def test_caustics_do_not_depend_on_the_unit(renderer, technique, s):
    psnr = psnr_against_unscaled(renderer, "caustic-sphere", technique, s)
    assert psnr > 45.0, psnr


# Measured on llvmpipe, 96x96, impostors on mirror-concave scaled by s against s = 1: 24.8 and 27.7 dB at
# s = 1e-3 and 1e-2 while impostor_tolerance was 1e-3 scene units (at small scales it stopped the
# correction after one step), 46.1 and 50.7 dB now that it is 1e-4 bounding radii (35.9 at 1e-4, 45.6
# at 100, where the fixed tolerance was already fine).
@pytest.mark.parametrize("s", [1e-3, 1e-2])
def test_impostor_correction_does_not_depend_on_the_unit(renderer, s):
    psnr = psnr_against_unscaled(renderer, "mirror-concave", "impostors", s)
    assert psnr > 42.0, psnr


# Measured on llvmpipe, 96x96, per-vertex on mirror-concave scaled by s against s = 1: 28.0 and 28.1 dB at
# s = 10 and 100 before, 49.5 and 117.9 after. The mirror is a spherical cap: its principal curvatures are
# equal, so the least-squares fit's principal directions were round-off, and the frustum's up (the smaller
# of the principal direction's and the camera's, Kakimoto et al. 4.3) turned with the unit.
@pytest.mark.parametrize("s", [10.0, 100.0])
def test_per_vertex_frustum_does_not_turn_with_the_unit(renderer, s):
    psnr = psnr_against_unscaled(renderer, "mirror-concave", "per-vertex", s)
    assert psnr > 45.0, psnr
