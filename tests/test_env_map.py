"""env-map against the CPU: the GPU environment lookup, IOR 1.0 glass, and the mirror sphere against ``exact``."""
from __future__ import annotations

import numpy as np
import pytest

import caustica
from caustica.render.draw import culls_back_faces
from caustica.scene import Camera, Glass, Mirror, Scene, SceneObject, Transform, procedural_environment
from caustica.scene.mesh import Mesh
from caustica.scene.shapes import sphere


def psnr(image, reference, peak=1.0):
    mse = np.mean((np.clip(image, 0, peak) - np.clip(reference, 0, peak)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(peak**2 / mse)


def sphere_scene(material, size=(96, 96), fov_y=40.0):
    camera = Camera(position=[0.0, 0.3, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=fov_y, size=size)
    obj = SceneObject("ball", sphere(1.0, subdivisions=5), material, Transform())
    return Scene(camera=camera, objects=[obj], environment=bilinear(procedural_environment("sky-checker")))


def bilinear(environment):
    """Per-sample comparisons with the CPU lookup and ``exact``: the same bilinear sample in each
    direction (Environment.filter; the footprint filter has its own tests in test_environment_filter)."""
    environment.filter = "bilinear"
    return environment


def test_background_matches_cpu_environment_lookup(renderer):
    """Every background pixel is the environment in the pixel's ray direction, as Mitsuba samples it."""
    scene = Scene(camera=Camera(position=[0, 0, 0], look_at=[0.3, 0.4, -1.0], fov_y=80, size=(128, 96)))
    bilinear(scene.environment)
    gpu = renderer.render(scene, "env-map")
    _, dirs = scene.camera.primary_rays()
    cpu = scene.environment.lookup(dirs[:, :, 0])
    assert gpu.shape == cpu.shape == (96, 128, 3)
    assert psnr(gpu, cpu) > 45.0
    assert np.abs(gpu - cpu).max() < 0.05 * max(1.0, cpu.max())


def test_ior_one_glass_is_invisible(renderer):
    """Glass of IOR 1.0 neither reflects (F = 0) nor bends: the image equals the empty scene."""
    with_ball = renderer.render(sphere_scene(Glass(ior=1.0)), "env-map")
    empty = sphere_scene(Glass(ior=1.0))
    empty.objects = []
    without = renderer.render(empty, "env-map")
    assert psnr(with_ball, without) > 45.0


def test_glass_absorption_follows_beer_lambert(renderer):
    """Under a white sky, the ray through the centre sees F + (1 - F) T with T = 0.2^(2R / 1) in G and B."""
    scene = sphere_scene(Glass(1.5, absorption_color=[1.0, 0.2, 0.2], absorption_distance=1.0), size=(97, 97))
    scene.environment = procedural_environment("white")
    image = renderer.render(scene, "env-map")
    centre = image[48, 48]
    fresnel = 0.04  # ((1.5 - 1) / (1.5 + 1))^2 at normal incidence
    assert centre[0] == pytest.approx(1.0, abs=1e-3)
    assert centre[1] == pytest.approx(fresnel + (1 - fresnel) * 0.2**2, abs=2e-3)
    assert centre[2] == pytest.approx(centre[1], abs=1e-5)


def test_mirror_sphere_agrees_with_exact(renderer):
    """A single mirror bounce is exact for both: env-map within 45 dB PSNR (sRGB) of the oracle at 4 spp.

    Measured 56.9 dB on llvmpipe; the residual is the tessellated silhouette and
    interpolated normals against the exact sphere.
    """
    from caustica.images import linear_to_srgb

    scene = sphere_scene(Mirror([0.9, 0.9, 0.9]))
    raster = renderer.render(scene, "env-map", spp=4)
    exact = renderer.render(scene, "exact", spp=4)
    value = psnr(linear_to_srgb(np.clip(raster, 0, 1)), linear_to_srgb(np.clip(exact, 0, 1)))
    assert value > 45.0, value


def test_exit_directions_are_the_single_refraction(renderer):
    """env-map's debug output: T1 = refract(view, N, 1/ior) at the front surface, undefined off the refractor."""
    from caustica.raytrace.optics import refract

    scene = sphere_scene(Glass(1.5), size=(33, 33))
    dirs, valid = renderer.exit_directions(scene, "env-map")
    origins, rays = scene.camera.primary_rays()
    rays = rays[:, :, 0]
    assert valid[16, 16] and not valid[0, 0]
    # Closed form at a few pixels: intersect the unit sphere, refract once.
    for row, col in [(16, 16), (10, 20), (22, 12)]:
        o, d = origins[row, col, 0], rays[row, col]
        b = np.dot(o, d)
        t = -b - np.sqrt(b * b - (np.dot(o, o) - 1.0))
        n = o + t * d
        expected, _ = refract(d[None], n[None], 1.0 / 1.5)
        angle = np.degrees(np.arccos(np.clip(np.dot(dirs[row, col], expected[0]) / np.linalg.norm(dirs[row, col]), -1, 1)))
        assert angle < 0.5, (row, col, angle)  # tessellated sphere: interpolated normals, flat facets


def test_dispersive_glass_uses_one_ior_per_channel(renderer):
    """Low-Abbe glass bends red and blue differently: the channels separate where the single-IOR
    variant keeps them together (the shader variant with DISPERSION=1)."""
    plain = renderer.render(sphere_scene(Glass(1.5)), "env-map")
    dispersive = renderer.render(sphere_scene(Glass(1.5, abbe=15.0)), "env-map")
    ball = (slice(30, 66), slice(30, 66))
    assert np.all(np.isfinite(dispersive))
    assert np.abs(dispersive[ball] - plain[ball]).max() > 0.05
    outside = (slice(0, 8), slice(0, 8))
    np.testing.assert_allclose(dispersive[outside], plain[outside], atol=1e-6)


@pytest.mark.parametrize("preset, technique", [("glass-sphere", "depth-search"), ("caustic-sphere", "env-map"),
                                               ("glass-sphere", "image-space")])
def test_culling_solids_back_faces_leaves_the_image_unchanged(renderer, monkeypatch, preset, technique):
    """ShadeSurfaces culls the back faces of solids seen from outside (they lie behind front faces):
    the image equals the one drawn with every face, pixel for pixel."""
    scene = caustica.load_scene(preset)
    scene.camera = scene.camera.with_size(96, 96)
    solids = [o for o in scene.objects if o.mesh.is_solid()]
    assert solids and all(culls_back_faces(o, scene.camera.clip_from_world()) for o in solids)
    culled = renderer.render(scene, technique)
    monkeypatch.setattr(Mesh, "is_solid", lambda self: False)
    every_face = renderer.render(scene, technique)
    assert np.array_equal(culled, every_face)


def test_no_culling_with_the_eye_inside_a_solid(renderer):
    """From inside a glass ball only its back faces face the eye: they are drawn, not culled."""
    scene = sphere_scene(Glass(ior=1.5))
    scene.camera = Camera(position=[0.0, 0.0, 0.5], look_at=[0.0, 0.0, -1.0], fov_y=40.0, size=(48, 48))
    assert not culls_back_faces(scene.objects[0], scene.camera.clip_from_world())
    inside = renderer.render(scene, "env-map")
    empty = renderer.render(Scene(camera=scene.camera, objects=[], environment=scene.environment), "env-map")
    assert np.abs(inside - empty).mean() > 0.01  # seen through the ball's far side, the sky is bent
