"""The photon oracle against closed forms: flux conservation, the ball lens focus, IOR 1, dispersion, a mirror."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.raytrace.optics import fresnel_dielectric, reflect
from caustica.raytrace.photons import (
    irradiance_histogram,
    irradiance_on_pixels,
    trace_photons,
)
from caustica.scene import (
    Camera,
    Diffuse,
    DirectionalLight,
    Glass,
    Mirror,
    Scene,
    SceneObject,
    Transform,
    procedural_environment,
)
from caustica.scene.shapes import plane, sphere

DOWN = [0.0, -1.0, 0.0]


def ball_scene(glass: Glass, radius=0.5, height=1.0, floor=1000.0, direction=DOWN, irradiance=2.0) -> Scene:
    """A glass ball (traced as the true sphere) above a large diffuse floor at y = 0, a directional light."""
    ball = SceneObject("ball", sphere(radius, subdivisions=3), glass, Transform(position=[0.0, height, 0.0]))
    ground = SceneObject("floor", plane((floor, floor)), Diffuse(color=[0.5, 0.5, 0.5]))
    return Scene(camera=Camera(position=[0.0, 2.0, 3.0], look_at=[0.0, 0.0, 0.0], size=(64, 64)),
                 objects=[ball, ground], lights=[DirectionalLight(direction, [irradiance] * 3)],
                 environment=procedural_environment("black"))


def disc_mean(fn, samples=200_000) -> float:
    """Mean of fn(sin_i, cos_i) over a disc of impact parameters (uniform in area), midpoint rule."""
    u = (np.arange(samples) + 0.5) / samples  # (b / R)^2
    return float(np.mean(fn(np.sqrt(u), np.sqrt(1.0 - u))))


def sphere_paths(n: float, max_depth: int, split: bool):
    """Per impact parameter: Fresnel weight of each path leaving a sphere, and whether it heads down.

    A ray of incidence angle i refracts to t; after k internal reflections it
    leaves with the deviation D_k = 2 (i - t) + k (pi - 2 t) (the rainbow
    formula) and weight (1 - F)^2 F^k, with F the same at every interface; the
    external reflection deviates by pi - 2 i with weight F. Under light going
    straight down, a path reaches the floor when cos D > 0.
    """
    def weight_down(sin_i, cos_i):
        f = fresnel_dielectric(cos_i, 1.0, n)
        t = np.arcsin(sin_i / n)
        i = np.arcsin(sin_i)
        total = np.zeros_like(sin_i)
        internal = range(max_depth - 1) if split else range(1)  # k + 2 interactions <= max_depth
        for k in internal:
            deviation = 2.0 * (i - t) + k * (np.pi - 2.0 * t)
            total += np.where(np.cos(deviation) > 0, (1.0 - f) ** 2 * f**k, 0.0)
        if split:
            total += np.where(np.cos(np.pi - 2.0 * i) > 0, f, 0.0)
        return total
    return weight_down


@pytest.mark.parametrize("branches", ["transmit", "split"])
def test_flux_through_a_sphere_is_conserved(branches):
    """Floor flux = E pi R^2 times the disc mean of the Fresnel weights of the paths that head down.

    transmit: (1 - F1)(1 - F2); split: also the external reflection and up to
    six internal reflections (max_depth 8). 200k photons; bound 0.5 %
    (measured: transmit 0.025 %, split 0.019 %). The bookkeeping closes to 1e-9.
    """
    n, radius, e = 1.5, 0.5, 2.0
    scene = ball_scene(Glass(ior=n), radius=radius, irradiance=e)
    hits = trace_photons(scene, count=200_000, seed=1, max_depth=8, branches=branches, min_weight=0.0)
    expected = e * np.pi * radius**2 * disc_mean(sphere_paths(n, 8, branches == "split"))
    assert hits.emitted[0] == pytest.approx(e * np.pi * radius**2, rel=1e-9)
    assert hits.total_flux[0] == pytest.approx(expected, rel=5e-3)
    assert np.all(hits.object_index == 1) and np.all(hits.bounces >= 1)
    balance = hits.total_flux + hits.escaped + hits.dropped + hits.direct
    np.testing.assert_allclose(balance, hits.emitted, rtol=1e-9)


def paraxial_focus(hits, center_y: float) -> float:
    """Distance below the centre where exit rays cross the axis, extrapolated to zero ray height.

    Each floor hit gives a ray (position, direction) in a meridian plane; its
    axis crossing, fitted as f0 + c h^2 against the ray's height h at the
    centre plane (spherical aberration is quadratic), extrapolates to f0.
    """
    p, d = hits.position, hits.direction
    pxz, dxz = p[:, [0, 2]], d[:, [0, 2]]
    t_axis = -np.einsum("ij,ij->i", pxz, dxz) / np.einsum("ij,ij->i", dxz, dxz)
    focus = center_y - (p[:, 1] + t_axis * d[:, 1])
    height = np.linalg.norm(pxz + ((center_y - p[:, 1]) / d[:, 1])[:, None] * dxz, axis=1)
    design = np.stack([np.ones_like(height), height**2], axis=1)
    return float(np.linalg.lstsq(design, focus, rcond=None)[0][0])


def test_ball_lens_focuses_at_n_d_over_4_n_minus_1():
    """Paraxial photons (impact parameter <= R / 20) cross the axis at f = n D / (4 (n - 1)) from the centre.

    Bound 1 %; measured 1e-7 relative (the fit removes the spherical aberration).
    """
    n, radius, height = 1.5, 0.5, 2.0
    scene = ball_scene(Glass(ior=n), radius=radius, height=height, floor=20.0)
    hits = trace_photons(scene, count=20_000, target=([0.0, height, 0.0], radius / 20), branches="transmit")
    assert np.all(hits.bounces == 2)
    expected = n * 2 * radius / (4 * (n - 1))
    assert paraxial_focus(hits, height) == pytest.approx(expected, rel=1e-2)


def test_ior_one_passes_light_undeviated():
    """IOR 1: the floor under the ball gets exactly E inside the shadow disc and nothing outside.

    400k photons, 32x32 bins over 2R: the mean over the bins fully inside the
    disc is E within 1 % (measured 0.03 %), every such bin within 5 sigma of
    the photon count noise (measured at most 2.8 sigma), the bins fully outside are zero.
    """
    radius, e = 0.5, 3.0
    scene = ball_scene(Glass(ior=1.0), radius=radius, irradiance=e)
    hits = trace_photons(scene, count=400_000, seed=2)
    res, extent = 32, 2.2 * radius
    image = irradiance_histogram(hits, [0, 0, 0], [1, 0, 0], [0, 0, 1], extent, res)[..., 0]
    centers = (np.arange(res) + 0.5) / res * extent - extent / 2
    r = np.hypot(*np.meshgrid(centers, centers, indexing="ij"))
    half_diagonal = extent / res / np.sqrt(2)
    inside, outside = r + half_diagonal < radius, r - half_diagonal > radius
    assert inside.sum() > 400
    assert image[inside].mean() == pytest.approx(e, rel=1e-2)
    photons_per_bin = 400_000 * (extent / res) ** 2 / (np.pi * radius**2)
    assert np.all(np.abs(image[inside] - e) < 5 * e / np.sqrt(photons_per_bin))
    assert np.all(image[outside] == 0.0)
    assert np.all(hits.bounces == 2)


def test_dispersion_blue_focuses_nearer_than_red():
    """With an Abbe number (IOR R < G < B), each channel focuses at n_c R / (2 (n_c - 1)): blue nearest.

    Each channel's paraxial focus within 1 % of the closed form (measured 1e-7 relative).
    """
    glass = Glass(ior=1.5, abbe=20.0)
    n_rgb = glass.ior_rgb
    assert n_rgb[0] < n_rgb[1] < n_rgb[2]
    radius, height = 0.5, 2.0
    scene = ball_scene(glass, radius=radius, height=height, floor=20.0)
    hits = trace_photons(scene, count=10_000, target=([0.0, height, 0.0], radius / 20), branches="transmit")
    focus = []
    for c in range(3):
        channel = hits.flux[:, c] > 0
        assert np.all(hits.flux[channel][:, [k for k in range(3) if k != c]] == 0)
        focus.append(paraxial_focus(hits.select(channel), height))
        assert focus[c] == pytest.approx(n_rgb[c] * radius / (2 * (n_rgb[c] - 1)), rel=1e-2)
    assert focus[2] < focus[1] < focus[0]


def test_tilted_mirror_sends_light_by_the_law_of_reflection():
    """A flat mirror (unit square, colour 0.9) tilted 10 degrees from vertical reflects a slanted beam to the floor.

    Every hit travels along r = d - 2 (d.n) n (measured 9e-9); the flux-weighted
    centroid lands where the mirror centre's reflected ray meets the floor
    (bound 2 cm, about 5 sigma of the photon noise; measured 3.8 mm); the total
    is 0.9 E A |d.n| (bound 1 %, measured 0.05 %).
    """
    d = np.array([1.0, -1.0, 0.0]) / np.sqrt(2.0)
    center = np.array([0.0, 1.5, 0.0])
    angle = np.radians(80.0)  # plane normal +Y rotated about Z
    normal = np.array([-np.sin(angle), np.cos(angle), 0.0])
    mirror = SceneObject("mirror", plane((1.0, 1.0)), Mirror(color=[0.9, 0.9, 0.9]),
                         Transform(position=center, rotation=[0.0, 0.0, 80.0]))
    ground = SceneObject("floor", plane((40.0, 40.0)), Diffuse())
    e = 2.0
    scene = Scene(objects=[mirror, ground], lights=[DirectionalLight(d, [e] * 3)],
                  environment=procedural_environment("black"))
    hits = trace_photons(scene, count=100_000, seed=3)
    r = reflect(d, normal)
    np.testing.assert_allclose(hits.direction, np.broadcast_to(r, hits.direction.shape), atol=1e-7)
    spot = center + center[1] / -r[1] * r
    centroid = (hits.position * hits.flux[:, :1]).sum(axis=0) / hits.flux[:, 0].sum()
    assert np.linalg.norm(centroid - spot) < 0.02
    assert hits.total_flux[0] == pytest.approx(0.9 * e * abs(d @ normal), rel=1e-2)
    assert np.all(hits.bounces == 1) and np.all(hits.object_index == 1)


def test_pixel_irradiance_matches_the_histogram_on_a_floor():
    """Seen from straight above, the per-pixel caustic irradiance equals the floor histogram over the same squares.

    The photons binned by pixel (area from the pixel corners' hits) agree with
    the planar histogram to 1e-6: both bin the same photons into the same squares.
    """
    scene = ball_scene(Glass(ior=1.5), floor=20.0)
    hits = trace_photons(scene, count=50_000, seed=4)
    # The camera sits under the ball, looking down (+x right, -z up): it sees the 1 x 1 square of floor.
    fov_y = 2 * np.degrees(np.arctan(0.5 / 0.4))
    scene.camera = Camera(position=[0.0, 0.4, 0.0], look_at=[0.0, 0.0, 0.0], up=[0.0, 0.0, -1.0], fov_y=fov_y,
                          size=(16, 16))
    pixels = irradiance_on_pixels(hits, scene)
    histogram = irradiance_histogram(hits, [0, 0, 0], [1, 0, 0], [0, 0, 1], 1.0, 16)
    np.testing.assert_allclose(pixels, histogram, rtol=1e-6, atol=1e-9)
    assert pixels.sum() > 0
