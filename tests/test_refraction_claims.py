"""The TVCG paper's claim for convex objects: depth search beats Wyman's distance estimate.

Both techniques against the exact exit directions through a unit sphere, for
IOR 1.5, 1.75 and 0.8. Measured at 96x96 on llvmpipe (mean degrees):
depth-search 0.17 / 0.04 / 0.91, image-space 4.2 / 5.7 / 1.3, env-map 18.6 / 22.8 / 12.1.
"""
from __future__ import annotations

import pytest

from caustica.metrics import angular_error, exact_exit_directions
from caustica.scene import Camera, Glass, Scene, SceneObject, procedural_environment
from caustica.scene.shapes import sphere


def sphere_scene(ior: float) -> Scene:
    camera = Camera(position=[0.0, 0.3, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(96, 96))
    return Scene(camera=camera, objects=[SceneObject("ball", sphere(1.0, 5), Glass(ior=ior))],
                 environment=procedural_environment("sky-checker"))


@pytest.mark.parametrize("ior", [1.5, 1.75, 0.8])
def test_depth_search_is_closer_to_exact_than_image_space(ior, renderer):
    scene = sphere_scene(ior)
    reference = exact_exit_directions(scene, scene.camera)
    errors = {}
    for technique in ("env-map", "image-space", "depth-search"):
        dirs, valid = renderer.exit_directions(scene, technique)
        errors[technique] = angular_error(dirs, reference[0], valid & reference[1])["mean_deg"]
    assert errors["depth-search"] < errors["image-space"] < errors["env-map"], errors
