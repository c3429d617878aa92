"""The environment's light in the raster techniques (issue 23 parts 2, 3; passes/shading/environment.py).

Known answers: the environment's sun (a small bright disc) lights and shadows a floor as the directional
light of the same irradiance does; an IOR-1 ball under the sun casts no shadow (its caustic gives the light
back); far from objects a floor under a constant environment has radiance = albedo (irradiance pi), with a
sun added pi + the sun's irradiance times its cosine; the sun is no light of scene.lights.
"""
from __future__ import annotations

import numpy as np
import pytest

from caustica.lighting.environment import environment_sun
from caustica.metrics.images import psnr_linear
from caustica.scene import Camera, Diffuse, DirectionalLight, Environment, Glass, Scene, SceneObject, Transform
from caustica.scene.environment import uv_to_direction
from caustica.scene.shapes import box, plane, sphere

SIZE = (96, 96)
SUN = np.array([0.35, 0.8, -0.3]) / np.linalg.norm([0.35, 0.8, -0.3])  # towards the sun
SUN_RADIUS, SUN_RIM, SUN_RADIANCE = 4.0, 1.0, 150.0  # degrees (disc radius, width of its linear rim), W/m^2/sr
ALBEDO = 0.8


def sun_image(background: float = 0.0, width: int = 512) -> np.ndarray:
    """An equirectangular image of ``background`` radiance with the sun's disc (a linear rim of SUN_RIM), its
    texels at the directions the lookup (Mitsuba's) gives them: u = (x + 1/2) / W, v = y / (H - 1)."""
    h = width // 2
    uu, vv = np.meshgrid((np.arange(width) + 0.5) / width, np.arange(h) / (h - 1))
    angle = np.degrees(np.arccos(np.clip(uv_to_direction(np.stack([uu, vv], -1)) @ SUN, -1.0, 1.0)))
    disc = np.clip((SUN_RADIUS - angle) / SUN_RIM + 0.5, 0.0, 1.0)
    return np.repeat((background + SUN_RADIANCE * disc)[..., None], 3, axis=2).astype(np.float32)


def sun_irradiance() -> float:
    """The disc's radiance integrated over solid angle (1-D quadrature over the angle from its centre)."""
    theta = np.radians(np.linspace(0.0, SUN_RADIUS + SUN_RIM, 20001))
    profile = np.clip((SUN_RADIUS - np.degrees(theta)) / SUN_RIM + 0.5, 0.0, 1.0)
    return float(np.trapezoid(SUN_RADIANCE * profile * 2.0 * np.pi * np.sin(theta), theta))


def floor_scene(objects=(), environment=None, lights=()) -> Scene:
    camera = Camera(position=[0.0, 5.0, 3.5], look_at=[0.0, 0.0, -0.3], fov_y=50.0, size=SIZE)
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse([ALBEDO] * 3))
    return Scene(camera=camera, objects=[floor, *objects], lights=list(lights),
                 environment=environment or Environment(sun_image()))


def red_box() -> SceneObject:
    return SceneObject("box", box((0.6, 0.8, 0.6)), Diffuse([0.7, 0.15, 0.1]), Transform(position=[0.0, 0.4, 0.0]))


def floor_hits(camera: Camera) -> np.ndarray:
    """Per pixel: where the primary ray meets the floor (y = 0)."""
    origin, direction = (a[:, :, 0] for a in camera.primary_rays())
    return origin + (-origin[..., 1] / direction[..., 1])[..., None] * direction


def test_sun_is_extracted_with_its_irradiance_and_direction():
    sun = environment_sun(Environment(sun_image())).light
    assert sun is not None
    assert np.degrees(np.arccos(-sun.direction @ SUN)) < 0.2
    assert sun.intensity == pytest.approx([sun_irradiance()] * 3, rel=0.01)
    assert environment_sun(Environment(np.ones((64, 128, 3), np.float32))).light is None  # no bright part


def test_sun_only_environment_is_the_equivalent_directional_light(renderer):
    """The same image and shadow as a black environment with DirectionalLight(-SUN, sun_irradiance)."""
    sun_scene = floor_scene([red_box()])
    light_scene = floor_scene([red_box()], Environment(sun_image(0.0) * 0.0),
                              [DirectionalLight(direction=-SUN, intensity=[sun_irradiance()] * 3)])
    a, b = renderer.render(sun_scene, "env-map"), renderer.render(light_scene, "env-map")
    assert not sun_scene.lights  # derived per frame, never the user's
    assert psnr_linear(a, b) > 35.0
    # The shadow (grey floor darker than half the lit floor) lies where the light's does.
    hit = floor_hits(sun_scene.camera)
    on_floor = np.abs(hit).max(axis=-1) < 3.0
    lit = ALBEDO / np.pi * sun_irradiance() * SUN[1]
    shadows = [on_floor & (image.mean(axis=-1) < 0.5 * lit) & (np.abs(image[..., 0] - image[..., 1]) < 0.05 * lit)
               for image in (a, b)]
    assert shadows[1].sum() > 100
    assert (shadows[0] & shadows[1]).sum() / (shadows[0] | shadows[1]).sum() > 0.9
    # And it is a shadow where the geometry says: the floor whose ray to the sun meets the box's middle.
    middle = hit + (0.4 / SUN[1]) * SUN
    beneath = on_floor & np.all(np.abs(middle[..., [0, 2]]) < 0.2, axis=-1)
    assert beneath.sum() > 20 and a[beneath].mean() < 0.05 * lit


def test_ior1_ball_casts_no_shadow(renderer):
    """Under the sun (with caustics, as auto plans them for glass) a ball of IOR 1 gives back all the light it
    blocks."""
    ball = SceneObject("ball", sphere(0.5, 4), Glass(ior=1.0), Transform(position=[0.0, 1.0, 0.0]))
    with_ball, without = floor_scene([ball]), floor_scene()
    # What auto planned before it left such glass out (test_auto: test_invisible_glass_is_left_out...).
    image = renderer.render(with_ball, "impostors+caustic-mapping", internal_bounces=0, convex_exits=True,
                            environment_bake=64, **{"caustic-mapping.map_size": 256})
    empty = renderer.render(without, "env-map")
    hit = floor_hits(with_ball.camera)
    shadow = (np.linalg.norm((hit + SUN / SUN[1])[..., [0, 2]], axis=-1) < 0.35) & (np.abs(hit).max(axis=-1) < 3.0)
    # Floor pixels the ball does not cover on screen (seen past it, through it would be the refraction).
    origin, direction = (x[:, :, 0] for x in with_ball.camera.primary_rays())
    to_centre = np.array([0.0, 1.0, 0.0]) - origin
    along = (to_centre * direction).sum(-1)
    miss = np.linalg.norm(to_centre - along[..., None] * direction, axis=-1) > 0.55
    region = shadow & miss
    assert region.sum() > 30
    ratio = image[region].mean() / empty[region].mean()
    assert ratio == pytest.approx(1.0, abs=0.08), ratio


@pytest.mark.parametrize("with_sun", [False, True], ids=["constant", "constant+sun"])
def test_floor_far_from_objects_under_constant_environment(renderer, with_sun):
    """Radiance = albedo / pi * (pi * 1 + E_sun cos) on the floor away from the box and its shadow."""
    environment = Environment(sun_image(1.0) if with_sun else np.ones((256, 512, 3), np.float32))
    scene = floor_scene([red_box()], environment)
    image = renderer.render(scene, "env-map")
    hit = floor_hits(scene.camera)
    far = (np.abs(hit).max(axis=-1) < 3.0) & (np.linalg.norm(hit[..., [0, 2]], axis=-1) > 2.0)
    far &= np.linalg.norm((hit + (0.8 / SUN[1]) * SUN)[..., [0, 2]], axis=-1) > 1.2  # off the box's sun shadow
    assert far.sum() > 500
    sun = sun_irradiance() * SUN[1] if with_sun else 0.0
    expected = ALBEDO / np.pi * (np.pi + sun)
    assert image[far].mean(axis=0) == pytest.approx([expected] * 3, rel=0.01)
    assert np.abs(image[far] / expected - 1.0).max() < 0.03


# ---- part 2: the environment's lobes (auto's environment_lobes) -------------------------------------


def test_lobes_leave_the_open_floor_at_albedo(renderer):
    """Far from objects nothing blocks a lobe: the floor keeps radiance = albedo under a constant environment."""
    scene = floor_scene([red_box()], Environment(np.ones((128, 256, 3), np.float32)))
    image = renderer.render(scene, "auto", environment_lobes=16)
    hit = floor_hits(scene.camera)
    far = (np.abs(hit).max(axis=-1) < 3.0) & (np.linalg.norm(hit[..., [0, 2]], axis=-1) > 2.0)
    assert far.sum() > 500
    assert image[far].mean(axis=0) == pytest.approx([ALBEDO] * 3, rel=0.01)
    near = (np.abs(hit).max(axis=-1) < 3.0) & (np.abs(hit[..., 0]) < 0.45) & (hit[..., 2] > 0.3) & (hit[..., 2] < 0.4)
    assert near.sum() > 3 and image[near].mean() < 0.85 * ALBEDO  # beside the box: part of the sky is the box's
    assert image[near].mean() < renderer.render(scene, "auto", environment_lobes=0)[near].mean() - 0.1


def test_lobes_shadow_the_floor_under_a_slab(renderer):
    """Under a 3 x 3 slab 0.3 above the floor, the constant sky reaches the centre only below 11 degrees of
    elevation: E = pi sin^2(11 deg), radiance 0.8 * 0.037; unoccluded SH gave the albedo, 0.8."""
    slab = SceneObject("slab", box((3.0, 0.05, 3.0)), Diffuse([0.5] * 3), Transform(position=[0.0, 0.325, 0.0]))
    scene = floor_scene([slab], Environment(np.ones((128, 256, 3), np.float32)))
    scene.camera = Camera(position=[0.0, 0.15, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    image = renderer.render(scene, "auto", environment_lobes=16)
    hit = floor_hits(scene.camera)
    centre = np.abs(hit[..., [0, 2]]).max(axis=-1) < 0.5
    assert centre.sum() > 20
    assert image[centre].mean() < 0.15 * ALBEDO


# ---- glass in the lobes' maps: its transmittance, not an opaque shadow ---------------------------------

SLAB_HEIGHT, SLAB_HALF, SLAB_THICKNESS = 0.2, 3.5, 0.05  # a 7 x 7 glass slab's underside 0.2 above the floor


def fresnel(cos_i: np.ndarray, ior: float) -> np.ndarray:
    """Unpolarised Fresnel reflectance entering glass of ``ior`` from air."""
    cos_t = np.sqrt(1.0 - (1.0 - cos_i**2) / ior**2)
    rs = (cos_i - ior * cos_t) / (cos_i + ior * cos_t)
    rp = (ior * cos_i - cos_t) / (ior * cos_i + cos_t)
    return 0.5 * (rs**2 + rp**2)


def under_slab(transmittance) -> float:
    """Irradiance / pi at the floor under the slab's centre from a constant sky of radiance 1, where the sky
    seen through the slab comes through as transmittance(cos theta) (closed form: quadrature over the
    hemisphere of the slab's square footprint)."""
    theta, phi = np.meshgrid(np.linspace(0.0, np.pi / 2 - 1e-6, 2001), np.linspace(0.0, 2 * np.pi, 721),
                             indexing="ij")
    reach = SLAB_HEIGHT * np.tan(theta)
    covered = (np.abs(reach * np.cos(phi)) < SLAB_HALF) & (np.abs(reach * np.sin(phi)) < SLAB_HALF)
    through = np.where(covered, transmittance(np.cos(theta)), 1.0)
    weight = np.cos(theta) * np.sin(theta) / np.pi
    return float(np.trapezoid(np.trapezoid(through * weight, phi[0], axis=1), theta[:, 0]))


def glass_slab_floor(renderer, material, environment=None) -> np.ndarray:
    """auto with the lobes: the mean radiance / albedo of the floor under the slab's centre, seen from
    between the slab and the floor."""
    slab = SceneObject("slab", box((2 * SLAB_HALF, SLAB_THICKNESS, 2 * SLAB_HALF)), material,
                       Transform(position=[0.0, SLAB_HEIGHT + SLAB_THICKNESS / 2, 0.0]))
    scene = floor_scene([slab], environment or Environment(np.ones((128, 256, 3), np.float32)))
    scene.camera = Camera(position=[0.0, 0.1, 3.9], look_at=[0.0, 0.0, 0.0], fov_y=30.0, size=SIZE)
    image = renderer.render(scene, "auto", environment_lobes=16)
    hit = floor_hits(scene.camera)
    centre = np.abs(hit[..., [0, 2]]).max(axis=-1) < 0.5
    assert centre.sum() > 50
    return image[centre].mean(axis=0) / ALBEDO


@pytest.mark.parametrize("ior", [1.5, 2.0])
def test_clear_glass_slab_passes_the_sky_by_its_fresnel_transmittance(renderer, ior):
    """Under a constant sky, the floor beneath a clear slab gets the sky through two interfaces: radiance /
    albedo = the hemisphere's mean of (1 - F(theta))^2 over the slab's footprint (0.838 for IOR 1.5, 0.716 for
    2), not 1 (glass left out) and not 0.003 (an opaque slab)."""
    got = glass_slab_floor(renderer, Glass(ior=ior))
    expected = under_slab(lambda c: (1.0 - fresnel(c, ior)) ** 2)
    assert got == pytest.approx([expected] * 3, rel=0.015)


def test_absorbing_glass_slab_tints_the_floor_by_beer_lambert(renderer):
    """A coloured slab (transmittance 0.9 / 0.5 / 0.2 per channel through its thickness) adds Beer-Lambert
    absorption along the straight chord through it, SLAB_THICKNESS / cos theta, per channel (the model;
    exp(-sigma d) at normal incidence; docs/environment-light.md measures it against the refracted path).
    Measured 0.717 / 0.313 / 0.096 against 0.708 / 0.301 / 0.092: the 16 lobes' mean directions sample the
    steep 1 / cos of the lowest band coarsely."""
    colour = np.array([0.9, 0.5, 0.2])
    got = glass_slab_floor(renderer, Glass(ior=1.5, absorption_color=colour, absorption_distance=SLAB_THICKNESS))
    for channel, transmitted in enumerate(colour):
        expected = under_slab(lambda c: (1.0 - fresnel(c, 1.5)) ** 2 * transmitted ** (1.0 / c))
        assert got[channel] == pytest.approx(expected, rel=0.05), channel  # 16 lobes' quadrature of 1 / cos
    assert got[0] > 2.0 * got[1] > 4.0 * got[2]  # tinted: red passes, blue is stopped


def test_ior1_glass_casts_no_sky_shadow(renderer):
    """A ball of IOR 1 without absorption transmits the whole sky: the floor beside its foot keeps the albedo
    (an opaque ball of the same size darkens it below 0.9)."""
    constant = Environment(np.ones((128, 256, 3), np.float32))
    images = {}
    for name, material in (("glass", Glass(ior=1.0)), ("opaque", Diffuse([0.5] * 3))):
        ball = SceneObject("ball", sphere(0.5, 4), material, Transform(position=[0.0, 0.5, 0.0]))
        scene = floor_scene([ball], constant)
        # drop_invisible_glass=False: the lobes' glass path, not auto's leaving such glass out.
        images[name] = renderer.render(scene, "auto", environment_lobes=16, drop_invisible_glass=False)
    hit = floor_hits(scene.camera)
    origin, direction = (x[:, :, 0] for x in scene.camera.primary_rays())
    to_centre = np.array([0.0, 0.5, 0.0]) - origin
    along = (to_centre * direction).sum(-1)
    miss = np.linalg.norm(to_centre - along[..., None] * direction, axis=-1) > 0.55
    foot = miss & (np.linalg.norm(hit[..., [0, 2]], axis=-1) < 0.8) & (np.abs(hit).max(axis=-1) < 3.0)
    assert foot.sum() > 30
    assert images["opaque"][foot].mean() < 0.9 * ALBEDO
    assert images["glass"][foot].mean(axis=0) == pytest.approx([ALBEDO] * 3, rel=0.005)


def test_glass_that_transmits_everything_leaves_opaque_shadows_bit_identical(renderer):
    """The glass path (ENVIRONMENT_GLASS) multiplies each lit tap by exp(-0) = 1: an IOR-1 ball hidden inside
    the opaque box leaves every floor pixel as the box alone gives it, bit for bit."""
    constant = Environment(np.ones((128, 256, 3), np.float32))
    hidden = SceneObject("hidden", sphere(0.2, 3), Glass(ior=1.0), Transform(position=[0.0, 0.4, 0.0]))
    alone, with_glass = floor_scene([red_box()], constant), floor_scene([red_box(), hidden], constant)
    a = renderer.render(alone, "auto", environment_lobes=16)
    b = renderer.render(with_glass, "auto", environment_lobes=16, drop_invisible_glass=False)  # the glass path
    hit = floor_hits(alone.camera)
    floor = (np.abs(hit).max(axis=-1) < 3.0) & ~np.all(np.abs(hit[..., [0, 2]]) < 0.35, axis=-1)
    assert (a[floor] < 0.95 * ALBEDO).sum() > 20  # the box's sky shadow is in the region
    np.testing.assert_array_equal(a[floor], b[floor])


def test_floor_bounce_lights_the_box_sides_from_below(renderer):
    """With the lobes, what a diffuse surface sees below the horizon is the floor lit by the sky: under a
    constant sky of radiance 1 a box side facing +z sees half sky (1) and half floor (radiance ALBEDO), so
    its radiance is its albedo times (1 + ALBEDO) / 2 (the SH of a step in y is exact to band 2), where the
    environment's own ground gave the albedo (test_lobes_leave_the_open_floor_at_albedo: the floor's stays)."""
    grey = SceneObject("box", box((0.6, 2.0, 0.6)), Diffuse([0.5] * 3), Transform(position=[0.0, 1.0, 0.0]))
    scene = floor_scene([grey], Environment(np.ones((128, 256, 3), np.float32)))
    scene.camera = Camera(position=[0.0, 1.6, 4.0], look_at=[0.0, 1.2, 0.0], fov_y=40.0, size=SIZE)
    image = renderer.render(scene, "auto", environment_lobes=16)
    origin, direction = (a[:, :, 0] for a in scene.camera.primary_rays())
    hit = origin + ((0.3 - origin[..., 2]) / direction[..., 2])[..., None] * direction  # the plane z = 0.3
    upper = (np.abs(hit[..., 0]) < 0.25) & (hit[..., 1] > 1.3) & (hit[..., 1] < 1.9)  # far above the floor's shadow
    assert upper.sum() > 30
    assert image[upper].mean(axis=0) == pytest.approx([0.5 * (1.0 + ALBEDO) / 2.0] * 3, rel=0.02)
    before = renderer.render(scene, "auto", environment_lobes=0)  # unoccluded SH of the environment's ground
    assert before[upper].mean(axis=0) == pytest.approx([0.5] * 3, rel=0.02)


def test_scene_floor_is_the_flat_diffuse_object_under_the_rest():
    from caustica.lighting.environment import scene_floor

    scene = floor_scene([red_box()])
    assert scene_floor(scene) is scene.objects[0]
    shelf = SceneObject("shelf", plane((8.0, 8.0)), Diffuse([0.5] * 3), Transform(position=[0.0, 0.5, 0.0]))
    assert scene_floor(Scene(camera=scene.camera, objects=[shelf, red_box()])) is None  # the box reaches below it
    small = SceneObject("mat", plane((0.3, 0.3)), Diffuse([0.5] * 3))
    assert scene_floor(Scene(camera=scene.camera, objects=[small, red_box()])) is None  # covers less than the box
    assert scene_floor(Scene(camera=scene.camera, objects=[red_box()])) is None


def test_blocked_sky_shows_the_occluders_bounce(renderer):
    """Where a lobe's sky is blocked, the receiver sees the occluder lit instead: under a constant sky a
    white wall (albedo 0.8, lit by the sky above its horizon: radiance 0.4) adds to the floor at distance x
    from its foot ALBEDO * F * 0.4, F = (1 - x / sqrt(x^2 + H^2)) / 2 the form factor of a wide wall of height
    H, over what a black wall leaves (which only blocks). Measured 0.160 against 0.155 (the lobes' strata
    are either side of the wall whole)."""
    constant = Environment(np.ones((128, 256, 3), np.float32))
    height = 20.0  # tall: the 16 lobes' top band, 50 to 90 degrees, lies wholly behind it
    images = {}
    for albedo in (0.0, 0.8):
        wall = SceneObject("wall", box((16.0, height, 0.2)), Diffuse([albedo] * 3),
                           Transform(position=[0.0, height / 2, -0.1]))
        floor = SceneObject("floor", plane((20.0, 20.0)), Diffuse([ALBEDO] * 3))
        camera = Camera(position=[0.0, 2.5, 3.0], look_at=[0.0, 0.0, 0.6], fov_y=40.0, size=SIZE)
        scene = Scene(camera=camera, objects=[floor, wall], environment=constant)
        images[albedo] = renderer.render(scene, "auto", environment_lobes=16)
    hit = floor_hits(scene.camera)
    strip = (np.abs(hit[..., 0]) < 1.5) & (hit[..., 2] > 0.3) & (hit[..., 2] < 0.9)
    assert strip.sum() > 100
    x = hit[..., 2][strip]
    expected = ALBEDO * 0.5 * (1.0 - x / np.sqrt(x**2 + height**2)) * 0.4
    added = (images[0.8] - images[0.0])[strip].mean(axis=-1)
    assert added.mean() == pytest.approx(expected.mean(), rel=0.06)
    assert images[0.0][strip].mean() < 0.6 * ALBEDO  # the wall blocks about half the sky


def test_lobes_given_by_name_shade_a_lit_scene_too(renderer):
    """With a light of its own auto leaves the lobes off by default, but ``environment_lobes`` given by name is
    honoured: under the slab of the test above, shadowed from a point light right over it, the constant sky
    reaches the centre only below 11 degrees (radiance 0.8 * 0.037, the light adding nothing there) with the
    lobes, and unoccluded (the albedo, 0.8) without. The floor's light map (auto's environment_bake, which it
    plans here by default: tests/test_environment_bake.py) is named off, so the lobes' rule alone decides."""
    from caustica.scene import PointLight

    slab = SceneObject("slab", box((3.0, 0.05, 3.0)), Diffuse([0.5] * 3), Transform(position=[0.0, 0.325, 0.0]))
    light = PointLight(position=[0.0, 3.0, 0.0], intensity=[5.0] * 3)
    scene = floor_scene([slab], Environment(np.ones((128, 256, 3), np.float32)), lights=[light])
    scene.camera = Camera(position=[0.0, 0.15, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    hit = floor_hits(scene.camera)
    centre = np.abs(hit[..., [0, 2]]).max(axis=-1) < 0.5
    assert centre.sum() > 20
    default = renderer.render(scene, "auto", environment_bake=0)
    assert default[centre].mean() == pytest.approx(ALBEDO, rel=0.05)
    assert renderer.render(scene, "auto", environment_lobes=0)[centre].mean() == pytest.approx(ALBEDO, rel=0.05)
    assert renderer.render(scene, "auto", environment_lobes=16)[centre].mean() < 0.15 * ALBEDO
