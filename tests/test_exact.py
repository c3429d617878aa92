"""The exact oracle against closed forms: Fresnel, Snell through a ball, Beer-Lambert."""
from __future__ import annotations

import math

import numpy as np
import pytest

from caustica.errors import TechniqueError
from caustica.raytrace.embree_scene import RayScene, ray_scene_for
from caustica.raytrace.optics import fresnel_dielectric, reflect, refract
from caustica.raytrace.paths import TraceStats, distance_along_negative_normal, exit_directions, interface, trace
from caustica.scene import Camera, Diffuse, Glass, Mirror, PointLight, Scene, SceneObject, Transform
from caustica.scene.environment import procedural_environment
from caustica.scene.mesh import Mesh
from caustica.scene.shapes import cylinder, plane, sphere
from caustica.techniques.exact import Exact, ExactParams


# -- helpers ----------------------------------------------------------------------


def fresnel_from_angles(theta_i: float, n_i: float, n_t: float) -> float:
    """Independent form of the Fresnel equations: R_s = sin^2(i-t)/sin^2(i+t), R_p = tan^2(i-t)/tan^2(i+t)."""
    s = n_i / n_t * math.sin(theta_i)
    if s >= 1.0:
        return 1.0
    theta_t = math.asin(s)
    if theta_i == 0.0:
        return ((n_i - n_t) / (n_i + n_t)) ** 2
    r_s = (math.sin(theta_i - theta_t) / math.sin(theta_i + theta_t)) ** 2
    r_p = (math.tan(theta_i - theta_t) / math.tan(theta_i + theta_t)) ** 2
    return 0.5 * (r_s + r_p)


def ball(radius: float = 1.0, subdivisions: int = 6, analytic: bool = True) -> Mesh:
    mesh = sphere(radius, subdivisions)
    if analytic:
        mesh.analytic_sphere = (np.zeros(3), radius)
    return mesh


def one_object_scene(mesh: Mesh, material, environment: str = "sky-checker", position=(0.0, 0.0, 0.0)) -> Scene:
    obj = SceneObject("ball", mesh, material, Transform(position=position))
    return Scene(objects=[obj], environment=procedural_environment(environment))


def rays_towards_ball(impact: np.ndarray, radius: float = 1.0, seed: int = 0):
    """Rays parallel to -Z at impact parameters ``impact`` (fractions of R), random azimuth."""
    phi = np.random.default_rng(seed).uniform(0.0, 2.0 * np.pi, len(impact))
    b = impact * radius
    origins = np.stack([b * np.cos(phi), b * np.sin(phi), np.full_like(b, 5.0 * radius)], axis=1)
    dirs = np.tile([0.0, 0.0, -1.0], (len(b), 1))
    return origins, dirs


def ball_deviation(impact: np.ndarray, ior: float) -> np.ndarray:
    """Closed form: two Snell refractions through a ball deviate by 2 (theta_i - theta_t)."""
    theta_i = np.arcsin(impact)
    theta_t = np.arcsin(np.sin(theta_i) / ior)
    return 2.0 * (theta_i - theta_t)


# -- optics -----------------------------------------------------------------------


@pytest.mark.parametrize("n_i, n_t", [(1.0, 1.5), (1.5, 1.0)])
def test_fresnel_normal_incidence_is_four_percent(n_i, n_t):
    assert fresnel_dielectric(1.0, n_i, n_t) == pytest.approx(0.04, abs=1e-12)


@pytest.mark.parametrize("degrees", [30.0, 60.0, 80.0])
def test_fresnel_matches_closed_form_air_to_glass(degrees):
    theta = math.radians(degrees)
    assert fresnel_dielectric(math.cos(theta), 1.0, 1.5) == pytest.approx(fresnel_from_angles(theta, 1.0, 1.5), abs=1e-12)


def test_fresnel_matches_closed_form_glass_to_air_and_total_internal_reflection():
    critical = math.degrees(math.asin(1.0 / 1.5))
    for degrees in (10.0, 30.0, 40.0):
        theta = math.radians(degrees)
        assert fresnel_dielectric(math.cos(theta), 1.5, 1.0) == pytest.approx(fresnel_from_angles(theta, 1.5, 1.0), abs=1e-12)
    beyond = np.radians([critical + 0.01, 45.0, 60.0, 80.0, 89.9])
    np.testing.assert_array_equal(fresnel_dielectric(np.cos(beyond), 1.5, 1.0), 1.0)


def test_brewster_angle_leaves_only_s_polarisation():
    theta_b = math.atan(1.5)
    theta_t = math.asin(math.sin(theta_b) / 1.5)
    r_s = (math.sin(theta_b - theta_t) / math.sin(theta_b + theta_t)) ** 2
    # R = (R_s + R_p) / 2 with R_p = 0 at Brewster's angle.
    assert fresnel_dielectric(math.cos(theta_b), 1.0, 1.5) == pytest.approx(0.5 * r_s, abs=1e-12)


def test_refract_obeys_snell_and_flags_total_internal_reflection():
    rng = np.random.default_rng(1)
    n = np.tile([0.0, 0.0, 1.0], (1000, 1))
    d = rng.normal(size=(1000, 3))
    d[:, 2] = -np.abs(d[:, 2])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for eta in (1.0 / 1.5, 1.5):
        t, tir = refract(d, n, eta)
        sin_i = np.linalg.norm(np.cross(d, n), axis=1)
        sin_t = np.linalg.norm(np.cross(t, n), axis=1)
        np.testing.assert_array_equal(tir, eta * sin_i > 1.0)
        np.testing.assert_allclose(sin_t[~tir], eta * sin_i[~tir], atol=1e-12)
        assert np.all(t[~tir, 2] < 0)  # transmitted through the surface
        np.testing.assert_allclose(t[tir], reflect(d[tir], n[tir]), atol=1e-12)
        # Incident, normal and transmitted directions are coplanar.
        np.testing.assert_allclose(np.einsum("ij,ij->i", np.cross(d, n), t), 0.0, atol=1e-12)


def test_glass_side_is_the_shading_normals_at_a_smooth_silhouette():
    """A grazing ray meets a face from outside where the interpolated normal, tilted 20 degrees, turns away
    from it (d . n = 0.25): it leaves the smooth surface from inside at cos 0.25, where 1.5^2 (1 - 0.25^2) > 1,
    so it is totally reflected about the shading normal, as Mitsuba's dielectric does. Facing the ray, the
    same normal gives the ordinary entry: Fresnel at its own angle, bent into the face."""
    d = np.array([[1.0, 0.0, -0.1]]) / math.hypot(1.0, 0.1)
    geometric = np.array([[0.0, 0.0, 1.0]])
    tilted = np.array([[math.sin(math.radians(20)), 0.0, math.cos(math.radians(20))]])
    assert float(d[0] @ tilted[0]) > 0.2 and float(d[0] @ geometric[0]) < 0
    away = interface(d, tilted, geometric, np.array([1.5]))
    assert not away.entering[0] and away.tir[0] and away.reflectance[0] == 1.0
    np.testing.assert_allclose(away.refracted, reflect(d, tilted), atol=1e-12)
    np.testing.assert_allclose(away.geometric_normal, geometric)
    toward = np.array([[-math.sin(math.radians(20)), 0.0, math.cos(math.radians(20))]])
    entry = interface(d, toward, geometric, np.array([1.5]))
    cos_i = -float(d[0] @ toward[0])
    assert entry.entering[0] and not entry.tir[0]
    assert entry.reflectance[0] == pytest.approx(fresnel_from_angles(math.acos(cos_i), 1.0, 1.5), abs=1e-9)
    assert entry.refracted[0, 2] < 0  # into the face


def test_smooth_prism_silhouette_matches_mitsuba():
    """An 8-sided smooth-shaded glass column in the sky: the pixels on its outline against Mitsuba's path
    tracer (2048 spp). Measured 27.0 dB; with the face deciding the side (the earlier rule) 25.0."""
    pytest.importorskip("mitsuba", reason="the Mitsuba reference needs the 'reference' extra")
    from scipy import ndimage

    from caustica.metrics.images import psnr_linear
    from caustica.metrics.regions import region_masks
    from caustica.reference.render import render_reference

    column = SceneObject("column", cylinder(0.5, 1.2, 8), Glass(ior=1.5),
                         Transform(position=[0, 0.6, 0], rotation=[0, 10, 0]))
    floor = SceneObject("floor", plane((10.0, 10.0)), Diffuse(color=[0.7, 0.7, 0.7]))
    camera = Camera(position=[2.6, 1.3, 2.2], look_at=[0, 0.55, 0], fov_y=38.0, size=(64, 48))
    scene = Scene(camera=camera, objects=[floor, column], environment=procedural_environment("sky-checker"),
                  name="smooth-prism")
    reference = render_reference(scene, spp=2048, progress=False)
    glass = region_masks(scene)["refractor"]
    outline = ndimage.binary_dilation(glass) & ~ndimage.binary_erosion(glass)
    assert outline.sum() > 100
    image = Exact().render(scene, camera, ExactParams(), 4)
    assert psnr_linear(image, reference, outline) > 26.0


# -- ray queries ------------------------------------------------------------------


def test_intersect_reports_object_position_and_normals():
    plane = Mesh(np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], float), None, np.array([[0, 1, 2], [0, 2, 3]]))
    scene = Scene(objects=[SceneObject("floor", plane, Diffuse()), SceneObject("ball", ball(0.5), Glass(), Transform(position=(0, 0, 2)))])
    rs = RayScene(scene)
    rng = np.random.default_rng(2)
    origins = np.column_stack([rng.uniform(-3, 3, (500, 2)), np.full(500, 10.0)])
    dirs = np.tile([0.0, 0.0, -1.0], (500, 1))
    hits = rs.intersect(origins, dirs)
    on_ball = np.hypot(origins[:, 0], origins[:, 1]) < 0.5
    assert hits.hit.all()
    np.testing.assert_array_equal(hits.object_index, np.where(on_ball, 1, 0))
    np.testing.assert_allclose(hits.position, origins + hits.t[:, None] * dirs, atol=1e-12)
    np.testing.assert_allclose(hits.position[~on_ball, 2], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(hits.position[on_ball] - [0, 0, 2], axis=1), 0.5, atol=1e-12)
    np.testing.assert_allclose(hits.geometric_normal[~on_ball], [[0, 0, 1]] * (~on_ball).sum())
    # Shadow rays: blocked by the ball only between it and the light.
    up = -dirs
    start = hits.position[~on_ball] + 1e-6 * up[~on_ball]
    blocked = rs.occluded(start, up[~on_ball], 10.0)
    np.testing.assert_array_equal(blocked, np.hypot(start[:, 0], start[:, 1]) < 0.5)
    assert not rs.occluded(start, up[~on_ball], 1.0).any()


def test_distance_along_negative_normal_of_a_sphere_is_its_diameter():
    np.testing.assert_allclose(distance_along_negative_normal(sphere(0.7, 3)), 1.4, atol=1e-5)


# -- exit directions ----------------------------------------------------------------


@pytest.mark.parametrize("ior", [1.5, 1.33, 2.0])
def test_exit_directions_through_an_analytic_ball_match_the_closed_form(ior):
    impact = np.linspace(0.0, 0.99, 400)
    scene = one_object_scene(ball(), Glass(ior))
    origins, dirs = rays_towards_ball(impact)
    exit_dir, valid, path_length = exit_directions(RayScene(scene), scene, origins, dirs)
    assert valid.all()
    deviation = np.arccos(np.clip(-exit_dir[:, 2], -1.0, 1.0))
    np.testing.assert_allclose(deviation, ball_deviation(impact, ior), atol=1e-4)
    # Chord inside: 2 R cos(theta_t).
    np.testing.assert_allclose(path_length, 2.0 * np.cos(np.arcsin(impact / ior)), atol=1e-9)


def test_exit_directions_through_a_tessellated_ball_are_close():
    impact = np.linspace(0.0, 0.95, 400)
    scene = one_object_scene(ball(analytic=False), Glass(1.5))
    origins, dirs = rays_towards_ball(impact)
    exit_dir, valid, _ = exit_directions(RayScene(scene), scene, origins, dirs)
    assert valid.all()
    deviation = np.arccos(np.clip(-exit_dir[:, 2], -1.0, 1.0))
    np.testing.assert_allclose(deviation, ball_deviation(impact, 1.5), atol=5e-3)


@pytest.mark.parametrize("analytic", [True, False])
def test_index_one_glass_leaves_rays_undeviated(analytic):
    scene = one_object_scene(ball(analytic=analytic), Glass(1.0))
    origins, dirs = rays_towards_ball(np.linspace(0.0, 0.99, 300))
    exit_dir, valid, _ = exit_directions(RayScene(scene), scene, origins, dirs)
    assert valid.all()
    np.testing.assert_allclose(exit_dir, dirs, atol=1e-6)


def test_index_one_ball_renders_as_the_environment():
    camera = Camera(position=(0.0, 0.5, 4.0), size=(64, 48))
    with_ball = one_object_scene(ball(), Glass(1.0))
    empty = Scene(environment=with_ball.environment)
    technique = Exact()
    image = technique.render(with_ball, camera, ExactParams(), 1)
    background = technique.render(empty, camera, ExactParams(), 1)
    assert image.shape == (48, 64, 3) and image.dtype == np.float32
    assert np.abs(image - background).mean() < 1e-4


# -- radiance -----------------------------------------------------------------------


def test_mirror_ball_reflects_the_environment():
    scene = one_object_scene(ball(), Mirror(color=(0.9, 0.8, 0.7)))
    origins, dirs = rays_towards_ball(np.linspace(0.0, 0.99, 200))
    radiance = trace(RayScene(scene), scene, origins, dirs)
    # Closed form: hit point on the unit sphere, normal = hit point, r = reflect(d, n).
    b2 = np.sum(origins[:, :2] ** 2, axis=1)
    hit = origins.copy()
    hit[:, 2] = np.sqrt(1.0 - b2)
    expected = np.array([0.9, 0.8, 0.7]) * scene.environment.lookup(reflect(dirs, hit))
    np.testing.assert_allclose(radiance, expected, rtol=1e-5, atol=1e-6)


def test_beer_lambert_through_the_centre_of_a_ball():
    glass = Glass(1.5, absorption_color=(0.5, 0.7, 0.9), absorption_distance=1.0)
    scene = one_object_scene(ball(), glass, environment="white")
    rs = RayScene(scene)
    origin, direction = np.array([[0.0, 0.0, 5.0]]), np.array([[0.0, 0.0, -1.0]])
    f = 0.04
    transmittance = np.exp(-glass.absorption_coefficient * 2.0)
    # Depth 2: front reflection plus the straight path through (the internal reflection is cut).
    np.testing.assert_allclose(trace(rs, scene, origin, direction, max_depth=2)[0], f + (1 - f) ** 2 * transmittance, rtol=1e-12)
    # Every internal reflection: f + (1-f)^2 T / (1 - f T) (forward and backward exits).
    stats = TraceStats()
    radiance = trace(rs, scene, origin, direction, max_depth=32, min_weight=0.0, stats=stats)
    np.testing.assert_allclose(radiance[0], f + (1 - f) ** 2 * transmittance / (1 - f * transmittance), rtol=1e-12)
    assert stats.total < 1e-12


def test_dropped_weight_is_reported_per_depth():
    scene = one_object_scene(ball(), Glass(1.5), environment="white")
    stats = TraceStats()
    trace(RayScene(scene), scene, np.array([[0.0, 0.0, 5.0]]), np.array([[0.0, 0.0, -1.0]]), max_depth=2, stats=stats)
    # The internal reflection at the back face, weight (1 - F) F, is cut at depth 3.
    assert stats.by_depth_limit[3] == pytest.approx(0.96 * 0.04, rel=1e-12)


def test_dispersive_glass_traces_each_channel_with_its_own_index():
    dispersive = Glass(1.5, abbe=20.0)
    assert np.ptp(dispersive.ior_rgb) > 0.01
    origins, dirs = rays_towards_ball(np.linspace(0.0, 0.95, 100))
    radiance = trace(RayScene(s := one_object_scene(ball(), dispersive)), s, origins, dirs)
    for c in range(3):
        single = one_object_scene(ball(), Glass(dispersive.ior_rgb[c]))
        np.testing.assert_allclose(radiance[:, c], trace(RayScene(single), single, origins, dirs)[:, c], rtol=1e-12)


def test_diffuse_floor_lit_by_a_point_light_with_a_glass_shadow():
    plane = Mesh(np.array([[-5, 0, -5], [5, 0, -5], [5, 0, 5], [-5, 0, 5]], float), None, np.array([[0, 2, 1], [0, 3, 2]]))
    light = PointLight(position=(0.0, 4.0, 0.0), intensity=(20.0, 20.0, 20.0))
    scene = Scene(
        objects=[SceneObject("floor", plane, Diffuse(color=(0.5, 0.5, 0.5))), SceneObject("ball", ball(0.5), Glass(), Transform(position=(0, 2, 0)))],
        lights=[light],
        environment=procedural_environment("black"),
        intensity_scale=2.0,
    )
    x = np.array([0.0, 1.5, 3.0])
    origins = np.column_stack([x, np.full(3, 1.0), np.full(3, 3.0)])
    targets = np.column_stack([x, np.zeros(3), np.zeros(3)])
    dirs = (targets - origins) / np.linalg.norm(targets - origins, axis=1, keepdims=True)
    radiance = trace(RayScene(scene), scene, origins, dirs)
    distance = np.linalg.norm(light.position - targets, axis=1)
    irradiance = 20.0 * (4.0 / distance) / distance**2
    expected = 0.5 / np.pi * irradiance * 2.0
    expected[0] = 0.0  # under the ball: glass casts an opaque shadow
    np.testing.assert_allclose(radiance[:, 0], expected, rtol=1e-9, atol=1e-12)


# -- technique ----------------------------------------------------------------------


def test_exact_params_are_validated():
    technique = Exact()
    assert technique.make_params(max_depth=3).max_depth == 3
    for bad in ({"max_depth": -1}, {"max_depth": 2.5}, {"min_weight": 1.5}, {"min_weight": -0.1}):
        with pytest.raises(TechniqueError):
            technique.make_params(**bad)
    with pytest.raises(ValueError):
        ExactParams(max_depth=-1)


def test_ray_scene_is_cached_until_an_object_moves():
    scene = one_object_scene(ball(), Glass())
    first = ray_scene_for(scene)
    assert ray_scene_for(scene) is first
    scene.objects[0] = scene.objects[0].moved(Transform(position=(1.0, 0.0, 0.0)))
    assert ray_scene_for(scene) is not first


def test_dn_of_an_icosphere_has_no_slipped_rays():
    """Every vertex of a subdivided icosphere aims exactly at its antipodal vertex; none may slip through."""
    from caustica.raytrace.paths import distance_along_negative_normal
    from caustica.scene.shapes import sphere

    dn = distance_along_negative_normal(sphere(1.0, 5))
    np.testing.assert_allclose(dn, 2.0, atol=1e-4)


def test_exact_image_does_not_depend_on_its_row_bands(monkeypatch):
    """exact traces rows in bands of about one trace batch; bands of a few rows give the same bytes."""
    import caustica
    from caustica.techniques import exact

    scene = caustica.load_scene("caustic-sphere")
    renderer = caustica.Renderer((40, 28))
    whole = renderer.render(scene, "exact", spp=4)
    monkeypatch.setattr(exact, "BATCH_SIZE", 40 * 4 * 3)  # three rows a band, the last band shorter
    banded = renderer.render(scene, "exact", spp=4)
    assert np.array_equal(whole, banded)
