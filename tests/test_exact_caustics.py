"""``exact`` with caustics (issue 22 part 1): exact photons from the lights, gathered at the diffuse end
of every eye path (raytrace/caustic_gather.py), against closed forms and against Mitsuba's light tracer."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.metrics.images import psnr_linear, relmse
from caustica.raytrace.caustic_gather import CausticGather
from caustica.raytrace.photons import trace_photons
from caustica.renderer import Renderer
from caustica.scene import Camera, Diffuse, Glass, PointLight, Scene, SceneObject, Transform
from caustica.scene.environment import procedural_environment
from caustica.scene.shapes import plane, sphere

SIZE = (64, 48)


def ball_over_floor(ior: float, light=(0.6, 3.0, 0.4), intensity=6.0, with_ball: bool = True) -> Scene:
    """A glass ball of radius 0.5 resting 0.3 above a grey floor under a point light, in a black environment
    (as path-traced references have)."""
    ball = sphere(0.5, 5)
    ball.analytic_sphere = (np.zeros(3), 0.5)
    objects = [SceneObject("floor", plane((6.0, 6.0)), Diffuse(color=[0.7, 0.7, 0.7]))]
    if with_ball:
        objects.append(SceneObject("ball", ball, Glass(ior=ior), Transform(position=[0.0, 0.8, 0.0])))
    camera = Camera(position=[0.0, 2.6, 3.2], look_at=[0.0, 0.3, 0.0], fov_y=42.0, size=SIZE)
    return Scene(camera=camera, objects=objects, lights=[PointLight(position=list(light), intensity=[intensity] * 3)],
                 environment=procedural_environment("black"))


def test_an_index_one_ball_leaves_the_floor_lit_as_without_it():
    """At IOR 1 the ball neither bends nor reflects light (F = 0): every photon of its 'shadow' reaches the
    floor, so the floor must come out at the bare floor's E = I cos(theta) / d^2, the ball itself invisible.
    Without the photons the shadow stays black."""
    with Renderer() as renderer:
        bare = renderer.render(ball_over_floor(1.0, with_ball=False), "exact", 4)
        ball = ball_over_floor(1.0)
        lit = renderer.render(ball, "exact", 4, caustic_photons=400_000)
        dark = renderer.render(ball, "exact", 4, caustic_photons=0)
    shadow = (bare.mean(axis=2) - dark.mean(axis=2)) > 0.5 * bare.mean(axis=2)  # the opaque shadow
    assert shadow.sum() > 40
    ratio = lit.mean(axis=2)[shadow] / bare.mean(axis=2)[shadow]
    assert abs(np.median(ratio) - 1.0) < 0.03, np.median(ratio)
    assert np.percentile(np.abs(ratio - 1.0), 80) < 0.12
    assert psnr_linear(lit, bare) > max(35.0, psnr_linear(dark, bare) + 8.0)


def test_the_gather_returns_a_uniform_irradiance_and_nothing_elsewhere():
    """Photons of total flux P spread uniformly over a unit square give E = P / 1 m^2 inside it, on the
    side they arrived from; zero on the other side, on another object and beyond the kernel's reach."""
    from caustica.raytrace.photons import PhotonHits

    rng = np.random.default_rng(3)
    n = 200_000
    position = np.c_[rng.uniform(0, 1, n), np.zeros(n), rng.uniform(0, 1, n)]
    hits = PhotonHits(position, np.full((n, 3), 2.0 / n), np.zeros(n, np.int32), np.tile([0.0, 1.0, 0.0], (n, 1)),
                      np.tile([0.0, -1.0, 0.0], (n, 1)), np.ones(n, np.int64))
    gather = CausticGather(hits, 1024, max_radius=0.2)
    points = np.array([[0.5, 0.0, 0.5], [0.3, 0.0, 0.7], [0.5, 0.0, 0.5], [0.5, 0.0, 0.5], [1.5, 0.0, 0.5]])
    normals = np.array([[0, 1, 0], [0, 1, 0], [0, -1, 0], [0, 1, 0], [0, 1, 0]], float)
    objects = np.array([0, 0, 0, 1, 0])
    e = gather.irradiance(points, normals, objects)[:, 0]
    assert np.allclose(e[:2], 2.0, rtol=0.06), e  # about 1/sqrt(1024) noise, times the cone filter's
    assert np.all(e[2:] == 0.0), e


def test_exact_caustics_are_deterministic_and_reused():
    scene = ball_over_floor(1.5)
    with Renderer() as renderer:
        a = renderer.render(scene, "exact", 1, caustic_photons=100_000)
        scene.camera.position = np.array([0.3, 2.6, 3.1])  # a camera move reuses the photons
        renderer.render(scene, "exact", 1, caustic_photons=100_000)
        scene.camera.position = np.array([0.0, 2.6, 3.2])
        b = renderer.render(scene, "exact", 1, caustic_photons=100_000)
    assert np.array_equal(a, b)


def test_a_glass_ball_focuses_light_inside_its_shadow():
    """Under an IOR 1.5 ball the caustic puts more light on the floor than the bare floor gets (the focus),
    within the geometric shadow; the total flux the ball sends down is at most what it intercepts."""
    scene = ball_over_floor(1.5)
    hits = trace_photons(scene, count=200_000, seed=1)
    assert len(hits) > 0
    assert np.all(hits.total_flux <= hits.emitted * (1.0 + 1e-9))
    with Renderer() as renderer:
        bare = renderer.render(ball_over_floor(1.5, with_ball=False), "exact", 4)
        lit = renderer.render(scene, "exact", 4, caustic_photons=400_000)
    assert lit.mean(axis=2).max() > 3.0 * bare.mean(axis=2).max()


def test_exact_caustics_match_mitsubas_light_tracer(reference_cache):
    """On diffuse pixels Mitsuba's composite takes the light part from its light tracer (ptracer), which
    finds caustics by construction: exact's caustic region must agree within the reference's noise."""
    pytest.importorskip("mitsuba", reason="the Mitsuba reference needs the 'reference' extra")
    from caustica.metrics.regions import region_masks
    from caustica.reference.render import render_reference

    scene = ball_over_floor(1.5)
    reference = render_reference(scene, spp=512, progress=False, cache_dir=reference_cache)
    masks = region_masks(scene)
    with Renderer() as renderer:
        with_caustics = renderer.render(scene, "exact", 4)
        without = renderer.render(scene, "exact", 4, caustic_photons=0)
    caustic = masks["caustic"]
    assert caustic.sum() > 30
    error, error_without = relmse(with_caustics, reference, caustic), relmse(without, reference, caustic)
    assert error < 0.03 and error < 0.2 * error_without, (error, error_without)
