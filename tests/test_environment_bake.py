"""The floor's light map of the environment's light (raytrace/environment_bake.py, auto's environment_bake):
known answers under a constant sky, the sky's caustic under a ball lens, determinism, and the plan's rule."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.raytrace.environment_bake import bake_floor, open_irradiance
from caustica.scene import Camera, Diffuse, Environment, Glass, Scene, SceneObject, Transform
from caustica.scene.environment import uv_to_direction
from caustica.scene.shapes import box, plane, sphere

ALBEDO = 0.8
WHITE = Environment(np.ones((128, 256, 3), np.float32))
SIZE = (96, 72)


def floor_scene(objects=(), environment=WHITE) -> Scene:
    camera = Camera(position=[0.0, 6.0, 5.0], look_at=[0.0, 0.0, 0.0], fov_y=50.0, size=SIZE)
    floor = SceneObject("floor", plane((8.0, 8.0)), Diffuse([ALBEDO] * 3))
    return Scene(camera=camera, objects=[floor, *objects], environment=environment)


def texel_centres(bake) -> np.ndarray:
    """(n, n, 2) x, z of each texel's centre."""
    return bake.texel_centres()[..., [0, 2]]


WALL_HEIGHT, WALL_X, WALL_LENGTH = 2.0, -1.0, 7.6  # a black wall whose face is the plane x = -1


def black_wall() -> SceneObject:
    return SceneObject("wall", box((0.4, WALL_HEIGHT, WALL_LENGTH)), Diffuse([0.0] * 3),
                       Transform(position=[WALL_X - 0.2, WALL_HEIGHT / 2, 0.0]))


def wall_fraction(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The share of a constant sky's irradiance a floor point (x, 0, z) still gets: 1 less the view factor to
    the wall's face, the integral over it of cos_floor cos_wall / (pi r^2) = y a / (pi r^4) (a = x - WALL_X),
    by the midpoint rule on a 200 x 400 grid."""
    y = (np.arange(200) + 0.5) / 200 * WALL_HEIGHT
    s = ((np.arange(400) + 0.5) / 400 - 0.5) * WALL_LENGTH
    cell = (WALL_HEIGHT / 200) * (WALL_LENGTH / 400)
    a = np.asarray(x, np.float64)[..., None, None] - WALL_X
    r2 = a**2 + y[:, None] ** 2 + (s[None, :] - np.asarray(z, np.float64)[..., None, None]) ** 2
    return 1.0 - (y[:, None] * a / (np.pi * r2**2)).sum(axis=(-2, -1)) * cell


def test_open_floor_under_a_constant_sky_has_irradiance_pi():
    """Nothing above the floor: every texel is pi (radiance = albedo), to the texel sum's 0.1 %."""
    scene = floor_scene()
    bake = bake_floor(scene, scene.objects[0], WHITE, size=8, samples=16)
    assert open_irradiance(WHITE.image) == pytest.approx([np.pi] * 3, rel=1e-3)
    assert np.allclose(bake.irradiance, np.pi, rtol=1e-3)


def test_floor_beside_a_wall_gets_the_unoccluded_fraction():
    """A black wall takes its view factor from the sky: each of the 256 cosine rays carries pi / 256 of the
    irradiance and the stratified estimate of the blocked share counts them; the wall's edge crosses about 32
    of the 16 x 16 strata, each off by at most one ray, so per texel the integral to within 6 rays (about
    sqrt(32)), unbiased (the mean error under half a ray) and 0.5 % on average; the texels inside the wall take
    their neighbours' values (no black at its foot)."""
    scene = floor_scene([black_wall()])
    bake = bake_floor(scene, scene.objects[0], WHITE, size=32, samples=256)
    centres = texel_centres(bake)
    x = centres[..., 0] - WALL_X
    near = (x > 0.05) & (np.abs(centres[..., 1]) < 3.0)
    expected = open_irradiance(WHITE.image)[0] * wall_fraction(centres[..., 0][near], centres[..., 1][near])
    got = bake.irradiance[near].mean(axis=-1)
    ray = np.pi / 256
    assert np.abs(got - expected).max() < 6 * ray and abs((got - expected).mean()) < 0.5 * ray
    assert np.abs(got / expected - 1.0).mean() < 0.005
    assert bake.irradiance[x < -0.1].min() > 0.4 * np.pi  # inside the wall: filled from the outside


def test_an_ior_one_ball_leaves_no_shadow_and_an_opaque_one_does():
    """Glass of IOR 1 and no absorption lets every ray through unchanged: the bake is the open floor's (to
    float rounding); the same ball opaque darkens the floor at its foot."""
    ball = sphere(0.8, 5)
    ball.analytic_sphere = (np.zeros(3), 0.8)
    clear = SceneObject("ball", ball, Glass(ior=1.0), Transform(position=[0.0, 0.8, 0.0]))
    scene = floor_scene([clear])
    bake = bake_floor(scene, scene.objects[0], WHITE, size=16, samples=64)
    assert np.allclose(bake.irradiance, open_irradiance(WHITE.image), rtol=1e-5)
    opaque = floor_scene([SceneObject("ball", ball, Diffuse([0.0] * 3), Transform(position=[0.0, 0.8, 0.0]))])
    dark = bake_floor(opaque, opaque.objects[0], WHITE, size=16, samples=64).irradiance
    assert dark[7:9, 7:9].max() < 0.5 * np.pi


def overhead_sky() -> Environment:
    """Radiance 1 everywhere and 40 within 15 degrees of the zenith."""
    h, w = 128, 256
    uu, vv = np.meshgrid((np.arange(w) + 0.5) / w, np.arange(h) / (h - 1))
    up = uv_to_direction(np.stack([uu, vv], -1))[..., 1]
    return Environment(np.repeat(np.where(up > np.cos(np.radians(15.0)), 40.0, 1.0)[..., None], 3, 2).astype("f4"))


def test_a_glass_ball_focuses_the_sky_onto_the_floor():
    """The sky's caustic: a clear ball (IOR 1.5, radius 1) resting on the floor under a bright overhead cap
    focuses it 0.5 below the floor (the ball lens's focus, n R / (2 (n - 1)) from its centre), so the light
    through the ball lands near its foot: there the floor gets more than twice the open floor's irradiance
    (the unoccluded SH, what the raster techniques gave before, is the open floor's everywhere); without the
    ball the floor is open everywhere."""
    sky = overhead_sky()
    ball = sphere(1.0, 6)
    ball.analytic_sphere = (np.zeros(3), 1.0)
    scene = floor_scene([SceneObject("ball", ball, Glass(ior=1.5), Transform(position=[0.0, 1.0, 0.0]))], sky)
    bake = bake_floor(scene, scene.objects[0], sky, size=32, samples=256)
    centres = texel_centres(bake)
    foot = np.linalg.norm(centres, axis=-1) < 0.3
    open_ = open_irradiance(sky.image)
    assert bake.irradiance[foot].mean(axis=0) == pytest.approx(bake.irradiance[foot].mean(), rel=1e-6)  # grey sky
    assert bake.irradiance[foot].mean() > 2.0 * open_.mean()
    empty = floor_scene([], sky)
    assert np.allclose(bake_floor(empty, empty.objects[0], sky, size=8, samples=16).irradiance, open_, rtol=1e-6)


def test_a_bake_is_bit_identical_across_runs():
    scene = floor_scene([black_wall()])
    first = bake_floor(scene, scene.objects[0], WHITE, size=16, samples=32).irradiance
    again = bake_floor(floor_scene([black_wall()]), scene.objects[0], WHITE, size=16, samples=32).irradiance
    assert np.array_equal(first, again)


def test_auto_reads_the_light_map_on_the_floor(renderer):
    """auto plans the light map on a floor with an object on it, under the environment alone (no lobes then),
    and the floor's pixels show it: radiance albedo x the wall's unoccluded fraction beside the black wall
    (within 3 %: the map's bilinear filter over 64 texels across 8), which the old unoccluded SH had at the
    albedo. Lobes named without a map keep the lobes on the floor."""
    from caustica.techniques import get_technique

    scene = floor_scene([black_wall()])
    auto = get_technique("auto")
    planned = auto.for_scene(scene, auto.make_params())[1]
    assert planned.environment_bake > 0 and planned.environment_lobes == 0
    named = auto.for_scene(scene, auto.make_params(environment_lobes=16))[1]
    assert named.environment_bake == 0 and named.environment_lobes == 16
    alone = floor_scene()
    assert auto.for_scene(alone, auto.make_params())[1].environment_bake == 0  # nothing on the floor
    image = renderer.render(scene, "auto")
    origin, direction = (a[:, :, 0] for a in scene.camera.primary_rays())
    hit = origin + (-origin[..., 1] / direction[..., 1])[..., None] * direction
    x = hit[..., 0] - WALL_X
    strip = (x > 0.2) & (x < 2.5) & (np.abs(hit[..., 2]) < 2.5)
    assert strip.sum() > 200
    ratio = image[strip].mean(axis=-1) / (ALBEDO * wall_fraction(hit[..., 0][strip], hit[..., 2][strip]))
    assert np.abs(ratio - 1.0).max() < 0.03


def test_glass_shows_the_floor_lit_by_the_light_map(renderer):
    """Through a clear ball of IOR 1 (impostors, as auto plans glass over a floor; their textures share the map) the floor beside the black
    wall shows the same radiance as seen directly, albedo x the wall's unoccluded share: within 3 % per pixel
    on average 1 % (the impostor texture's resampling); the SH alone gave 27 % more."""
    ball = sphere(0.6, 5)
    ball.analytic_sphere = (np.zeros(3), 0.6)
    scene = floor_scene([black_wall(), SceneObject("ball", ball, Glass(ior=1.0), Transform(position=[0.3, 0.6, 0.0]))])
    # What auto planned before it left such glass out (test_auto: test_invisible_glass_is_left_out...).
    image = renderer.render(scene, "impostors", internal_bounces=0, convex_exits=True, merge_planes=True,
                            environment_bake=64)
    from caustica.raytrace.embree_scene import ray_scene_for

    origin, direction = (a.reshape(-1, 3) for a in scene.camera.primary_rays(1))
    through = (ray_scene_for(scene).intersect(origin, direction).object_index == 2).reshape(image.shape[:2])
    hit = (origin + (-origin[:, 1] / direction[:, 1])[:, None] * direction).reshape(image.shape)
    assert through.sum() > 80
    ratio = image[through].mean(axis=-1) / (ALBEDO * wall_fraction(hit[..., 0][through], hit[..., 2][through]))
    assert np.abs(ratio - 1.0).max() < 0.03 and np.abs(ratio - 1.0).mean() < 0.01


def test_the_map_is_kept_per_scene_state_not_per_camera():
    """light_maps keeps the maps while geometry, materials and environment stay: a camera move gives the same
    maps back (no bake), a new environment or material bakes again."""
    import dataclasses

    from caustica.lighting.bake import light_maps

    def floor_bake(scene, sun_taken, size, samples):
        return light_maps(scene, sun_taken, size, samples)[0]

    scene = floor_scene([black_wall()])
    first = floor_bake(scene, False, 8, samples=16)
    moved = dataclasses.replace(scene, camera=Camera(position=[3.0, 2.0, 1.0], look_at=[0.0, 0.0, 0.0], size=SIZE))
    assert floor_bake(moved, False, 8, samples=16) is first
    dimmer = dataclasses.replace(scene, environment=Environment(np.full((128, 256, 3), 0.5, np.float32)))
    assert np.allclose(floor_bake(dimmer, False, 8, samples=16).irradiance, 0.5 * first.irradiance, rtol=1e-5)
    white_wall = dataclasses.replace(black_wall(), material=Diffuse([1.0] * 3))
    brighter = floor_bake(dataclasses.replace(scene, objects=[scene.objects[0], white_wall]), False, 8, samples=16)
    assert (brighter.irradiance >= first.irradiance).all() and (brighter.irradiance > first.irradiance).any()


def test_a_box_on_a_black_floor_sees_half_the_sky_on_its_sides():
    """The faces of a box-shaped object get light maps too (box_faces: any rotation and scale): on a black floor
    under a constant sky every side texel sees the sky's upper half, irradiance pi / 2, and the top the whole
    sky, pi, to 0.1 % (the bottom, on the floor, is never seen). The floor is 200 wide: a ray from height y less
    than y / 100 radians below the horizon passes its edge and sees the ground, which adds at most
    integral cos(phi) y / 100 dphi = 2 y / 100 to a side texel's irradiance (the mean over the texels below that
    bound, each at most 3 of the 256 rays, pi / 256 each, above pi / 2)."""
    from caustica.raytrace.environment_bake import bake_rectangles, box_faces

    floor = SceneObject("floor", plane((200.0, 200.0)), Diffuse([0.0] * 3))
    block = SceneObject("block", box((0.8, 1.0, 0.5)), Diffuse([0.5] * 3),
                        Transform(position=[0.3, 0.5, -0.2], rotation=[0.0, 30.0, 0.0]))
    scene = Scene(camera=Camera(size=SIZE), objects=[floor, block], environment=WHITE)
    faces = box_faces(block)
    assert box_faces(floor) is None  # a plane is no box
    maps = bake_rectangles(scene, faces, (8, 8), WHITE, samples=256)
    full = open_irradiance(WHITE.image)[0]
    for light_map in maps:
        y = light_map.normal[1]
        if y < -0.5:
            continue
        if y > 0.5:
            assert np.allclose(light_map.irradiance, full, rtol=1e-3)
            continue
        excess = light_map.irradiance.mean(axis=-1) - full / 2
        height = light_map.texel_centres()[..., 1]
        assert excess.min() > -1e-3 and excess.max() < 3 * np.pi / 256 + 1e-3, light_map.normal
        assert excess.mean() < 2 * height.mean() / 100
    # The normals came out of the rotation: the +x face's normal is (cos 30, 0, -sin 30).
    assert np.allclose(maps[1].normal, [np.cos(np.radians(30)), 0.0, -np.sin(np.radians(30))], atol=1e-9)


def test_auto_shades_a_box_face_from_its_light_map(renderer):
    """A box beside the black wall, its face towards the wall 1.5 away: auto's pixels of that face are albedo /
    pi times its light map's bilinear value at the pixel's point (the shading finds the face's map and its
    texel: within 1 %), where the unoccluded SH (with the floor's bounce) is more than 5 % off."""
    from caustica.lighting.bake import light_maps
    from caustica.raytrace.embree_scene import ray_scene_for
    from caustica.raytrace.environment_bake import BAKE_SIZE

    block = SceneObject("block", box((0.8, 1.0, 0.8)), Diffuse([0.6] * 3), Transform(position=[0.9, 0.5, 0.0]))
    scene = floor_scene([black_wall(), block])
    scene.camera = Camera(position=[-0.6, 2.2, 2.2], look_at=[0.5, 0.5, 0.0], fov_y=40.0, size=SIZE)
    image = renderer.render(scene, "auto")
    face = next(m for m in light_maps(scene, False, BAKE_SIZE)[1:] if m.normal[0] < -0.99 and m.origin[0] > 0)
    origin, direction = (a.reshape(-1, 3) for a in scene.camera.primary_rays(1))
    hits = ray_scene_for(scene).intersect(origin, direction)
    st = np.stack([(hits.position - face.origin) @ face.u / (face.u @ face.u),
                   (hits.position - face.origin) @ face.v / (face.v @ face.v)], axis=-1)
    on = (hits.object_index == 2) & (hits.geometric_normal[:, 0] < -0.99) & np.all((st > 0.05) & (st < 0.95), axis=1)
    assert on.sum() > 100
    rows, columns = face.irradiance.shape[:2]
    x = np.clip(st[on, 0] * columns, 0.5, columns - 0.5) - 0.5
    y = np.clip(st[on, 1] * rows, 0.5, rows - 0.5) - 0.5
    x0, y0 = np.minimum(x.astype(int), columns - 2), np.minimum(y.astype(int), rows - 2)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    e = face.irradiance
    bilinear = ((e[y0, x0] * (1 - fx) + e[y0, x0 + 1] * fx) * (1 - fy)
                + (e[y0 + 1, x0] * (1 - fx) + e[y0 + 1, x0 + 1] * fx) * fy)
    expected = 0.6 / np.pi * bilinear.mean(axis=-1)
    got = image.reshape(-1, 3)[on].mean(axis=-1)
    assert np.abs(got / expected - 1.0).max() < 0.01
    unoccluded = renderer.render(scene, "auto", environment_bake=0, environment_lobes=0).reshape(-1, 3)[on]
    assert np.abs(unoccluded.mean(axis=-1) / expected - 1.0).mean() > 0.05


BOUNCE_RADIUS, BOUNCE_HEIGHT, SUN = 0.5, 1.0, 2.0  # a glass ball (IOR 1.5) centred 1.0 over the floor, E0 = 2


def _fresnel(cos_i: np.ndarray, eta: float) -> np.ndarray:
    """Unpolarized Fresnel reflectance from a medium of relative index ``eta`` (n_from / n_to), 1 past TIR."""
    sin_t2 = eta**2 * (1.0 - cos_i**2)
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    rs = ((eta * cos_i - cos_t) / (eta * cos_i + cos_t)) ** 2
    rp = ((eta * cos_t - cos_i) / (eta * cos_t + cos_i)) ** 2
    return np.where(sin_t2 >= 1.0, 1.0, 0.5 * (rs + rp))


def foot_bounce(albedo: float, ior: float = 1.5, steps: int = 20000, bounces: int = 8) -> float:
    """The irradiance at the foot of the ball (on the axis under it) of the floor's own light come back through
    it under the sun straight overhead, in closed form up to a 1-D integral: each ray from the foot at angle a
    off the axis stays in one plane through the axis; it reflects off the ball (Fresnel) or enters and leaves
    after 0..``bounces`` internal reflections (the same angle of incidence at each: a sphere). What leaves
    downwards and lands outside the shadow disc (radius R: the sun is overhead) and within 200 of the axis
    brings albedo / pi E0; E = 2 pi integral of (the weight landing lit) cos a sin a da times that."""
    a = (np.arange(steps) + 0.5) / steps * np.arcsin(BOUNCE_RADIUS / BOUNCE_HEIGHT)
    d = np.stack([np.sin(a), np.cos(a)], axis=1)
    centre = np.array([0.0, BOUNCE_HEIGHT])

    def lit(x, r, w):
        down = r[:, 1] < 0.0
        reach = np.abs(x[:, 0] - x[:, 1] / np.where(down, r[:, 1], -1.0) * r[:, 0])
        return np.where(down & (reach > BOUNCE_RADIUS) & (reach < 200.0), w, 0.0)

    x = (BOUNCE_HEIGHT * np.cos(a) - np.sqrt(BOUNCE_RADIUS**2 - (BOUNCE_HEIGHT * np.sin(a)) ** 2))[:, None] * d
    n = (x - centre) / BOUNCE_RADIUS
    c = -(d * n).sum(axis=1)
    f = _fresnel(c, 1.0 / ior)
    landed = lit(x, d + 2.0 * c[:, None] * n, f)
    inside = d / ior + (c / ior - np.sqrt(1.0 - (1.0 - c**2) / ior**2))[:, None] * n
    weight = 1.0 - f
    for _ in range(bounces):
        x = x - 2.0 * ((x - centre) * inside).sum(axis=1)[:, None] * inside
        n = (x - centre) / BOUNCE_RADIUS
        ci = np.minimum((inside * n).sum(axis=1), 1.0)
        fi = _fresnel(ci, ior)
        out = ior * inside + (np.sqrt(np.maximum(1.0 - ior**2 * (1.0 - ci**2), 0.0)) - ior * ci)[:, None] * n
        landed += lit(x, out, weight * (1.0 - fi))
        inside = inside - 2.0 * ci[:, None] * n
        weight = weight * fi
    return float(albedo * SUN * 2.0 * np.sum(landed * np.cos(a) * np.sin(a)) * (a[1] - a[0]))


def bounce_scene(albedo: float = ALBEDO, lights: bool = True, glass: bool = True) -> Scene:
    """The ball over a 400-wide floor (nothing is lost past its edge) under the sun overhead, black environment."""
    from caustica.scene import DirectionalLight
    from caustica.scene.environment import procedural_environment

    ball = sphere(BOUNCE_RADIUS, 6)
    ball.analytic_sphere = (np.zeros(3), BOUNCE_RADIUS)
    caster = SceneObject("ball", ball, Glass(ior=1.5) if glass else Diffuse([0.5] * 3),
                         Transform(position=[0.0, BOUNCE_HEIGHT, 0.0]))
    floor = SceneObject("floor", plane((400.0, 400.0)), Diffuse([albedo] * 3))
    camera = Camera(position=[0.0, 3.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=50.0, size=SIZE)
    return Scene(camera=camera, objects=[floor, caster], environment=procedural_environment("black"),
                 lights=[DirectionalLight([0.0, -1.0, 0.0], [SUN] * 3)] if lights else [])


def test_the_floors_light_comes_back_through_glass_in_a_black_environment():
    """In a black environment the light map holds the floor's own light bounced back through the glass (one
    bounce of exact's rays): at the ball's foot (one texel 0.02 wide, 4096 rays) the closed form's
    0.0371 = 1.9 % of the open floor's E0 (the ball's view factor from there is (R/h)^2 = 1/4), to 3 % (the
    rays past the 200 of the closed form that the square floor still catches); with the floor's albedo halved,
    exactly half (to float rounding, 1e-5: the floor's albedo enters once, where the bounced ray lands)."""
    from caustica.raytrace.environment_bake import bake_rectangles

    def at_foot(scene) -> float:
        half = 0.01
        texel = (np.array([-half, 0.0, -half]), np.array([2 * half, 0.0, 0.0]), np.array([0.0, 0.0, 2 * half]),
                 np.array([0.0, 1.0, 0.0]))
        found = bake_rectangles(scene, [texel], (1, 1), scene.environment, samples=4096)[0].irradiance
        assert np.allclose(found, found[..., :1], rtol=1e-6)  # grey
        return float(found.mean())

    expected = foot_bounce(ALBEDO)
    assert 0.01 * SUN < expected < ALBEDO * SUN * (BOUNCE_RADIUS / BOUNCE_HEIGHT) ** 2
    assert at_foot(bounce_scene()) == pytest.approx(expected, rel=0.03)
    assert at_foot(bounce_scene(ALBEDO / 2)) == pytest.approx(at_foot(bounce_scene()) / 2, rel=1e-5)


def test_auto_bakes_the_bounce_only_under_a_light_through_glass():
    """auto plans the light maps in a black environment where a light shines through glass onto the floor, and
    not without the light (nothing to bounce) or without the glass (the rule is for the light the glass sends
    back; an opaque ball's diffuse bounce under a light keeps the frame it had)."""
    from caustica.techniques import get_technique

    auto = get_technique("auto")
    planned = lambda scene: auto.for_scene(scene, auto.make_params())[1]  # noqa: E731
    assert planned(bounce_scene())[0].environment_bake > 0
    assert planned(bounce_scene(lights=False)).environment_bake == 0
    assert planned(bounce_scene(glass=False)).environment_bake == 0


def test_less_open_gathers_trace_only_the_blocked_rays_and_give_what_tracing_all_gives():
    """cosine_gather's control variate (each ray less the open sky along it) traces only the rays something
    blocks: the rest bring exactly 0. Over a glass ball and a box under the sky-checker, with the bounce, it
    equals tracing every ray and subtracting the open sky ray by ray; a texel nothing shadows is exactly 0."""
    from caustica.raytrace.embree_scene import ray_scene_for
    from caustica.raytrace.environment_light import EnvironmentLight, cosine_directions
    from caustica.raytrace.paths import EnvironmentSampling, Materials, cosine_gather
    from caustica.scene.environment import sky_checker

    sky = Environment(sky_checker(128, 64))
    ball = SceneObject("ball", sphere(0.8), Glass(1.5), Transform(position=[0.0, 1.0, 0.0]))
    block = SceneObject("block", box((0.6, 0.6, 0.6)), Diffuse([0.7, 0.2, 0.2]), Transform(position=[1.2, 0.3, 0.0]))
    scene = floor_scene([ball, block], sky)
    rays, materials = ray_scene_for(scene), Materials.of(scene)
    x, z = np.meshgrid(np.linspace(-3.5, 3.5, 12), np.linspace(-3.5, 3.5, 12))
    points = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], axis=1)
    normal = np.tile([0.0, 1.0, 0.0], (len(points), 1))
    sampling = EnvironmentSampling(EnvironmentLight(sky, bright=0.0), 64, 0, True)
    less_open = cosine_gather(rays, scene, points, normal, normal, sampling, materials, materials.ior_rgb[:, 0],
                              less_open=True)
    every_ray = cosine_gather(rays, scene, points, normal, normal, sampling, materials, materials.ior_rgb[:, 0])
    directions = cosine_directions(points, normal, 64)
    open_sky = sampling.light.rest.lookup(directions.reshape(-1, 3)).reshape(len(points), 64, 3).mean(axis=1)
    assert np.allclose(less_open, every_ray - open_sky, rtol=0.0, atol=1e-6)
    corner = np.argmin(np.linalg.norm(points - [-3.5, 0.0, -3.5], axis=1))
    assert np.all(less_open[corner] == 0.0)
    assert np.abs(less_open).max() > 0.05  # the ball's and the box's shadows and the sky's caustic are there
