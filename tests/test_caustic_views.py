"""The caustic map's fitted view holds a ball's outer halo under a close point light (issue 43).

A glass ball (radius 0.5, centre 1 above a 10 x 10 floor) under a point light
at 2.2: the ball spans about 25 degrees from the light, and Embree's photons
land 1 percent of the caustic's flux beyond 13 degrees, 0.1 percent beyond 20
and the last at about 33. A per-axis flux trim of 1e-3 alone fitted the map to
15 degrees and cut the halo along a square (a few 1e-3 of the flux lost).
"""
from __future__ import annotations

import numpy as np
import pytest

from caustica import scene as sc
from caustica.raytrace.photons import trace_photons
from caustica.renderer import Renderer
from caustica.scene.shapes import plane, sphere
from caustica.scene.transform import Transform

LIGHT = (0.0, 2.2, 0.0)


def close_light_ball() -> sc.Scene:
    camera = sc.Camera(position=[0.0, 2.6, 3.6], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=(16, 12))
    ball = sc.SceneObject("ball", sphere(0.5, 5), sc.Glass(ior=1.5), Transform(position=[0.0, 1.0, 0.0]))
    floor = sc.SceneObject("floor", plane((10.0, 10.0)), sc.Diffuse([0.6] * 3))
    return sc.Scene(camera=camera, objects=[ball, floor], lights=[sc.PointLight(list(LIGHT), [20.0] * 3)],
                    environment=sc.procedural_environment("black"))


def flux_outside(clip_from_world: np.ndarray, points: np.ndarray, flux: np.ndarray) -> float:
    """The fraction of ``flux`` whose ``points`` project outside the view's [-1, 1]^2 (or behind it)."""
    clip = np.c_[points, np.ones(len(points))] @ np.asarray(clip_from_world, np.float64).T
    inside = (clip[:, 3] > 0) & np.all(np.abs(clip[:, :2]) <= clip[:, 3:4], axis=1)
    return float(flux[~inside].sum() / flux.sum())


@pytest.fixture(scope="module")
def exact_landings():
    hits = trace_photons(close_light_ball(), count=1 << 16, max_depth=8, branches="transmit")
    on_floor = hits.position[:, 1] < 1e-3
    return hits.position[on_floor], hits.flux[on_floor].sum(axis=1)


# The most of the exact caustic flux that may land outside each technique's view. Before: 3.7e-3 and 1.2e-2.
# photon-splats lands its own photons narrower than exact (Wyman's d~: 99.9 percent within 14 degrees, not
# 20), so its view, fitted to them, still misses 2.9e-3 of exact's flux.
LOST = {"caustic-mapping": 2e-4, "photon-splats": 5e-3}


@pytest.mark.parametrize("technique", sorted(LOST))
def test_caustic_view_holds_the_halo(technique, exact_landings):
    """The fitted caustic view holds all but LOST of the exact caustic flux."""
    points, flux = exact_landings
    with Renderer((16, 12), keep_channels=True) as renderer:
        renderer.render(close_light_ball(), technique=f"env-map+{technique}")
        caustic = renderer.channels["caustic_maps"][0]
    assert caustic.clip_from_world is not None  # one frustum, not the cube atlas
    assert flux_outside(caustic.clip_from_world, points, flux) < LOST[technique]
