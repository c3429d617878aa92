"""``exact`` on glTF metallic-roughness surfaces: a white furnace, energy conservation, a normal map, and
Mitsuba's path tracer on a rough metal ball and a glossy plastic floor."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.scene import microfacet
from caustica.metrics.images import psnr_linear
from caustica.raytrace import principled
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.scene import Camera, Diffuse, PointLight, Scene, SceneObject, Transform
from caustica.scene.environment import procedural_environment
from caustica.scene.materials import Principled
from caustica.scene.shapes import box, plane, sphere
from caustica.techniques.exact import Exact, ExactParams


def ball(radius=1.0):
    mesh = sphere(radius, 4)
    mesh.analytic_sphere = (np.zeros(3), radius)
    return mesh


def furnace(obj, size=(32, 32), position=(0.0, 0.0, 4.0)) -> Scene:
    camera = Camera(position=list(position), look_at=[0.0, 0.0, 0.0], fov_y=32.0, size=size)
    return Scene(camera=camera, objects=[obj], lights=[], environment=procedural_environment("white"), name="furnace")


def table_albedo(cos_v: np.ndarray, row: int) -> np.ndarray:
    """A white metal's single-scattering albedo A + B from microfacet.brdf_table's row ``row``, linear in cos_v."""
    table = microfacet.brdf_table()
    size = table.shape[0]
    return np.interp(cos_v, (np.arange(size) + 0.5) / size, table[row, :, 0] + table[row, :, 1])


@pytest.mark.parametrize("row", [9, 15, 24, 31])
def test_white_furnace_rough_metal_ball_returns_what_single_scattering_keeps(row):
    """A convex white metal (F0 = 1) in a white sky reflects E(cos_v), the single-scattering GGX albedo: the
    environment less what single scattering loses (1 - E, from the split-sum table; no interreflection on a
    ball). Roughness at the table's texel centres 0.30, 0.48, 0.77, 0.98, whose mean loss over the ball's
    pixels is 1.9 %, 11 %, 37 % and 59 %."""
    roughness = (row + 0.5) / microfacet.BRDF_TABLE_SIZE
    scene = furnace(SceneObject("ball", ball(), Principled(base_color=[1.0] * 3, metallic=1.0, roughness=roughness)))
    assert scene.objects[0].material.kind == "diffuse" and scene.objects[0].material.glossy
    spp = 16
    image = Exact().render(scene, scene.camera, ExactParams(), spp)
    origins, dirs = scene.camera.primary_rays(spp)
    height, width = dirs.shape[:2]
    hits = ray_scene_for(scene).intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    cos_v = np.clip(-np.sum(dirs.reshape(-1, 3) * hits.normal, axis=1), 0.0, 1.0)
    on_ball = hits.hit.reshape(height, width, spp).all(axis=2)
    expected = table_albedo(cos_v, row).reshape(height, width, spp).mean(axis=2)[on_ball]
    measured = image[on_ball].astype(np.float64)
    assert np.allclose(measured, measured[:, :1])  # white in, white out
    loss = 1.0 - expected.mean()
    assert abs(measured.mean() - expected.mean()) < 0.01 * expected.mean()
    assert 1.0 - measured.mean() <= loss + 0.01
    if row == 9:
        assert measured.mean() > 0.97  # a moderately rough metal keeps nearly all (98 %)


@pytest.mark.parametrize("roughness", [0.1, 0.3, 0.6, 1.0])
@pytest.mark.parametrize("cos_v", [1.0, 0.7, 0.3, 0.05])
def test_plastic_brdf_albedo_and_sampling_agree_with_evaluation(roughness, cos_v):
    """A white dielectric base under its specular layer: the importance-sampled weights f cos / pdf average to
    the albedo that evaluating f over uniform directions gives. From cos_v 0.7 up it reflects at most what it
    receives; towards grazing glTF's mix creates energy (its diffuse part is weighted by 1 - F(v.h), nearly 1
    for most light directions, while the specular lobe rises to F(cos_v)): up to about 1.7 at cos_v 0.05, and
    never more than 1 + F(cos_v) (the diffuse part at most 1 plus Fresnel at the view)."""
    n = 200_000
    rng = np.random.default_rng(7)
    surface = principled.Surface(np.tile([0.0, 0.0, 1.0], (n, 1)), np.ones((n, 3)), np.full((n, 3), 0.04),
                                 np.full((n, 3), 0.04), np.full(n, microfacet.alpha_of(roughness)), np.zeros((n, 3)))
    view = np.tile([np.sqrt(1.0 - cos_v ** 2), 0.0, cos_v], (n, 1))
    _, weight = principled.sample(surface, surface.normal, view, rng.random((n, 3)))
    sampled = weight[:, 0].mean()
    u = rng.random((n, 2))
    z, phi = u[:, 0], 2.0 * np.pi * u[:, 1]
    light = np.stack([np.sqrt(1.0 - z * z) * np.cos(phi), np.sqrt(1.0 - z * z) * np.sin(phi), z], axis=1)
    values = principled.evaluate(surface, surface.normal, view, light)[:, 0] * z * 2.0 * np.pi
    uniform = values.mean()
    noise = 3.0 * weight[:, 0].std() / np.sqrt(n)
    # Four standard errors of the two estimates (uniform directions are noisy on a sharp lobe) and 1 %.
    assert abs(sampled - uniform) < 4.0 * np.hypot(noise / 3.0, values.std() / np.sqrt(n)) + 0.01 * uniform
    assert sampled <= 1.0 + float(microfacet.schlick(0.04, cos_v)) + noise
    if cos_v >= 0.7:
        assert sampled <= 1.002 + noise


@pytest.mark.parametrize("metallic", [0.0, 1.0])
def test_rough_slab_in_a_white_furnace_creates_no_energy(metallic):
    """A white rough slab (plastic, or a metal with F0 = 1) seen from above (cos_v >= 0.8 on its top) in a
    white sky is no brighter than the sky."""
    slab = SceneObject("slab", box((3.0, 0.4, 3.0)), Principled(base_color=[1.0] * 3, metallic=metallic, roughness=0.5))
    scene = furnace(slab, size=(24, 24), position=(0.0, 4.0, 1.0))
    image = Exact().render(scene, scene.camera, ExactParams(), 16)
    origins, dirs = (a[:, :, 0].reshape(-1, 3) for a in scene.camera.primary_rays(1))
    hits = ray_scene_for(scene).intersect(origins, dirs)
    top = hits.hit & (hits.normal[:, 1] > 0.99)
    assert top.sum() > 100 and np.all(-dirs[top, 1] > 0.8)
    on_slab = image.reshape(-1, 3)[top]
    assert 0.9 < on_slab.mean() < 1.0
    assert np.percentile(on_slab, 99) < 1.2  # single pixels carry the noise of 16 samples


def tilted_plane_scene(normal_map: bool) -> Scene:
    """A glossy plane under a light: its normals tilted 20 degrees about z either by a constant normal map
    or in the mesh itself."""
    mesh = plane((4.0, 4.0))
    angle = np.radians(20.0)
    tilt = np.array([np.sin(angle), np.cos(angle), 0.0])
    if normal_map:
        # The plane's tangent (+u) is +x: the map's x along it, z along the normal.
        texel = np.array([np.sin(angle), 0.0, np.cos(angle)]) * 0.5 + 0.5
        material = Principled(base_color=[0.5, 0.4, 0.3], metallic=0.5, roughness=0.4,
                              normal_texture=np.broadcast_to(texel, (4, 4, 3)).astype(np.float32).copy())
    else:
        mesh.normals = np.tile(tilt, (len(mesh.vertices), 1)).astype(mesh.normals.dtype)
        material = Principled(base_color=[0.5, 0.4, 0.3], metallic=0.5, roughness=0.4)
    camera = Camera(position=[0.0, 3.0, 3.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(24, 24))
    return Scene(camera=camera, objects=[SceneObject("plane", mesh, material)],
                 lights=[PointLight(position=[1.0, 2.0, 1.0], intensity=[5.0] * 3)],
                 environment=procedural_environment("black"), name="tilted")


def test_constant_normal_map_equals_the_tilted_plane():
    """A plane whose constant normal map tilts its normal shades as the plane whose normals are tilted so."""
    mesh = plane((4.0, 4.0))
    assert mesh.uvs is not None
    from caustica.scene.tangents import mesh_tangents

    assert np.allclose(mesh_tangents(mesh)[:, :3], [1.0, 0.0, 0.0], atol=1e-6)  # the test's frame assumption
    mapped_scene, tilted_scene = tilted_plane_scene(True), tilted_plane_scene(False)
    mapped = Exact().render(mapped_scene, mapped_scene.camera, ExactParams(), 1)
    tilted = Exact().render(tilted_scene, tilted_scene.camera, ExactParams(), 1)
    assert psnr_linear(mapped, tilted) > 50.0
    flat = Principled(base_color=[0.5, 0.4, 0.3], metallic=0.5, roughness=0.4)
    scene = tilted_plane_scene(True)
    scene.objects[0].material = flat
    assert psnr_linear(Exact().render(scene, scene.camera, ExactParams(), 1), tilted) < 40.0  # the tilt shows


def metal_ball_scene() -> Scene:
    obj = SceneObject("ball", ball(), Principled(base_color=[0.95, 0.64, 0.54], metallic=1.0, roughness=0.4))
    camera = Camera(position=[0.0, 0.6, 3.6], look_at=[0.0, 0.0, 0.0], fov_y=38.0, size=(64, 64))
    return Scene(camera=camera, objects=[obj], lights=[], environment=procedural_environment("sky-checker"),
                 name="metal-ball")


def plastic_floor_scene() -> Scene:
    floor = SceneObject("floor", plane((8.0, 8.0)), Principled(base_color=[0.2, 0.3, 0.6], roughness=0.3))
    chalk = SceneObject("ball", ball(0.6), Diffuse(color=[0.8] * 3), Transform(position=[0.0, 0.6, 0.0]))
    camera = Camera(position=[0.0, 2.0, 4.5], look_at=[0.0, 0.3, 0.0], fov_y=40.0, size=(64, 64))
    return Scene(camera=camera, objects=[floor, chalk], lights=[PointLight(position=[1.5, 3.0, -1.0], intensity=[12.0] * 3)],
                 environment=procedural_environment("sky-checker"), name="plastic-floor")


@pytest.mark.parametrize("make, exact_spp, mean_tolerance", [(metal_ball_scene, 128, 0.01),
                                                            (plastic_floor_scene, 64, 0.05)])
def test_exact_matches_mitsuba_within_its_noise(reference_cache, make, exact_spp, mean_tolerance):
    """exact against Mitsuba's principled BSDF (256 spp, two seeds): exact differs from the seeds' mean by no more
    than the seeds differ from each other (the noise floor), and every channel's mean agrees within
    ``mean_tolerance`` (1 % on the metal, where both are Schlick's GGX; 5 % on the plastic, whose Mitsuba diffuse
    is Disney's, not glTF's Lambertian less Fresnel)."""
    pytest.importorskip("mitsuba", reason="the Mitsuba reference needs the 'reference' extra")
    from caustica.reference.render import render_reference

    scene = make()
    seeds = [render_reference(scene, spp=256, progress=False, cache_dir=reference_cache, seed=s) for s in (0, 1)]
    floor = psnr_linear(seeds[1], seeds[0])
    image = Exact().render(scene, scene.camera, ExactParams(), exact_spp)
    reference = (seeds[0] + seeds[1]) / 2.0
    assert psnr_linear(image, reference) > floor
    means, expected = image.mean(axis=(0, 1)), reference.mean(axis=(0, 1))
    assert np.all(np.abs(means - expected) < mean_tolerance * expected)
