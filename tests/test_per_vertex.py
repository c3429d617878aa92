"""per-vertex (Kakimoto et al.): exact at every vertex, least-squares viewpoint, patches, lenses."""
from __future__ import annotations

import math

import numpy as np
import pytest

from caustica.errors import TechniqueError
from caustica.metrics import psnr_linear
from caustica.passes.shading.lights import light_passes
from caustica.per_vertex import closest_point_to_lines, double_refraction, principal_directions, split_patches
from caustica.per_vertex.viewpoint import Lines, fit_view_volume
from caustica.raytrace.embree_scene import ray_scene_for
from caustica.raytrace.optics import normalize
from caustica.raytrace.paths import follow_refraction, trace
from caustica.render.frame import Frame
from caustica.render.graph import run_passes
from caustica.scene import Camera, Diffuse, Scene, SceneObject
from caustica.scene import presets_per_vertex as presets
from caustica.scene.shapes import box
from caustica.scene.transform import Transform
from caustica.techniques import per_vertex as pv
from caustica.techniques.raster import read_rgba


def flat_scene(radius: float, resolution: int = 8) -> Scene:
    """A mirror (curvature ``radius``) facing boxes of distinct flat colours; ambient light only."""
    mirror = presets.mirror_object("mirror", presets.curved_mirror(1.0, 1.0, radius, resolution), [0, 0, 0], [0, 0, 1])
    colours = [(0.9, 0.1, 0.1), (0.1, 0.8, 0.1), (0.1, 0.2, 0.9), (0.9, 0.8, 0.1), (0.6, 0.1, 0.7), (0.1, 0.7, 0.7)]
    objects = [mirror]
    for k, colour in enumerate(colours):
        x, y = (k % 3 - 1) * 1.6, (k // 3 - 0.5) * 1.6
        objects.append(SceneObject(f"box-{k}", box((1.6, 1.6, 0.2)), Diffuse(color=list(colour)),
                                   Transform(position=[x, y, 4.0])))
    if radius < 0:  # in the zooming region: between the mirror and where its reflected rays cross
        objects.append(SceneObject("near-box", box((0.5, 0.3, 0.05)), Diffuse(color=[0.95, 0.95, 0.95]),
                                   Transform(position=[0.0, -0.3, 0.3])))
    camera = Camera(position=[0.2, 0.1, 2.0], look_at=[0, 0, 0], fov_y=35.0, size=(96, 96))
    # Ambient only: a sky without its sun, which the raster techniques would add as a directional light.
    from caustica.scene.environment import Environment, sky_checker

    sky = Environment(sky_checker(sun_direction=None), source="test:sky-checker without its sun")
    return Scene(camera=camera, objects=objects, environment=sky)


def reflector_maps(renderer, scene, index, params):
    """The per-vertex work of one reflector and, per patch, its maps read back (rows bottom-up, as GL)."""
    frame = Frame(renderer.device, scene, scene.camera, params)
    run_passes(light_passes(params.shadow_map_size), frame)
    camera = scene.camera
    reflector = pv.prepare_reflector(scene, index, camera.position, camera.up, ray_scene_for(scene), params)
    maps = []
    for patch, zoom in zip(reflector.patches, reflector.zoom):
        pair = []
        for reverse in (False, True):
            if reverse and not (zoom.any() and patch.volume.has_zoom):
                pair.append(None)
                continue
            size = pv.map_texels(camera, reflector.points, patch, params)
            texture = pv.render_map(frame, pv.scene_without(scene, index), patch.volume, params, 0, size, reverse)
            pair.append(read_rgba(texture)[::-1, :, :3].copy())
            renderer.device.targets.give_back(texture)
        maps.append(pair)
    return reflector, maps


def texel(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Nearest texel at texture coordinates (origin at the lower left)."""
    h, w = image.shape[:2]
    col = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    row = np.clip((uv[:, 1] * h).astype(int), 0, h - 1)
    return image[row, col]


@pytest.mark.parametrize("radius", [2.0, -1.2])
def test_texel_at_every_vertex_is_the_exact_hit(renderer, radius):
    """3.4: at each mirror vertex the map texel under its coordinates is the colour along its exact ray
    (convex; concave with hits in the zooming region read from the reversed map, 4.2)."""
    scene = flat_scene(radius)
    params = pv.PerVertexParams(map_size=256, shadow_map_size=64)
    reflector, maps = reflector_maps(renderer, scene, 0, params)
    lines = reflector.channels[0]
    expected = trace(ray_scene_for(scene), scene, lines.origins, lines.directions, max_depth=1)
    for k, patch in enumerate(reflector.patches):
        uv, zoom = reflector.uv[k][0], reflector.zoom[k]
        assert np.all((uv > 0) & (uv < 1)), "the frustum holds every Q"
        got = np.where(zoom[:, None], texel(maps[k][1], uv) if maps[k][1] is not None else 0.0, texel(maps[k][0], uv))
        close = np.all(np.abs(got - expected[patch.vertices]) < 0.02, axis=1)
        assert close.mean() > 0.9, (radius, close.mean())
    if radius < 0:
        assert any(z.any() for z in reflector.zoom), "the concave mirror's hits reach the zooming region"


def test_viewpoint_minimises_squared_distance_to_lines():
    """3.2: the least-squares viewpoint against a brute-force minimiser."""
    from scipy.optimize import minimize

    rng = np.random.default_rng(1)
    origins = rng.normal(size=(40, 3))
    dirs = normalize(rng.normal(size=(40, 3)) + [0, 0, 3])

    def cost(p):
        offset = p - origins
        return float(np.sum(np.sum(offset**2, axis=1) - np.sum(offset * dirs, axis=1) ** 2))

    ours = closest_point_to_lines(origins, dirs)
    brute = minimize(cost, np.zeros(3), method="Nelder-Mead", options={"xatol": 1e-10, "fatol": 1e-12, "maxiter": 20000}).x
    assert cost(ours) <= cost(brute) + 1e-9
    assert np.allclose(ours, brute, atol=1e-4)


def test_planar_mirror_viewpoint_is_the_mirror_image_and_matches_exact(renderer):
    """For a flat mirror every reflected line passes through the eye's mirror image (no occlusion
    inconsistency), and the render equals `exact`."""
    scene = flat_scene(math.inf)
    camera = scene.camera
    reflector = pv.prepare_reflector(scene, 0, camera.position, camera.up, ray_scene_for(scene), pv.PerVertexParams())
    image_of_eye = camera.position * np.array([1.0, 1.0, -1.0])  # the mirror is the plane z = 0
    assert np.allclose(reflector.patches[0].volume.position, image_of_eye, atol=1e-9)
    ours = renderer.render(scene, "per-vertex", spp=4, shadow_map_size=256)
    exact = renderer.render(scene, "exact", spp=4)
    assert psnr_linear(ours, exact) > 35.0


def test_door_mirror_beats_cube_mapping_baseline(renderer):
    """fig. 1: the 49-vertex door mirror with the paper's 512^2 map is close to `exact` and far above env-map."""
    scene = presets.door_mirror(size=(96, 96))
    ours = renderer.render(scene, "per-vertex", map_size=512)
    exact = renderer.render(scene, "exact", environment_samples=0)  # the SH ambient per-vertex has
    baseline = renderer.render(scene, "env-map")
    assert pv.LAST_STATS["ray_vertices"] == 49
    assert psnr_linear(ours, exact) > 32.0
    assert psnr_linear(ours, exact) > psnr_linear(baseline, exact) + 15.0


def test_automatic_map_spends_its_density_on_the_covered_pixels():
    """map_size 0 (our extension): about map_density texels per eye pixel the mirror covers, shaped like the
    frustum; twice the image size, twice the map side. A fixed map_size gives the paper's square map."""
    sides = pv._MAP_SIDES
    for size in (128, 256):
        scene = presets.door_mirror(size=(size, size))
        camera = scene.camera
        reflector = pv.prepare_reflector(scene, 0, camera.position, camera.up, ray_scene_for(scene), pv.PerVertexParams())
        covered = reflector_mask(scene).sum()
        for density in (1.0, 3.0):
            params = pv.PerVertexParams(map_density=density)
            width, height = pv.map_texels(camera, reflector.points, reflector.patches[0], params)
            # Rounded up to the next side of the ladder (steps of at most 1.5x), never down.
            assert density * covered * 0.9 <= width * height <= density * covered * 1.5**2 * 1.1
            left, right, bottom, top = reflector.patches[0].volume.bounds
            assert 1 / 1.6 < (width / height) / ((right - left) / (top - bottom)) < 1.6
            assert width in sides and height in sides
        assert pv.map_texels(camera, reflector.points, reflector.patches[0], pv.PerVertexParams(map_size=300)) == (300, 300)


def test_denser_automatic_maps_come_closer_to_exact(renderer):
    """More texels per covered pixel: closer to `exact` (measured at 128^2: 26.9, 30.3, 33.9 dB)."""
    scene = presets.door_mirror(size=(128, 128))
    exact = renderer.render(scene, "exact", environment_samples=0)  # the SH ambient per-vertex has
    scores = [psnr_linear(renderer.render(scene, "per-vertex", map_density=d), exact) for d in (0.1, 0.5, 4.0)]
    assert scores[0] + 2.0 < scores[1] < scores[2] - 2.0


def reflector_mask(scene) -> np.ndarray:
    """Pixels whose primary ray first hits a mirror (Embree)."""
    origins, dirs = scene.camera.primary_rays(1)
    hits = ray_scene_for(scene).intersect(origins.reshape(-1, 3), dirs.reshape(-1, 3))
    kinds = np.array([o.material.kind == "mirror" for o in scene.objects] + [False])
    return kinds[hits.object_index]


def test_patches_agree_at_shared_vertices(renderer):
    """4.1, fig. 7: two mirrors with their own viewpoints show the same colour at their 7 shared vertices."""
    scene = presets.mirror_patches(size=(64, 64))
    params = pv.PerVertexParams(map_size=256, shadow_map_size=64, max_patches=1)
    (left, left_maps), (right, right_maps) = (reflector_maps(renderer, scene, i, params) for i in (0, 1))
    assert not np.allclose(left.patches[0].volume.position, right.patches[0].volume.position)
    points = [scene.objects[i].world_mesh().vertices[r.vertex_ids] for i, r in ((0, left), (1, right))]
    distance = np.linalg.norm(points[0][:, None] - points[1][None], axis=2)
    a, b = np.nonzero(distance < 1e-6)
    assert len(a) == 7
    assert np.allclose(left.channels[0].hit_points[a], right.channels[0].hit_points[b], atol=1e-6)
    colour_a = texel(left_maps[0][0], left.uv[0][0][a])
    colour_b = texel(right_maps[0][0], right.uv[0][0][b])
    assert np.abs(colour_a - colour_b).max() < 0.05


def test_fov_threshold_splits_into_patches_sharing_vertices():
    """4.1: the split stops once every frustum is narrower than the threshold; faces are partitioned."""
    scene = presets.mirror_series(1.0, resolution=12, size=(64, 64))
    camera = scene.camera
    params = pv.PerVertexParams(fov_threshold=60.0, max_patches=64)
    reflector = pv.prepare_reflector(scene, 0, camera.position, camera.up, ray_scene_for(scene), params)
    assert len(reflector.patches) > 1
    assert all(max(p.volume.fov_degrees) <= 60.0 for p in reflector.patches)
    faces = np.concatenate([p.faces for p in reflector.patches])
    assert len(faces) == len(reflector.faces) and len(np.unique(faces, axis=0)) == len(faces)
    shared = np.intersect1d(reflector.patches[0].vertices, np.concatenate([p.vertices for p in reflector.patches[1:]]))
    assert len(shared) > 0


def test_split_patches_keeps_one_patch_below_threshold():
    faces = np.array([[0, 1, 2], [1, 3, 2]])

    class Narrow:
        fov_degrees = (10.0, 10.0)

    patches = split_patches(faces, np.zeros((4, 3)), lambda vertices: Narrow(), 30.0, 8)
    assert len(patches) == 1 and np.array_equal(patches[0].vertices, [0, 1, 2, 3])


def test_saddle_up_vector_on_principal_direction():
    """4.3: the fitted principal directions of y = (x^2 - z^2) / (2R) are the x and z axes."""
    vertices, normals, _ = presets.curved_mirror(1.0, 1.0, 1.5, 10, "saddle")
    directions, curvature = principal_directions(vertices, normals, np.array([0.0, 1.0, 0.0]))
    assert curvature[0] < 0 < curvature[1]
    assert abs(abs(directions[0] @ [0, 0, 1]) - 1) < 1e-6 and abs(abs(directions[1] @ [1, 0, 0]) - 1) < 1e-6
    lines = Lines(vertices, normalize(np.c_[vertices[:, 0], np.ones(len(vertices)), -vertices[:, 2]]),
                  np.full(len(vertices), 3.0))
    volume = fit_view_volume(lines, vertices, np.array([[-2.0] * 3, [2.0] * 3]), directions[0])
    assert abs(abs(volume.view_from_world[1, :3] @ directions[0]) - 1) < 1e-6


def test_lens_vertices_match_exact_double_refraction():
    """4.5: at every eye-facing lens vertex, the twice-refracted ray is the oracle's."""
    scene = presets.spectacle_lens(size=(64, 64))
    eye, lens = scene.camera.position, scene.objects[0].world_mesh()
    p, n = lens.vertices.astype(np.float64), lens.normals.astype(np.float64)
    front = (np.einsum("ij,ij->i", n, p - eye) < 0) & (np.hypot(p[:, 0], p[:, 1]) < 0.24)  # off the rim
    ray_scene = ray_scene_for(scene)
    ours = double_refraction(ray_scene, 0, eye, p[front], n[front], 1.5)
    start = eye + 0.999 * (p[front] - eye)
    exact = follow_refraction(ray_scene, scene, start, normalize(p[front] - eye))
    assert ours.valid.all() and exact.valid.all()
    assert np.degrees(np.arccos(np.clip(np.sum(ours.directions * exact.direction, axis=1), -1, 1))).max() < 1e-3
    assert np.abs(ours.origins - exact.position).max() < 1e-6


def test_lens_render_close_to_exact(renderer):
    scene = presets.spectacle_lens(size=(96, 96))
    ours, exact = renderer.render(scene, "per-vertex"), renderer.render(scene, "exact")
    assert psnr_linear(ours, exact) > 22.0
    assert psnr_linear(ours, exact) > psnr_linear(renderer.render(scene, "env-map"), exact) + 8.0


def test_equal_iors_per_channel_equal_the_plain_render(renderer):
    """fig. 15: aberration with three equal IORs is the single-IOR render (one shared map)."""
    scene = presets.spectacle_lens(size=(64, 64), ior=1.61)
    plain = renderer.render(scene, "per-vertex")
    same = renderer.render(scene, "per-vertex", ior_rgb=(1.61, 1.61, 1.61))
    split = renderer.render(scene, "per-vertex", ior_rgb=presets.ABERRATION_IOR_RGB)
    assert np.abs(plain - same).max() < 1e-5
    assert np.abs(plain - split).max() > 1e-3


def test_cached_lens_work_gives_the_same_image(renderer):
    """Section 5: with the lens fixed to the eye, cached refraction vectors give the same frame."""
    scene = presets.spectacle_lens(size=(64, 64))
    fresh = renderer.render(scene, "per-vertex")
    first = renderer.render(scene, "per-vertex", cache=True)
    second = renderer.render(scene, "per-vertex", cache=True)
    assert np.abs(first - fresh).max() < 1e-5 and np.abs(second - fresh).max() < 1e-4


def test_mirror_in_a_mirror_needs_depth_two(renderer):
    """4.4: with depth 2 the side mirror seen in the front mirror shows the blocks, as `exact` does."""
    scene = presets.mirror_in_mirror(size=(64, 64))
    exact = renderer.render(scene, "exact")
    one = renderer.render(scene, "per-vertex", depth=1)
    two = renderer.render(scene, "per-vertex", depth=2)
    assert psnr_linear(two, exact) > psnr_linear(one, exact) + 1.0


def test_markers_sit_at_exact_hits():
    scene = presets.door_mirror(size=(32, 32), markers=True)
    assert scene.objects[-1].name == "markers"
    assert len(scene.objects[-1].mesh.vertices) % 42 == 0 and len(scene.objects[-1].mesh.vertices) // 42 >= 40


@pytest.mark.parametrize("bad", [{"up": "sideways"}, {"map_size": 4}, {"map_size": "auto"}, {"map_density": 0.0},
                                 {"ior_rgb": (1.5, -1, 1.5)}, {"depth": 1.5}, {"fov_threshold": 0.0}, {"cache": "yes"}])
def test_bad_parameters_are_refused(renderer, bad):
    with pytest.raises(TechniqueError):
        renderer.render(presets.mirror_series(size=(16, 16)), "per-vertex", **bad)


def test_viewpoint_parallax_is_the_mean_angle_from_the_least_squares_viewpoint():
    """Two skew lines (through y = -a along x, through y = +a along z) have their least-squares viewpoint at the
    origin; each hit s along its line is seen from there atan(a / s) off the line; a third line through
    the origin that escapes adds 0 and leaves the viewpoint: the mean is 2 atan(a / s) / 3. Lines through one
    point (a flat mirror's) give 0."""
    from caustica.per_vertex.viewpoint import viewpoint_parallax

    a, s = 0.5, 2.0
    lines = Lines(np.array([[0.0, -a, 0.0], [0.0, a, 0.0], [0.0, 0.0, 0.0]]),
                  np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), np.array([s, s, np.inf]))
    assert viewpoint_parallax(lines) == pytest.approx(2.0 * math.degrees(math.atan(a / s)) / 3.0, rel=1e-9)
    rng = np.random.default_rng(3)
    directions = normalize(rng.normal(size=(20, 3)))
    through = Lines(np.array([1.0, 2.0, 3.0]) + 2.0 * directions, directions, rng.uniform(0.5, 3.0, 20))
    assert viewpoint_parallax(through) == pytest.approx(0.0, abs=1e-5)
    assert viewpoint_parallax(Lines(through.origins, through.directions, np.full(20, np.inf))) == 0.0


def test_a_mirror_shows_the_caustic_on_the_floor_it_reflects(renderer):
    """mirror-in-mirror: the sun reflected off one flat mirror lights a patch of floor, which the other mirror shows.
    per-vertex's reflection maps (Kakimoto et al. 3.2: the scene less the mirror, from the virtual viewpoint) shade
    that floor with the frame's caustic maps, so its mirror pixels there match exact's (photons traced) to 6 % on
    average; before, the maps left the caustic out and read exact's floor without its photons (ratio 0.84)."""
    from caustica import load_scene
    from caustica.reference.render import diffuse_coverage

    scene = load_scene("mirror-in-mirror")
    scene.camera = scene.camera.with_size(96, 72)
    with_photons = renderer.render(scene, "exact", 4)
    without = renderer.render(scene, "exact", 4, caustic_photons=0)
    image = renderer.render(scene, "per-vertex+caustic-mapping")
    mirrors = diffuse_coverage(scene, scene.camera) < 0.5
    lit = mirrors & ((with_photons - without).mean(axis=-1) > 0.1 * without.mean(axis=-1))
    assert lit.sum() >= 20
    ratio = image[lit].mean(axis=-1) / with_photons[lit].mean(axis=-1)
    assert abs(ratio.mean() - 1.0) < 0.06


def _straight_down_map(renderer, lit_texels):
    """A 64 x 64 caustic map of a directional light shining straight down (-y) from (0, 10, 0) over a floor at
    y = 0, 4 x 4 world units wide (ortho), with ``lit_texels`` (rows, cols slices) lit; and its light sample."""
    from caustica.lighting.samples import LightSample
    from caustica.passes.caustics.maps import CAUSTIC_PROJECTIVE, CausticMap
    from caustica.scene.codes import LIGHT_DIRECTIONAL
    from caustica.scene.transform import orthographic_clip_from_view

    view_from_world = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, 0], [0, 1.0, 0, -10.0], [0, 0, 0, 1.0]])  # looks down -y
    texels = np.zeros((64, 64, 4), np.float32)
    texels[..., 3] = 10.0  # every texel sees the floor 10 below the light
    texels[lit_texels + (slice(0, 3),)] = 1.0
    texture = renderer.device.ctx.texture((64, 64), 4, texels.tobytes(), dtype="f4")
    caustic = CausticMap(texture, CAUSTIC_PROJECTIVE, orthographic_clip_from_view(2.0, 2.0, 0.1, 20.0) @ view_from_world)
    sample = LightSample(LIGHT_DIRECTIONAL, np.array([0.0, 10.0, 0.0]), np.array([0.0, -1.0, 0.0]), np.ones(3))
    return caustic, sample


def test_lit_boxes_put_a_caustic_maps_light_on_its_receiver(renderer):
    """Known answer: texels 30-33 lit in both directions, grown by LIT_MARGIN (2) to 28-35, lie on the floor
    (y = 0) between x, z = +-(35.5 / 64 * 2 - 1) * 2 = +-0.21875."""
    from caustica.passes.caustics.maps import LIT_MARGIN, lit_boxes

    assert LIT_MARGIN == 2
    caustic, sample = _straight_down_map(renderer, (slice(30, 34), slice(30, 34)))
    boxes = lit_boxes(caustic, sample)
    low, high = boxes[:, 0].min(axis=0), boxes[:, 1].max(axis=0)
    assert np.allclose(low, [-0.21875, 0.0, -0.21875], atol=1e-6) and np.allclose(high, [0.21875, 0.0, 0.21875],
                                                                                   atol=1e-6)
    assert lit_boxes(caustic, sample) is boxes  # read back once
    caustic.texture.release()


def test_a_caustic_reaches_a_view_that_sees_its_light(renderer):
    """maps_reaching: a camera looking at the lit patch sees it; one looking at the floor 3 units away, or up,
    does not; an unlit map reaches nothing; a cube map (no box fitted) reaches everything."""
    from caustica.passes.caustics.maps import CAUSTIC_CUBE, CausticMap, maps_reaching

    caustic, sample = _straight_down_map(renderer, (slice(30, 34), slice(30, 34)))
    assert maps_reaching([caustic], [sample], _look([0.0, 2.0, 2.0], [0.0, 0.0, 0.0], fov=20.0))
    assert not maps_reaching([caustic], [sample], _look([3.0, 2.0, 2.0], [3.0, 0.0, 0.0], fov=20.0))
    assert not maps_reaching([caustic], [sample], _look([0.0, 1.0, 0.5], [0.0, 5.0, 0.0], fov=20.0))
    dark, _ = _straight_down_map(renderer, (slice(0, 0), slice(0, 0)))
    assert not maps_reaching([dark, None], [sample, sample], _look([0.0, 2.0, 2.0], [0.0, 0.0, 0.0]))
    assert maps_reaching([CausticMap(dark.texture, CAUSTIC_CUBE)], [sample], _look([0.0, 1.0, 0.5], [0.0, 5.0, 0.0]))
    caustic.texture.release()
    dark.texture.release()


def _look(position, target, fov=40.0):
    return np.asarray(Camera(position=list(position), look_at=list(target), fov_y=fov, size=(64, 64)).clip_from_world())


def test_reflection_maps_take_only_caustic_maps_that_reach_them(renderer, monkeypatch):
    """A reflection map takes the frame's caustic maps only where their light can land in its view
    (maps_reaching): on mirror-flat none can (its reflected floor holds no caustic), and the image is the one
    rendered with the maps shared anyway, bit for bit; on mirror-in-mirror one can, and the maps are shared
    (test_a_mirror_shows_the_caustic_on_the_floor_it_reflects)."""
    from caustica import load_scene

    reaching = pv.maps_reaching
    for name, reached in (("mirror-flat", False), ("mirror-in-mirror", True)):
        scene = load_scene(name)
        scene.camera = scene.camera.with_size(64, 48)
        asked = []
        monkeypatch.setattr(pv, "maps_reaching", lambda *args: asked.append(reaching(*args)) or asked[-1])
        gated = renderer.render(scene, "per-vertex+caustic-mapping")
        assert asked and any(asked) == reached, (name, asked)
        monkeypatch.setattr(pv, "maps_reaching", lambda maps, samples, clip: bool(maps))
        assert np.array_equal(gated, renderer.render(scene, "per-vertex+caustic-mapping")), name
