"""Sample planes (Iwasaki et al. 5.2): caustics maps against the exact photon oracle, flux conservation,
illumination maps and sliced object images."""
from __future__ import annotations

import numpy as np
import pytest

from caustica import scene as sc
from caustica.metrics.images import relmse
from caustica.raytrace.optics import fresnel_dielectric
from caustica.raytrace.photons import irradiance_histogram, trace_photons
from caustica.scene.shapes import plane, sphere
from caustica.scene.transform import Transform
from caustica.transport.sample_planes import sample_plane_maps, sliced_object_images

RADIUS, IOR = 0.5, 1.5
X, Z = [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]


@pytest.fixture(scope="module")
def ball_scene() -> sc.Scene:
    camera = sc.Camera(position=[0.0, 3.0, 0.001], look_at=[0.0, 0.0, 0.0], up=[0, 0, -1], fov_y=60.0, size=(16, 16))
    glass = sc.SceneObject("ball", sphere(RADIUS, subdivisions=4), sc.Glass(ior=IOR), Transform(position=[0.0, 1.0, 0.0]))
    floor = sc.SceneObject("floor", plane((40.0, 40.0)), sc.Diffuse([0.5, 0.5, 0.5]))
    return sc.Scene(camera=camera, objects=[glass, floor], lights=[sc.DirectionalLight([0.0, -1.0, 0.0], [1.0] * 3)],
                    environment=sc.procedural_environment("black"))


# Measured (sphere R 0.5, 2562 vertices, 129 directions, quantized table, floor 0.5 below the ball, 32 x 32
# texels over 2 x 2, oracle 'transmit' with 4M photons): relMSE 0.0075; 64 x 64 over 1 x 1: 0.040 (the
# ring's sharp edge is smeared by the per-vertex volumes, and the oracle's noise grows per texel).
def test_sample_plane_at_the_receiver_reproduces_the_exact_caustic(ball_scene):
    hits = trace_photons(ball_scene, 0, count=1_000_000, branches="transmit")
    reference = irradiance_histogram(hits, [0.0, 0.0, 0.0], X, Z, 2.0, 32)
    ours = sample_plane_maps(ball_scene, 0, [([0.0, 0.0, 0.0], X, Z, 2.0, 32)])[0]
    assert ours.shape == reference.shape == (32, 32, 3)
    assert relmse(ours, reference) < 0.015
    assert ours.max() == pytest.approx(reference.max(), rel=0.2)


def sphere_transmittance() -> float:
    b = (np.arange(100000) + 0.5) / 100000
    f = fresnel_dielectric(np.sqrt(1.0 - b * b), 1.0, IOR)
    return float(np.mean((1.0 - f) ** 2 * 2.0 * b))


def test_flux_through_planes_below_the_ball_is_conserved(ball_scene):
    # Incident flux pi R^2 E times the sphere's (1 - F1)(1 - F2): 99.1-99.2% of it crosses each plane (the
    # bilinear transmittance under-reads grazing Fresnel by ~0.6%; grazing rays leave upwards).
    expected = np.pi * RADIUS**2 * sphere_transmittance()
    planes = [([0.0, y, 0.0], X, Z, 40.0, 64) for y in (0.45, 0.25, 0.0, -1.0)]
    for out in sample_plane_maps(ball_scene, 0, planes, quantized=False):
        assert out.sum(axis=(0, 1)) * (40.0 / 64) ** 2 == pytest.approx(np.full(3, expected), rel=0.015)


def test_sliced_object_images_mask_the_caustic_by_the_surfaces_in_each_slab(ball_scene):
    planes = [([0.0, 0.0, 0.0], X, Z, 2.0, 16), ([0.0, 0.3, 0.0], X, Z, 2.0, 16)]
    caustics = sample_plane_maps(ball_scene, 0, planes)
    sliced = sliced_object_images(ball_scene, 0, planes)
    # The floor lies in the first slab (covered everywhere, reflectance 0.5), not in the second.
    assert np.all(sliced[0][..., 3] == 1.0) and np.all(sliced[1][..., 3] == 0.0)
    np.testing.assert_allclose(sliced[0][..., :3], 0.5 * caustics[0])
    assert np.all(sliced[1][..., :3] == 0.0)
    with pytest.raises(ValueError, match="light_index"):
        sample_plane_maps(ball_scene, 3, planes)
