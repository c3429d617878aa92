"""``exact`` with the environment's light sampled: known irradiances, glass, the sun as a light, its caustic."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from caustica.raytrace.embree_scene import ray_scene_for
from caustica.raytrace.environment_light import EnvironmentLight, hammersley, rotated_pattern
from caustica.raytrace.paths import shade_diffuse
from caustica.scene import Camera, Diffuse, DirectionalLight, Glass, Scene, SceneObject, Transform
from caustica.scene.environment import Environment, procedural_environment, uv_to_direction
from caustica.scene.shapes import box, plane, sphere
from caustica.techniques.exact import Exact, ExactParams, environment_sampling

ALBEDO = 0.5
UP = np.array([0.0, 1.0, 0.0])


def ball(radius=1.0):
    mesh = sphere(radius, 4)
    mesh.analytic_sphere = (np.zeros(3), radius)
    return mesh


def floor_scene(objects, environment, lights=(), size=(48, 36)) -> Scene:
    floor = SceneObject("floor", plane((40.0, 40.0)), Diffuse(color=[ALBEDO] * 3))
    camera = Camera(position=[0.0, 7.0, 6.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=size)
    return Scene(camera=camera, objects=[floor, *objects], lights=list(lights), environment=environment, name="env-test")


def floor_radiance(scene, points, **params) -> np.ndarray:
    """Radiance (n, 3) the floor reflects at ``points`` (n, 3) on it (normal +y)."""
    normal = np.tile(UP, (len(points), 1))
    sampling = environment_sampling(scene, ExactParams(**params))
    return shade_diffuse(ray_scene_for(scene), scene, np.asarray(points, float), normal, normal,
                         np.full((len(points), 3), ALBEDO), environment=sampling)


def test_white_environment_floor_far_from_objects_has_radiance_albedo():
    """Irradiance pi from a white sky: radiance = albedo in every pixel of a bare floor, and far from a ball."""
    bare = floor_scene([], procedural_environment("white"))
    image = Exact().render(bare, bare.camera, ExactParams(), 1)
    assert np.allclose(image, ALBEDO, rtol=1e-6)
    scene = floor_scene([SceneObject("ball", ball(), Diffuse(color=[0.0] * 3), Transform(position=[0, 2, 0]))],
                        procedural_environment("white"))
    assert np.allclose(floor_radiance(scene, [[15.0, 0.0, 15.0], [-12.0, 0.0, 3.0]]), ALBEDO, rtol=1e-9)


@pytest.mark.parametrize("samples", [50, 64, 200, 1024])
def test_floor_under_a_black_ball_sees_the_unoccluded_fraction(samples):
    """A black ball (radius R, centre at distance d, angle beta from the normal, wholly above the floor)
    hides the cosine-weighted fraction (R / d)^2 cos(beta) of a white sky: E = pi (1 - that) (Modest,
    Radiative Heat Transfer, view factor of a sphere from a tilted element)."""
    scene = floor_scene([SceneObject("ball", ball(), Diffuse(color=[0.0] * 3), Transform(position=[0, 2, 0]))],
                        procedural_environment("white"))
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.5]])
    offset = np.array([0.0, 2.0, 0.0]) - points
    distance = np.linalg.norm(offset, axis=1)
    expected = ALBEDO * (1.0 - (1.0 / distance) ** 2 * offset[:, 1] / distance)
    radiance = floor_radiance(scene, points, environment_samples=samples)
    # Stratified samples of an edge: an error of about samples^(-3/4).
    tolerance = ALBEDO * 1.5 * samples ** -0.75
    assert np.allclose(radiance, expected[:, None], rtol=0, atol=tolerance), (radiance[:, 0], expected)
    # The old term: unoccluded, the white sky's full irradiance (0.4% over: the SH projection of 16x32 texels).
    assert np.allclose(floor_radiance(scene, points, environment_samples=0), ALBEDO, rtol=5e-3)


def test_ior_one_glass_ball_casts_no_environment_shadow():
    """Glass of IOR 1 neither reflects nor bends: the cosine rays pass it with weight 1."""
    scene = floor_scene([SceneObject("ball", ball(), Glass(ior=1.0), Transform(position=[0, 1.2, 0]))],
                        procedural_environment("white"))
    points = np.array([[0.0, 0.0, 0.0], [0.5, 0.0, 0.3], [-0.8, 0.0, 0.0]])
    assert np.allclose(floor_radiance(scene, points), ALBEDO, rtol=1e-9)
    # A black ball in its place: a shadow of (R / d)^2 = 1 / 1.44 of the sky under it.
    opaque = floor_scene([SceneObject("ball", ball(), Diffuse(color=[0.0] * 3), Transform(position=[0, 1.2, 0]))],
                         procedural_environment("white"))
    assert floor_radiance(opaque, points[:1])[0, 0] == pytest.approx(ALBEDO * (1 - 1 / 1.44), rel=0.03)


def sun_environment(direction, radius_degrees=3.0, radiance=60.0, size=(512, 256)) -> Environment:
    """A black sky with one disc of ``radiance`` texels around ``direction``."""
    width, height = size
    v = np.arange(height) / (height - 1)  # the lookup's rows sit at v = y / (H - 1)
    u = (np.arange(width) + 0.5) / width
    d = uv_to_direction(np.stack(np.meshgrid(u, v), axis=-1))
    disc = d @ (np.asarray(direction) / np.linalg.norm(direction)) > np.cos(np.radians(radius_degrees))
    return Environment(np.where(disc[..., None], np.float32(radiance), np.float32(0.0)) * np.ones(3, np.float32),
                       source="test:sun")


def sun_irradiance(environment: Environment, direction, n=1200, cosine=True) -> float:
    """The irradiance the environment gives a plane facing ``direction`` (``cosine`` False: its radiance
    integrated over the sphere): a fine midpoint quadrature."""
    v = (np.arange(n) + 0.5) / n
    u = (np.arange(2 * n) + 0.5) / (2 * n)
    uu, vv = np.meshgrid(u, v)
    d = uv_to_direction(np.stack([uu, vv], axis=-1))
    solid = (2 * np.pi / (2 * n)) * (np.pi / n) * np.sin(np.pi * vv)
    cos = np.maximum(d @ (np.asarray(direction) / np.linalg.norm(direction)), 0.0) if cosine else 1.0
    return float((environment.lookup(d)[..., 0] * cos * solid).sum())


def test_bright_part_sampling_integrates_the_bright_texels():
    """1 / pdf over the samples is the bright cells' solid angle; L / pdf their power; the split adds up."""
    sun = (0.3, 0.8, -0.5)
    env = sun_environment(sun)
    light = EnvironmentLight(env)
    d, radiance, pdf = light.sample_bright(hammersley(8192))
    assert (radiance[:, 0] / pdf).mean() == pytest.approx(light.bright_power(), rel=0.01)
    assert light.bright_power() == pytest.approx(sun_irradiance(env, sun, cosine=False), rel=0.01)
    assert light.bright_power() == pytest.approx(60.0 * 2 * np.pi * (1 - np.cos(np.radians(3.0))), rel=0.05)
    assert np.allclose(Environment(light.bright_image).lookup(d) + light.rest.lookup(d), env.lookup(d), atol=1e-5)
    assert np.all(light.rest.image == 0.0)
    assert not EnvironmentLight(procedural_environment("white")).has_bright
    # The per-point patterns are the same at the same point, whatever batch it comes in.
    p = np.array([[0.1, 0.0, 0.2], [3.0, 0.0, -1.0]])
    assert np.array_equal(rotated_pattern(p, 8, 1)[1], rotated_pattern(p[1:], 8, 1)[0])


def test_sun_environment_matches_the_equivalent_directional_light():
    """A sun-only sky and a DirectionalLight of its direction and irradiance light the floor alike,
    shadow of a box included: 90% of the pixels within 3% (the rest: the penumbra of a 3-degree sun), 2% on
    average over the image; the umbra is dark."""
    sun = np.array([0.5, 0.75, 0.3])
    sun /= np.linalg.norm(sun)
    env = sun_environment(sun)
    irradiance = sun_irradiance(env, sun)
    objects = [SceneObject("box", box((1.0, 1.5, 1.0)), Diffuse(color=[0.6] * 3), Transform(position=[0, 0.75, 0]))]
    by_sky = floor_scene(objects, env)
    by_light = floor_scene(objects, procedural_environment("black"),
                           [DirectionalLight(direction=-sun, intensity=[irradiance] * 3)])
    params = ExactParams(environment_light_samples=64, environment_bounce=False)
    sky, lit = (Exact().render(s, s.camera, params, 2)[..., 0] for s in (by_sky, by_light))
    far = floor_radiance(by_sky, [[6.0, 0.0, 6.0]], environment_light_samples=64)[0, 0]
    assert far == pytest.approx(ALBEDO / np.pi * irradiance * sun[1], rel=0.01)
    assert np.mean(np.abs(sky - lit)) < 0.02 * np.mean(lit)
    core = np.abs(sky - lit) <= 0.03 * np.maximum(lit, 1e-3)  # agreeing pixels: all but the penumbra
    assert core.mean() > 0.9
    umbra = lit < 1e-6
    assert umbra.sum() > 15 and np.median(sky[umbra]) == 0.0 and sky[umbra].mean() < 0.1 * lit.max()


def test_sun_caustic_of_a_glass_ball_brings_the_light_its_shadow_misses():
    """Under a sun-only sky a clear glass ball's shadow is filled by its caustic: the flux on the floor
    within the shadow's reach is the unshadowed flux less the ball's Fresnel reflection (4-10%)."""
    sun = np.array([0.0, 1.0, 0.0])
    env = sun_environment(sun, radius_degrees=2.0)
    scene = floor_scene([SceneObject("ball", ball(), Glass(ior=1.5), Transform(position=[0, 1.5, 0]))], env)
    g = np.linspace(-1.6, 1.6, 81)
    points = np.stack([np.repeat(g, len(g)), np.zeros(len(g) ** 2), np.tile(g, len(g))], axis=1)
    params = ExactParams(caustic_photons=200_000)
    from caustica.techniques.exact import caustic_gather

    gather = caustic_gather(scene, params)
    normal = np.tile(UP, (len(points), 1))
    caustic = gather.irradiance(points, normal, np.zeros(len(points), np.int64))[:, 0]
    direct = floor_radiance(scene, points, environment_bounce=False)[:, 0] / (ALBEDO / np.pi)  # no bounce off the ball
    cell = (g[1] - g[0]) ** 2
    unshadowed = sun_irradiance(env, sun) * (3.2 + cell ** 0.5) ** 2
    ratio = (caustic + direct).sum() * cell / unshadowed
    assert 0.88 < ratio < 0.98, ratio
    assert direct[len(points) // 2] == 0.0 and caustic[len(points) // 2] > 5 * sun_irradiance(env, sun)


def test_environment_caustic_matches_mitsuba():
    """The ball's caustic from a sun-only sky against Mitsuba's path tracer (no lights: ``path`` only),
    summed over the caustic pixels, within 10% (measured: 2.6% under), and over the rest of the floor within 3%."""
    pytest.importorskip("mitsuba", reason="the Mitsuba reference needs the 'reference' extra")
    from caustica.metrics.regions import region_masks
    from caustica.reference.render import render_reference

    sun = np.array([-0.2, 1.0, -0.6])  # behind the ball: its caustic lies between it and the camera
    sun /= np.linalg.norm(sun)
    env = sun_environment(sun, radius_degrees=6.0, radiance=8.0, size=(256, 128))
    scene = floor_scene([SceneObject("ball", ball(), Glass(ior=1.5), Transform(position=[0, 1.2, 0]))], env)
    scene.camera = dataclasses.replace(scene.camera, position=[0.0, 5.0, 4.0], look_at=[-0.3, 0.0, -0.2])
    reference = render_reference(scene, spp=1024, progress=False)
    image = Exact().render(scene, scene.camera, ExactParams(), 2)
    caustic = region_masks(dataclasses.replace(scene, lights=[DirectionalLight(direction=-sun)]))["caustic"]
    assert caustic.sum() > 30
    ratio = image[caustic].sum() / reference[caustic].sum()
    assert ratio == pytest.approx(1.0, abs=0.1), ratio
    rest = region_masks(scene)["rest"] & ~caustic  # the floor outside the caustic, its shadow included
    assert image[rest].sum() / reference[rest].sum() == pytest.approx(1.0, abs=0.03)


def test_no_bright_samples_puts_the_sun_in_the_cosine_rays():
    """environment_light_samples = 0: no bright part, the sun's light comes by the cosine rays: the same
    floor irradiance as the split (both within 3% of the quadrature at 4096 cosine rays and the default 16
    shadow rays; at 64 cosine rays an 8-degree sun is met by about one ray, the noise the split avoids)."""
    sun = np.array([0.3, 0.9, 0.2])
    env = sun_environment(sun, radius_degrees=8.0, radiance=5.0, size=(256, 128))
    scene = floor_scene([], env)
    points = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, -1.0], [-3.0, 0.0, 4.0]])
    expected = ALBEDO / np.pi * sun_irradiance(env, UP)
    assert environment_sampling(scene, ExactParams(environment_light_samples=0)).light.has_bright is False
    assert np.allclose(floor_radiance(scene, points), expected, rtol=0.03)
    assert np.allclose(floor_radiance(scene, points, environment_light_samples=0, environment_samples=4096), expected,
                       rtol=0.03)
