"""Real-time shading of opaque glTF metallic-roughness surfaces (Principled drawn "diffuse"): glTF's BRDF per
light, the split-sum environment with energy compensation, normal maps, and a Diffuse-equivalent Principled
drawn as its Diffuse. Closed-form checks on 64x64 frames."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.passes.shading.prefiltered import PREFILTER_LEVELS, prefiltered_environment
from caustica.scene.microfacet import alpha_of, layer_weights, reflect, sample_visible_normal, specular_brdf
from caustica.scene import Camera, Diffuse, DirectionalLight, PointLight, Scene, SceneObject, Transform
from caustica.scene import procedural_environment
from caustica.scene.environment import Environment
from caustica.scene.materials import Principled
from caustica.scene.shapes import plane, sphere

SIZE = (64, 64)


def scene_of(objects, camera, lights, environment="black") -> Scene:
    return Scene(camera=camera, objects=objects, lights=lights, environment=procedural_environment(environment))


def hit_on_floor(camera: Camera, pixel: tuple[int, int]) -> np.ndarray:
    """Where the ray through pixel (column, row)'s centre meets the plane y = 0."""
    origin, direction = (a[pixel[1], pixel[0], 0] for a in camera.primary_rays())
    return origin - origin[1] / direction[1] * direction


def pixel_of(camera: Camera, point) -> np.ndarray:
    """The (column, row) image position of a world point (row 0 at the top)."""
    clip = camera.clip_from_world() @ np.append(np.asarray(point, np.float64), 1.0)
    ndc = clip[:2] / clip[3]
    return np.array([(ndc[0] + 1.0) * 0.5 * camera.size[0], (1.0 - ndc[1]) * 0.5 * camera.size[1]])


@pytest.mark.parametrize("roughness", [0.1, 0.25, 0.5, 0.75, 1.0])
def test_white_furnace_rough_metal_ball_disappears(renderer, roughness):
    """A white metal ball (base colour 1, metallic 1) in a uniform white environment reflects it all: with
    Fdez-Aguera's compensation the split sum's weight (A + B)(1 + (1 / (A + B) - 1)) is 1 whatever the
    roughness (the compensation's error is nil for F0 = 1; float rounding aside) and the prefiltered
    environment of a uniform one is uniform. Uncompensated, roughness 1 would lose about a third."""
    camera = Camera(position=[0.0, 0.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=SIZE)
    ball = SceneObject("ball", sphere(0.8), Principled(base_color=[1.0] * 3, metallic=1.0, roughness=roughness))
    image = renderer.render(scene_of([ball], camera, [], "white"), "plain")
    white = procedural_environment("white").image.mean()
    assert np.abs(image - white).max() < 1e-3 * white


def test_normal_map_of_a_constant_tilt_equals_the_tilted_plane(renderer):
    """A flat plane whose constant normal map tilts its normal 30 degrees towards +X (the tangent, along +u)
    shades as the plane rotated by those 30 degrees, under a directional light and the sky: direct light,
    ambient and the glossy environment all follow the shading normal. A distant narrow camera sees one
    direction, so each plane is shaded uniformly; their middles are compared."""
    tilt = np.radians(30.0)
    camera = Camera(position=[0.0, 20.0, 6.0], look_at=[0.0, 0.0, 0.0], fov_y=4.0, size=SIZE)
    light = DirectionalLight(direction=[0.6, -1.0, 0.0], intensity=[3.0] * 3)
    encoded = np.array([np.sin(tilt), 0.0, np.cos(tilt)]) * 0.5 + 0.5
    normal_map = np.broadcast_to(encoded, (4, 4, 3)).astype(np.float32).copy()
    material = dict(base_color=[0.6, 0.5, 0.4], roughness=0.6)
    mapped = SceneObject("floor", plane((3.0, 3.0)), Principled(**material, normal_texture=normal_map))
    tilted = SceneObject("floor", plane((3.0, 3.0)), Principled(**material),
                         Transform(rotation=[0.0, 0.0, -30.0]))
    flat = SceneObject("floor", plane((3.0, 3.0)), Principled(**material))
    middle = (slice(24, 40), slice(24, 40))
    shade = {name: renderer.render(scene_of([obj], camera, [light], "sky-checker"), "plain")[middle].mean(axis=(0, 1))
             for name, obj in (("mapped", mapped), ("tilted", tilted), ("flat", flat))}
    np.testing.assert_allclose(shade["mapped"], shade["tilted"], rtol=0.01)
    assert np.abs(shade["flat"] - shade["tilted"]).max() > 0.1 * shade["tilted"].max()  # the tilt shows


def test_glossy_plastic_floor_highlight_sits_at_the_mirror_point(renderer):
    """A glossy plastic floor (roughness 0.2) under a point light: its brightest pixel lies within two
    pixels of where the light's mirror image through the floor meets the eye's ray."""
    camera = Camera(position=[0.0, 2.0, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=50.0, size=SIZE)
    light_position = np.array([0.8, 1.5, -1.0])
    floor = SceneObject("floor", plane((8.0, 8.0)), Principled(base_color=[0.2] * 3, roughness=0.2))
    image = renderer.render(scene_of([floor], camera, [PointLight(light_position, [5.0] * 3)]), "plain")
    mirror = light_position * np.array([1.0, -1.0, 1.0])
    eye = camera.position
    spot = eye + (mirror - eye) * (eye[1] / (eye[1] - mirror[1]))
    row, column = np.unravel_index(np.argmax(image.sum(axis=2)), image.shape[:2])
    expected = pixel_of(camera, spot) - 0.5  # pixel centres at integers
    assert np.hypot(column - expected[0], row - expected[1]) <= 2.0
    # Drawn as a Diffuse of its base colour instead, the brightest pixel is elsewhere (below the light).
    matte = SceneObject("floor", plane((8.0, 8.0)), Diffuse([0.2] * 3))
    diffuse = renderer.render(scene_of([matte], camera, [PointLight(light_position, [5.0] * 3)]), "plain")
    assert image.max() > 3.0 * diffuse.max()


@pytest.mark.parametrize("technique", ["plain", "auto"])
def test_principled_without_lobe_is_bit_identical_to_diffuse(renderer, technique):
    """metallic 0 and specular 0 (glossy False): the same pixels as Diffuse(color, texture), textured or not."""
    camera = Camera(position=[0.0, 2.0, 4.0], look_at=[0.0, 0.3, 0.0], fov_y=45.0, size=SIZE)
    light = PointLight([1.0, 3.0, 1.0], [20.0] * 3)
    texture = np.random.default_rng(5).uniform(0.1, 0.9, (8, 8, 3)).astype(np.float32)

    def render(make):
        objects = [SceneObject("floor", plane((4.0, 4.0)), make([0.7, 0.6, 0.5], texture)),
                   SceneObject("ball", sphere(0.4), make([0.3, 0.5, 0.8], None), Transform(position=[0.0, 0.4, 0.0]))]
        return renderer.render(scene_of(objects, camera, [light], "sky-checker"), technique)

    diffuse = render(lambda color, tex: Diffuse(color, texture=tex))
    principled = render(lambda color, tex: Principled(base_color=color, base_color_texture=tex, metallic=0.0,
                                                      specular=0.0))
    assert not Principled(specular=0.0).glossy
    assert np.array_equal(diffuse, principled)
    glossy = render(lambda color, tex: Principled(base_color=color, base_color_texture=tex, specular=1.0))
    assert not np.array_equal(diffuse, glossy)  # the same surfaces with their specular lobe do differ


def test_rough_metal_under_a_point_light_matches_the_brdf(renderer):
    """metallic 1, roughness 0.5, in a black environment: a floor pixel's radiance is glTF's specular BRDF
    (microfacet.specular_brdf, F0 the base colour) times its multiple-scattering compensation at the view
    (microfacet.layer_weights) times the light's irradiance there, within 3%."""
    camera = Camera(position=[0.0, 2.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=SIZE)
    light = PointLight([0.5, 2.0, -0.5], [10.0] * 3)
    base = np.array([0.9, 0.6, 0.3])
    floor = SceneObject("floor", plane((8.0, 8.0)), Principled(base_color=base, metallic=1.0, roughness=0.5))
    image = renderer.render(scene_of([floor], camera, [light]), "plain")
    pixel = (36, 30)
    p = hit_on_floor(camera, pixel)
    to_light = light.position - p
    distance2 = to_light @ to_light
    l, v, n = to_light / np.sqrt(distance2), camera.position - p, np.array([0.0, 1.0, 0.0])
    v = v / np.linalg.norm(v)
    h = (l + v) / np.linalg.norm(l + v)
    f = specular_brdf(l @ n, v @ n, h @ n, v @ h, float(alpha_of(0.5)), base)
    compensation, _ = layer_weights(base, np.zeros(3), np.array(v @ n), np.array(0.5))
    assert compensation.min() > 1.03  # the compensation is part of what is checked
    expected = f * compensation * light.intensity / distance2 * (l @ n)
    np.testing.assert_allclose(image[pixel[1], pixel[0]], expected, rtol=0.03)


def constant_map(value) -> np.ndarray:
    return np.broadcast_to(np.asarray(value, np.float32), (4, 4, 3)).copy()


FLOOR_CAMERA = Camera(position=[0.0, 2.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=SIZE)


def floor_pixels(camera: Camera, half_side: float) -> np.ndarray:
    """The pixels whose centre's ray meets y = 0 within ``half_side`` of the origin in x and z."""
    origin, direction = (a[:, :, 0] for a in camera.primary_rays())
    with np.errstate(divide="ignore", invalid="ignore"):
        hit = origin - (origin[..., 1] / direction[..., 1])[..., None] * direction
    return (direction[..., 1] < 0) & (np.abs(hit[..., 0]) < half_side) & (np.abs(hit[..., 2]) < half_side)


def lit_floor(renderer, material, lights=True, environment="sky-checker") -> np.ndarray:
    """An 8 x 8 floor of ``material`` under a point light (or none) and ``environment``, seen from above at an
    angle."""
    floor = SceneObject("floor", plane((8.0, 8.0)), material)
    light = [PointLight([0.5, 2.0, -0.5], [10.0] * 3)] if lights else []
    return renderer.render(scene_of([floor], FLOOR_CAMERA, light, environment), "plain")


def test_metallic_roughness_map_reads_green_as_roughness_and_blue_as_metallic(renderer):
    """A metallic-roughness map of (0, 0.5, 1) over factors 1 and 1 shades as roughness 0.5, metallic 1;
    its channels the other way round (metallic 0.5, roughness 1) do not."""
    base = [0.9, 0.6, 0.3]
    mapped = lit_floor(renderer, Principled(base_color=base, metallic=1.0, roughness=1.0,
                                            metallic_roughness_texture=constant_map([0.0, 0.5, 1.0])))
    factors = lit_floor(renderer, Principled(base_color=base, metallic=1.0, roughness=0.5))
    swapped = lit_floor(renderer, Principled(base_color=base, metallic=0.5, roughness=1.0))
    np.testing.assert_allclose(mapped, factors, rtol=1e-4, atol=1e-6)
    assert np.abs(swapped - factors).max() > 0.05


def test_occlusion_dims_the_environment_not_the_lights(renderer):
    """An occlusion map of red 0.25 (strength 1; green and blue ignored) scales the light from the
    environment (the ambient diffuse and the split-sum specular) by 0.25 and leaves the point light's. (A
    uniform environment: an environment's sun is a directional light of its own, not dimmed either.)"""
    material = dict(base_color=[0.5, 0.6, 0.7], roughness=0.4)
    occluded = lit_floor(renderer, Principled(**material, occlusion_texture=constant_map([0.25, 1.0, 0.0])),
                         environment="white")
    open_sky = lit_floor(renderer, Principled(**material), environment="white")
    environment_only = lit_floor(renderer, Principled(**material), lights=False, environment="white")
    floor = floor_pixels(FLOOR_CAMERA, 3.5)
    assert floor.mean() > 0.5 and environment_only[floor].mean() > 0.05
    np.testing.assert_allclose(occluded[floor], (open_sky - 0.75 * environment_only)[floor], rtol=1e-3, atol=1e-4)


def test_emission_is_added(renderer):
    """Emission (0.3, 0.2, 0.1) times an emission map of 0.5 adds (0.15, 0.1, 0.05) to every floor pixel."""
    material = dict(base_color=[0.5, 0.5, 0.5], roughness=0.5)
    glowing = lit_floor(renderer, Principled(**material, emission=[0.3, 0.2, 0.1], emission_texture=constant_map(0.5)))
    plain = lit_floor(renderer, Principled(**material))
    floor = floor_pixels(FLOOR_CAMERA, 3.5)
    np.testing.assert_allclose((glowing - plain)[floor], np.broadcast_to([0.15, 0.1, 0.05], (floor.sum(), 3)), atol=1e-5)


def ggx_prefiltered_step(polar: float, roughness: float, count: int = 100_000) -> float:
    """The split sum's prefiltered radiance (n = v = r) of an environment that is 1 above the horizon and 0
    below, at a direction ``polar`` radians from +Y: the n.l-weighted mean over GGX's reflected directions
    (microfacet.sample_visible_normal at normal incidence draws D(h) cos(h))."""
    rng = np.random.default_rng(0)
    normal = np.broadcast_to([0.0, 0.0, 1.0], (count, 3))
    half = sample_visible_normal(normal, float(alpha_of(roughness)), rng.random(count), rng.random(count))
    light = reflect(normal, half)
    weight = np.clip(light[:, 2], 0.0, None)
    height = np.cos(polar) * light[:, 2] + np.sin(polar) * light[:, 0]  # the world's y in r's frame
    return float((weight * (height > 0)).sum() / weight.sum())


def test_prefiltered_environment_is_the_ggx_convolution(renderer):
    """Each level of the prefiltered atlas (roughness k / (levels - 1)) holds the GGX convolution of the
    environment: for a sky of 1 over a black ground, per row (the polar angle; every column alike) within
    0.02 of the numpy estimate; level 0 is the environment itself."""
    image = np.zeros((64, 128, 3), np.float32)
    image[:32] = 1.0
    atlas = prefiltered_environment(renderer.device, Environment(image, source="test:step"))
    width, height = atlas.size
    texels = np.frombuffer(atlas.read(), np.float32).reshape(height, width, 4)[..., 0]
    rows = width // 2
    for row in (10, 21, 27, 37, 43):
        polar = np.pi * row / (rows - 1)
        assert texels[row].mean() == pytest.approx(float(polar < np.pi / 2), abs=1e-3)
        for level in range(1, PREFILTER_LEVELS):
            expected = ggx_prefiltered_step(polar, level / (PREFILTER_LEVELS - 1))
            assert texels[level * rows + row].mean() == pytest.approx(expected, abs=0.02), (level, row)
