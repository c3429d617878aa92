"""depth-search (Hu and Qin, TVCG 2007, 2.1 and 4) against the exact exit directions of the oracle."""
from __future__ import annotations

import numpy as np
import pytest

import caustica
from caustica.errors import TechniqueError
from caustica.metrics import angular_error, exact_exit_directions
from caustica.scene import Camera, Environment, Glass, Scene, SceneObject, procedural_environment
from caustica.scene.presets import PRESETS
from caustica.scene.shapes import sphere

# Mean exit-direction error (degrees) at 96x96, measured on llvmpipe with the defaults:
# IOR 1.5: 0.030, 1.75: 0.033, 0.8: 0.35 (env-map: 18.6, 22.8, 12.1); with back_iteration="secant" (start
# at d_V): 0.036, 0.040, 0.50; "depth-step" (the paper's small first dT and flat-face steps): 0.17, 0.05,
# 0.75. Bounds leave >2x margin (IOR 0.8 tightened from 1.5 when the front-exit start became the
# sphere's chord).
MEAN_BOUND = {1.5: 0.1, 1.75: 0.1, 0.8: 0.75}


def ball_scene(ior, size=96, position=(0.0, 0.0, 4.0), environment=None):
    camera = Camera(position=list(position), look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(size, size))
    return Scene(camera=camera, objects=[SceneObject("ball", sphere(1.0, 5), Glass(ior=ior))],
                 environment=environment or procedural_environment("sky-checker"))


def exit_error(renderer, scene, technique, **params):
    ref, ref_valid = exact_exit_directions(scene)
    dirs, valid = renderer.exit_directions(scene, technique, **params)
    return angular_error(dirs, ref, (valid, ref_valid))


@pytest.mark.parametrize("ior", [1.5, 1.75, 0.8])
def test_exit_directions_beat_env_map(renderer, ior):
    """Two interfaces found by depth search: far below env-map's one-interface error, for n_t > n_i and n_t < n_i."""
    scene = ball_scene(ior)
    ours = exit_error(renderer, scene, "depth-search")
    baseline = exit_error(renderer, scene, "env-map")
    assert ours["count"] > 0.9 * (96 * 96 * 0.17)  # the ball covers ~20% of the image
    assert ours["mean_deg"] < MEAN_BOUND[ior], ours
    assert ours["mean_deg"] < 0.2 * baseline["mean_deg"], (ours, baseline)


@pytest.mark.parametrize("ior", [1.5, 0.8])
def test_secant_back_iteration_beats_the_flat_face_steps(renderer, ior):
    """Ours: secant steps from a start read off the back buffer find the back exit closer than 2.1.3's
    small start with flat-face steps, within the same number of iterations (on the IOR 1.5 sphere the
    latter fails at the rim)."""
    scene = ball_scene(ior)
    secant = exit_error(renderer, scene, "depth-search")["mean_deg"]
    flat = exit_error(renderer, scene, "depth-search", back_iteration="depth-step")["mean_deg"]
    assert secant < 0.8 * flat, (secant, flat)


@pytest.mark.parametrize("ior", [1.5, 1.75])
def test_sphere_start_is_the_chord_of_a_sphere(renderer, ior):
    """Ours: a sphere cuts the chord 2 R cos(theta) from any line through P1 at theta to the normal,
    so d_V cos(theta_t) / cos(theta_i) is T1's chord: on a ball the start alone (no correction)
    already lands on the exit, where a start at d_V is far off (measured at 96x96: 0.22 / 0.30
    against 17 / 24 degrees mean; 0.030 / 0.033 after the corrections)."""
    scene = ball_scene(ior)
    chord = exit_error(renderer, scene, "depth-search", iterations=0)["mean_deg"]
    thickness = exit_error(renderer, scene, "depth-search", back_iteration="secant", iterations=0)["mean_deg"]
    assert chord < 0.6 and chord < 0.05 * thickness, (chord, thickness)


def test_ior_one_is_invisible(renderer):
    """IOR 1.0: no Fresnel reflection, no bending: the background shows through undistorted."""
    scene = ball_scene(1.0, size=64)
    with_ball = renderer.render(scene, "depth-search")
    scene.objects = []
    empty = renderer.render(scene, "depth-search")
    assert caustica.metrics.psnr_linear(with_ball, empty) > 40.0


def test_mirror_symmetric_cameras_give_mirrored_images(renderer):
    """A scene symmetric about x = 0 seen from (+a, 0, 4) and (-a, 0, 4) renders mirror images."""
    env = procedural_environment("sky-checker").image
    env = 0.5 * (env + env[:, ::-1])  # x -> -x maps u -> 1 - u: symmetric columns
    env = Environment(env, source="symmetrised sky-checker")
    left = renderer.render(ball_scene(0.8, size=64, position=(-0.7, 0.0, 4.0), environment=env), "depth-search")
    right = renderer.render(ball_scene(0.8, size=64, position=(0.7, 0.0, 4.0), environment=env), "depth-search")
    assert caustica.metrics.psnr_linear(left, right[:, ::-1]) > 35.0


def test_parameters_have_an_effect(renderer):
    """No dT correction (P2 next to P1) and a one-step silhouette search are worse than the defaults."""
    scene = ball_scene(0.8, size=64)
    default = exit_error(renderer, scene, "depth-search")["mean_deg"]
    assert exit_error(renderer, scene, "depth-search", iterations=0)["mean_deg"] > 2.0 * default
    assert exit_error(renderer, scene, "depth-search", search_steps=1)["mean_deg"] > 1.5 * default
    searched = exit_error(renderer, scene, "depth-search", assume_back_first=False)["mean_deg"]
    assert searched < MEAN_BOUND[0.8]


@pytest.mark.parametrize("params", [
    {"iterations": -1}, {"iterations": 2.5}, {"search_steps": 0}, {"search_start": 0.0},
    {"tolerance": -1e-3}, {"assume_back_first": "yes"}, {"shadow_map_size": 8}, {"steps": 8},
    {"internal_bounces": -1}, {"internal_bounces": 9}, {"internal_bounces": 1.5}, {"internal_bounces": True},
    {"internal_reflection": True}, {"back_iteration": "newton"},
    {"bounce_iterations": -2}, {"bounce_iterations": 33}, {"bounce_iterations": 1.5},
])
def test_bad_parameters_raise(renderer, params):
    with pytest.raises(TechniqueError):
        renderer.render(ball_scene(1.5, size=16), "depth-search", **params)


@pytest.mark.parametrize("name", ["tvcg-fig10", "tvcg-fig11"])
def test_procedural_presets_load(name):
    scene = caustica.load_scene(name)
    assert scene.camera.size == (512, 512) and scene.objects_of("glass")
    assert scene.environment.source == "procedural:sky-checker"


@pytest.mark.parametrize("name", ["glass-teapot", "glass-bunny"])
def test_data_presets_load(data_dir, name, monkeypatch):
    monkeypatch.setenv("CAUSTICA_DATA", str(data_dir))
    scene = caustica.load_scene(name)
    (obj,) = scene.objects_of("glass")
    extent = obj.world_mesh().bounds
    assert np.allclose((extent[0] + extent[1]) / 2, 0.0, atol=1e-6)
    assert 0.9 < np.max(extent[1] - extent[0]) < 2.5


def test_data_preset_without_data_names_the_file(monkeypatch, tmp_path):
    monkeypatch.setenv("CAUSTICA_DATA", str(tmp_path))
    with pytest.raises(caustica.SceneError, match="stanford-bunny.obj"):
        PRESETS["glass-bunny"]()


# PSNR (dB) against exact at 96x96, 4 spp, glass-sphere, measured on llvmpipe: rows internal_bounces 0-3,
# columns exact max_depth 2, 3, 4, 5, 16:
#   0: 51.5 31.5 30.5 30.1 29.9    1: 31.7 49.3 44.1 42.0 40.6
#   2: 30.4 42.1 44.6 44.0 43.0    3: 30.1 40.6 44.0 44.6 44.2
DEPTHS = (2, 3, 4, 5)


@pytest.fixture(scope="module")
def sphere_and_exact():
    from caustica.renderer import Renderer

    scene = caustica.load_scene("glass-sphere")
    scene.environment.filter = "bilinear"  # per-sample comparison with exact: the same lookup per sample
    small = Renderer((96, 96))
    exact = {depth: small.render(scene, "exact", spp=4, max_depth=depth) for depth in (*DEPTHS, 16)}
    return small, scene, exact


def test_no_internal_bounces_is_the_two_interface_image(sphere_and_exact):
    """internal_bounces = 0 (the default) is the paper: it matches exact limited to two interfaces
    (entry and exit) and misses the light reflected inside that max_depth 3 adds."""
    from caustica.metrics import psnr_linear

    small, scene, exact = sphere_and_exact
    plain = small.render(scene, "depth-search", spp=4)
    assert np.array_equal(plain, small.render(scene, "depth-search", spp=4, internal_bounces=0))
    assert psnr_linear(plain, exact[2]) > 48.0
    assert psnr_linear(plain, exact[3]) < 35.0


@pytest.mark.parametrize("bounces", [1, 2, 3])
def test_internal_bounces_match_exact_with_as_many_interactions(sphere_and_exact, bounces):
    """Our extension: k internal bounces are the paths of entry, k internal reflections and the exits,
    so the image is closest to exact with max_depth k + 2 among max_depth 2 to 5."""
    from caustica.metrics import psnr_linear

    small, scene, exact = sphere_and_exact
    image = small.render(scene, "depth-search", spp=4, internal_bounces=bounces)
    scores = {depth: psnr_linear(image, exact[depth]) for depth in DEPTHS}
    assert max(scores, key=scores.get) == bounces + 2, scores
    if bounces == 1:
        assert scores[3] > 45.0, scores


def test_each_internal_bounce_brings_the_image_closer_to_exact(sphere_and_exact):
    """Against full exact (max_depth 16): 29.9, 40.6, 43.0, 44.2 dB for 0-3 bounces; each step
    must gain at least half of that."""
    from caustica.metrics import psnr_linear

    small, scene, exact = sphere_and_exact
    scores = [psnr_linear(small.render(scene, "depth-search", spp=4, internal_bounces=k), exact[16]) for k in range(4)]
    gains = np.diff(scores)
    assert np.all(gains > [5.0, 1.2, 0.6]), scores


def test_internal_bounces_with_dispersion(renderer):
    """The dispersive shader variant follows the bounces per channel too. At 48x48, 4 spp (abbe 30),
    against exact max_depth 4: 29.6 dB without bounces, 35.9 with two (measured); at least 4 dB gained."""
    from caustica.metrics import psnr_linear

    scene = ball_scene(1.5, size=48)
    scene.objects[0].material = Glass(ior=1.5, abbe=30.0)
    exact = renderer.render(scene, "exact", spp=4, max_depth=4)
    plain = psnr_linear(renderer.render(scene, "depth-search", spp=4), exact)
    bounced = psnr_linear(renderer.render(scene, "depth-search", spp=4, internal_bounces=2), exact)
    assert bounced > plain + 4.0, (plain, bounced)


def test_bounce_iterations_default_to_iterations(renderer):
    """bounce_iterations -1 (the default) gives the bounced exits as many dT corrections as the first exit."""
    scene = ball_scene(1.5, size=32)
    for iterations in (5, 2):
        default = renderer.render(scene, "depth-search", internal_bounces=2, iterations=iterations)
        same = renderer.render(scene, "depth-search", internal_bounces=2, iterations=iterations,
                               bounce_iterations=iterations)
        assert np.array_equal(default, same)


def test_a_bounced_exit_starts_from_the_last_chord(sphere_and_exact):
    """On a sphere every chord of an internally reflected path is as long as the first (equal angles at
    both ends of a chord), so the bounced exits start exact and need no dT correction: 0 corrections are
    as close to exact (max_depth 4) as 5; a first guess other than the last chord would need them."""
    from caustica.metrics import psnr_linear

    small, scene, exact = sphere_and_exact
    corrected = psnr_linear(small.render(scene, "depth-search", spp=4, internal_bounces=2), exact[4])
    uncorrected = psnr_linear(small.render(scene, "depth-search", spp=4, internal_bounces=2, bounce_iterations=0),
                              exact[4])
    assert uncorrected > corrected - 0.3, (corrected, uncorrected)


def test_bounce_iterations_correct_the_bounced_exits_of_an_ellipsoid(renderer):
    """Where successive chords differ (an ellipsoid, 1.3 x 0.8 x 1, turned 60 degrees) the last chord is only a
    first guess and each dT correction brings the bounced exits closer to exact (max_depth 4). Measured at
    48x48, 4 spp: 21.5, 24.0, 26.5 dB for 0, 2, 5 corrections."""
    from caustica.metrics import psnr_linear
    from caustica.scene.transform import Transform

    scene = ball_scene(1.5, size=48)
    scene.objects[0] = SceneObject("ellipsoid", sphere(1.0, 4), Glass(ior=1.5),
                                   Transform(scale=(1.3, 0.8, 1.0), rotation=(60.0, 0.0, 0.0)))
    scene.environment.filter = "bilinear"
    exact = renderer.render(scene, "exact", spp=4, max_depth=4)
    scores = [psnr_linear(renderer.render(scene, "depth-search", spp=4, internal_bounces=2, bounce_iterations=k),
                          exact) for k in (0, 2, 5)]
    assert np.all(np.diff(scores) > 1.0), scores


def test_shared_bounce_lookups_are_the_per_channel_ones_without_dispersion(renderer):
    """Ours (shared_bounce_lookups): red and blue reuse green's lookups at the bounced exits. With a spread of
    5e-7 between the channels' IORs (abbe 1e6) that is the per-channel image; at abbe 30 it differs (by 0.04
    at most, measured) and is as close to exact with max_depth 4 (35.03 dB shared, 35.02 per channel)."""
    from caustica.metrics import psnr_linear

    scene = ball_scene(1.5, size=48)
    scene.objects[0].material = Glass(ior=1.5, abbe=1e6)
    shared = renderer.render(scene, "depth-search", spp=4, internal_bounces=2)
    own = renderer.render(scene, "depth-search", spp=4, internal_bounces=2, shared_bounce_lookups=False)
    assert np.abs(shared - own).max() < 1e-5
    scene.objects[0].material = Glass(ior=1.5, abbe=30.0)
    exact = renderer.render(scene, "exact", spp=4, max_depth=4)
    shared = renderer.render(scene, "depth-search", spp=4, internal_bounces=2)
    own = renderer.render(scene, "depth-search", spp=4, internal_bounces=2, shared_bounce_lookups=False)
    assert np.abs(shared - own).max() > 1e-3
    assert psnr_linear(shared, exact) > psnr_linear(own, exact) - 0.1


def _fresnel(cos_i: float, ior: float) -> float:
    """Unpolarised dielectric Fresnel reflectance from air into ``ior`` (optics.glsl's formula)."""
    sin_t = np.sqrt(1.0 - cos_i ** 2) / ior
    cos_t = np.sqrt(1.0 - sin_t ** 2)
    rs = (cos_i - ior * cos_t) / (cos_i + ior * cos_t)
    rp = (ior * cos_i - cos_t) / (ior * cos_i + cos_t)
    return 0.5 * (rs * rs + rp * rp)


def block_end_scene(size=48):
    """A clear block (2 x 0.5 x 0.5, IOR 1.5) seen through its +x end face from 20 away at 30 degrees above
    its axis, in an environment bright (1) above the horizon and black below."""
    from caustica.scene.shapes import box

    env = np.zeros((64, 128, 3), np.float32)
    env[:32] = 1.0
    view = np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0)), 0.0])
    camera = Camera(position=list(np.array([1.0, 0.0, 0.0]) + 20.0 * view), look_at=[1.0, 0.0, 0.0], fov_y=2.0,
                    size=(size, size))
    return Scene(camera=camera, objects=[SceneObject("block", box((2.0, 0.5, 0.5)), Glass(ior=1.5))],
                 environment=Environment(env, source="step", filter="bilinear"))


def test_convex_exits_follow_total_internal_reflection_through_a_block(renderer):
    """Ours (passes/shading/convex_exits.py): light entering a block's end face at 30 degrees refracts to
    theta_t = asin(sin 30 / 1.5), reflects totally off the side faces (incidence 70.5 > 41.8 degrees)
    and leaves through the far end at 30 degrees again, its vertical direction flipped once per side face
    met: by unfolding, once for entry heights y0 above 2 tan(theta_t) - 0.75 = -0.043 (it leaves upwards,
    into the bright sky: radiance (1 - F)^2 = 0.919 with two internal bounces), twice below (downwards,
    black). Measured (48x48): 0.919 and 0 with the exact exits; the search in screen space gives 0.958 on
    both sides (no exit found past the first reflection, whose reflected ray reads the sky)."""
    scene = block_end_scene()
    origins, dirs = (a[:, :, 0] for a in scene.camera.primary_rays())
    t = (1.0 - origins[..., 0]) / dirs[..., 0]  # where each pixel's ray meets the end face's plane x = 1
    y0, z0 = (origins[..., k] + t * dirs[..., k] for k in (1, 2))
    on_face = (np.abs(z0) < 0.2) & (np.abs(y0) < 0.23)
    theta_t = np.arcsin(np.sin(np.radians(30.0)) / 1.5)
    boundary = 2.0 * np.tan(theta_t) - 0.75
    once, twice = on_face & (y0 > boundary + 0.03), on_face & (y0 < boundary - 0.03)
    assert once.sum() > 50 and twice.sum() > 50
    expected = (1.0 - _fresnel(np.cos(np.radians(30.0)), 1.5)) ** 2
    image = renderer.render(scene, "depth-search", internal_bounces=2, convex_exits=True).mean(axis=2)
    assert abs(image[once].mean() - expected) < 0.01 and image[once].min() > expected - 0.03, image[once]
    assert image[twice].max() < 0.03, image[twice]


def l_shaped_prism():
    """A closed prism of unit height over an L-shaped outline: solid, not convex."""
    from caustica.scene import Mesh

    outline = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    vertices = np.array([[x, y, z] for z in (0.0, 1.0) for x, y in outline])
    sides = [[i, (i + 1) % 6, 6 + (i + 1) % 6] for i in range(6)] + [[i, 6 + (i + 1) % 6, 6 + i] for i in range(6)]
    caps = [[0, 5, 4], [0, 4, 3], [0, 3, 1], [1, 3, 2]]
    return Mesh(vertices, None, np.array(sides + caps + [[6 + i for i in c[::-1]] for c in caps]))


def test_face_planes_of_convex_polyhedra_only():
    """A block's faces lie on six planes (outward normal, offset half its size); a tessellated sphere has
    hundreds (None: the depth search stays), a concave L-shaped prism is not convex (None)."""
    from caustica.scene.shapes import box

    planes = box((2.0, 0.5, 1.0)).face_planes(16)
    assert planes.shape == (6, 4)
    assert sorted(np.round(np.abs(planes[:, :3]) @ [1.0, 2.0, 3.0] * 10 + planes[:, 3], 3)) == [
        11.0, 11.0, 20.25, 20.25, 30.5, 30.5]
    assert sphere(1.0, 3).face_planes(16) is None
    assert l_shaped_prism().is_solid() and l_shaped_prism().face_planes(16) is None


def test_convex_exits_of_an_analytic_ball_follow_its_bounces_closer(sphere_and_exact):
    """Ours: on glass-sphere (an analytic sphere) the exact exits follow three internal bounces to 52.6 dB
    against full exact, the searched ones to 50.1 (measured, 96x96, 4 spp); at least 1 dB better and 51."""
    from caustica.metrics import psnr_linear

    small, scene, exact = sphere_and_exact
    searched = psnr_linear(small.render(scene, "depth-search", spp=4, internal_bounces=3), exact[16])
    convex = psnr_linear(small.render(scene, "depth-search", spp=4, internal_bounces=3, convex_exits=True), exact[16])
    assert convex > max(searched + 1.0, 51.0), (searched, convex)


def _prism_planes(segments, radius, half):
    """The side planes of shapes.cylinder's n-gon (vertices at phi = 2 pi k / n, (r sin phi, y, r cos phi)) and
    its two caps: (K, 4) outward unit normals and offsets."""
    phi = 2.0 * np.pi * (np.arange(segments) + 0.5) / segments
    sides = np.column_stack([np.sin(phi), np.zeros(segments), np.cos(phi), np.full(segments, radius * np.cos(np.pi / segments))])
    return np.vstack([sides, [[0.0, 1.0, 0.0, half], [0.0, -1.0, 0.0, half]]])


def _smooth_normal(points, nearest, segments):
    """The mesh's interpolated normal at points on plane ``nearest``: a cap's plane normal, or on a side facet
    the point's own radial direction (the facet's corner normals are radial, and their blend at a point of the
    chord points along it)."""
    radial = points * [1.0, 0.0, 1.0]
    cap = np.where(nearest == segments, 1.0, -1.0)[:, None] * [0.0, 1.0, 0.0]
    return np.where((nearest < segments)[:, None], radial / np.linalg.norm(radial, axis=1, keepdims=True), cap)


def _refracted(d, n, eta):
    """Snell's law for unit d and unit n facing against it; zero where light reflects totally."""
    cos_i = -np.einsum("ij,ij->i", d, n)
    k = 1.0 - eta ** 2 * (1.0 - cos_i ** 2)
    t = eta * d + (eta * cos_i - np.sqrt(np.maximum(k, 0.0)))[:, None] * n
    return np.where((k > 0.0)[:, None], t, 0.0)


def prism_exit_directions(scene, segments, radius, half, ior, margin=0.02):
    """Closed form of the directions leaving a smooth-shaded n-gon prism (shapes.cylinder) at the origin after
    two refractions (reflected where the light reflects totally at the exit, as depth-search's exit direction
    is), per pixel centre, and where entry and exit are far (``margin``) from the rims (H, W bool)."""
    planes = _prism_planes(segments, radius, half)
    origins, dirs = (a[:, :, 0].reshape(-1, 3) for a in scene.camera.primary_rays())
    rate = dirs @ planes[:, :3].T
    t = (planes[:, 3] - origins @ planes[:, :3].T) / np.where(np.abs(rate) > 1e-12, rate, 1e-12)
    t_in = np.where(rate < 0, t, -np.inf).max(axis=1)
    t_out = np.where(rate > 0, t, np.inf).min(axis=1)
    p1 = origins + t_in[:, None] * dirs
    entry = np.argmax(np.where(rate < 0, t, -np.inf), axis=1)
    n1 = _smooth_normal(p1, entry, segments)
    t1 = _refracted(dirs, n1, 1.0 / ior)
    rate2 = t1 @ planes[:, :3].T
    t2 = (planes[:, 3] - p1 @ planes[:, :3].T) / np.where(np.abs(rate2) > 1e-12, rate2, 1e-12)
    ahead = np.where(rate2 > 1e-9, t2, np.inf)
    leave = np.argmin(ahead, axis=1)
    p2 = p1 + ahead.min(axis=1)[:, None] * t1
    n2 = _smooth_normal(p2, leave, segments)
    t_exit = _refracted(t1, -n2, ior)
    reflected = t1 - 2.0 * np.einsum("ij,ij->i", t1, n2)[:, None] * n2
    t_exit = np.where((np.einsum("ij,ij->i", t_exit, t_exit) > 0.5)[:, None], t_exit, reflected)  # TIR: reflected
    # Far from the rims, where the normal jumps between side and cap: the planes of the other kind at least margin away.
    def clear(p, own):
        gap = planes[:, 3] - p @ planes[:, :3].T
        side = own < segments
        return np.where(side, gap[:, segments:].min(axis=1), gap[:, :segments].min(axis=1)) > margin
    ok = (t_in < t_out) & (-np.einsum("ij,ij->i", dirs, n1) > 0.2) & clear(p1, entry) & clear(p2, leave)
    height, width = scene.camera.size[1], scene.camera.size[0]
    return t_exit.reshape(height, width, 3), ok.reshape(height, width)


@pytest.mark.parametrize("segments", [8, 64])
def test_convex_exits_of_a_smooth_prism_match_the_closed_form(renderer, segments):
    """Ours: shapes.cylinder(0.6, 0.8, n) is convex glass of n + 2 planes whose side is smooth-shaded; its exits are
    exact (Mesh.face_planes, up to MAX_CONVEX_PLANES) with the mesh's interpolated normal there
    (Mesh.face_plane_normals), so the light leaves as the closed form has it: through the prism's planes, with the
    radial normal on a side facet. Seen from 35 degrees above, through the top and the side, out of the side and
    the bottom (or reflected there totally). Measured (64x64, mean / p95 degrees): 8 sides 0.011 / 0.0003, 64
    sides 0.0001 / 0.0002; before, 10.2 / 61 (8 sides: each facet's flat normal) and 0.045 / 0.048 (64: over 16
    planes, so searched in screen space, as convex_exits=False gives)."""
    from caustica.scene.shapes import cylinder

    view = np.array([0.0, np.sin(np.radians(35.0)), np.cos(np.radians(35.0))])
    camera = Camera(position=list(6.0 * view + [0.35, 0.0, 0.0]), look_at=[0.0, -0.05, 0.0], fov_y=16.0,
                    size=(64, 64))
    scene = Scene(camera=camera, objects=[SceneObject("prism", cylinder(0.6, 0.8, segments), Glass(ior=1.5))],
                  environment=procedural_environment("sky-checker"))
    expected, ok = prism_exit_directions(scene, segments, 0.6, 0.4, 1.5)
    dirs, valid = renderer.exit_directions(scene, "depth-search", convex_exits=True)
    assert (ok & valid).sum() > 1500, (ok.sum(), valid.sum())
    error = angular_error(dirs, expected, (valid, ok))
    assert error["mean_deg"] < 0.02 and error["p95_deg"] < 0.005, error


def test_face_solid_finds_a_lens_spheres_and_rim():
    """Mesh.face_solid: a biconcave lens of aperture a, centre thickness t and edge thickness e is the outside of
    two balls of radius R = (a^2 + s^2) / 2s (s = (e - t) / 2) centred on its axis at +-(t / 2 + R), inside its
    rim's cylinder of radius a; a biconvex lens the inside of two balls. A torus, an L-shaped prism and a lens
    too coarse for its spheres to stand for its facets (8 sides) are no such solid."""
    from caustica.scene.shapes import biconcave_lens, biconvex_lens, torus

    a, t, e = 0.3, 0.04, 0.16
    s = (e - t) / 2.0
    radius = (a * a + s * s) / (2.0 * s)
    planes, _, quadrics = biconcave_lens(a, t, e, 64, 16).face_solid(128, 4)
    balls, rims = quadrics[quadrics[:, 7] == 0.0], quadrics[quadrics[:, 7] == 1.0]
    assert len(planes) == 0 and len(balls) == 2 and len(rims) == 1
    assert np.allclose(np.sort(balls[:, 2]), [-(t / 2.0 + radius), t / 2.0 + radius], atol=1e-4)
    assert np.allclose(balls[:, :2], 0.0, atol=1e-5) and np.allclose(balls[:, 3], -radius, atol=1e-4)
    assert np.allclose(np.abs(rims[0, 4:7]), [0.0, 0.0, 1.0], atol=1e-6) and abs(rims[0, 3] - a) < 2e-3
    _, _, convex = biconvex_lens(a, e, 0.0, 64, 16).face_solid(128, 4)
    radius = (a * a + (e / 2.0) ** 2) / e
    assert len(convex) == 2 and np.allclose(convex[:, 3], radius, atol=1e-4)
    assert torus(1.0, 0.3).face_solid(128, 4) is None
    assert biconcave_lens(a, t, e, 8, 16).face_solid(128, 4) is None
    assert l_shaped_prism().face_solid(16, 4) is None


def test_a_lens_read_back_from_gltf_keeps_its_exact_exits(tmp_path):
    """A user's lens arrives as a glTF mesh: spectacle-concave written to .glb and read back is still two concave
    balls and a cylinder, at the same place (convex_shape)."""
    from caustica.passes.shading.convex_exits import convex_shape
    from caustica.scene.io import export_scene, load_scene

    scene = caustica.load_scene("spectacle-concave")
    read = load_scene(export_scene(scene, tmp_path / "lens.glb"))
    before, after = (convex_shape(next(o for o in s.objects if o.material.kind == "glass")) for s in (scene, read))
    assert after is not None and len(after.planes) == 0
    assert np.allclose(after.quadrics, before.quadrics, atol=1e-4)
    assert sorted(np.sign(after.quadrics[:, 3]) * (1 + after.quadrics[:, 7])) == [-1.0, -1.0, 2.0]


def test_a_lens_with_smoothed_rim_normals_keeps_the_search():
    """A lens whose rim is welded to its caps with averaged normals (as "shade smooth" exports it) is shaded with
    normals tilted up to 45 degrees off the spheres' near the rim, which exact and Mitsuba follow; its faces there
    fit no sphere by their normals, so it is no solid (Mesh.face_solid) and keeps the depth search. Measured: the
    spheres' own normals on those faces would put a tilted biconcave lens at 19.6 dB of exact with 2 bounces,
    against the search's 25.7."""
    from caustica.scene import Mesh
    from caustica.scene.shapes import biconcave_lens

    mesh = biconcave_lens(0.3, 0.04, 0.16, 64, 16)
    _, first, merged = np.unique(np.round(mesh.vertices / 1e-6).astype(np.int64), axis=0, return_index=True,
                                 return_inverse=True)
    merged = merged.ravel()
    normals = np.zeros((len(first), 3))
    np.add.at(normals, merged, mesh.normals.astype(np.float64))
    smoothed = Mesh(mesh.vertices[first], normals / np.linalg.norm(normals, axis=1, keepdims=True), merged[mesh.faces])
    assert smoothed.is_solid() and len(smoothed.vertices) < len(mesh.vertices)
    assert mesh.face_solid(128, 4) is not None and smoothed.face_solid(128, 4) is None


def tilted_lens(concave: bool, view_deg: float) -> Scene:
    """A thick lens of IOR 1.6 turned 10 and 20 degrees, seen from 0.9 away at ``view_deg`` off its axis."""
    from caustica.scene import Transform
    from caustica.scene.shapes import biconcave_lens, biconvex_lens

    mesh = biconcave_lens(0.3, 0.04, 0.16, 64, 16) if concave else biconvex_lens(0.3, 0.16, 0.02, 64, 16)
    view = np.radians(view_deg)
    camera = Camera(position=[0.9 * np.sin(view), 0.1, 0.9 * np.cos(view)], look_at=[0.0, 0.0, 0.0], fov_y=45.0,
                    size=(96, 96))
    return Scene(camera=camera, objects=[SceneObject("lens", mesh, Glass(ior=1.6), Transform(rotation=[10.0, 20.0, 0.0]))],
                 environment=procedural_environment("sky-checker"))


@pytest.mark.parametrize("concave", [True, False])
def test_convex_exits_of_a_lens_match_exact(renderer, concave):
    """Ours: a lens's exits are exact on its spheres and rim (Mesh.face_solid), so on the paths that cross two
    interfaces the light leaves as exact (Embree, on the 64 x 16 facets) has it, where the depth search strays
    at the rims. Measured (96x96, mean / p95 degrees): concave 0.0055 / 0.019, convex 0.0049 / 0.018; searched
    0.26 / 0.0066 and 0.37 / 0.0057."""
    scene = tilted_lens(concave, 35.0)
    reference, two_interfaces = exact_exit_directions(scene, max_interfaces=2)
    errors = {}
    for exact_exits in (True, False):
        dirs, valid = renderer.exit_directions(scene, "depth-search", convex_exits=exact_exits)
        errors[exact_exits] = angular_error(dirs, reference, (valid, two_interfaces))
    assert errors[True]["count"] > 2500, errors
    assert errors[True]["mean_deg"] < 0.02 and errors[True]["p95_deg"] < 0.05, errors
    assert errors[True]["mean_deg"] < 0.2 * errors[False]["mean_deg"], errors


def test_convex_exits_follow_a_concave_lens_bounces(renderer):
    """Ours: in a thick concave lens much of the light reflects at its rim and faces before it leaves; with exact
    exits two internal bounces come to 34.6 dB of exact (96x96, 4 spp; searched in screen space 25.7), four to
    37.3 (26.1). At least 32 and 6 dB better."""
    from caustica.metrics import psnr_linear

    scene = tilted_lens(True, 35.0)
    exact = renderer.render(scene, "exact", 4)
    ours = psnr_linear(renderer.render(scene, "depth-search", 4, internal_bounces=2, convex_exits=True), exact)
    searched = psnr_linear(renderer.render(scene, "depth-search", 4, internal_bounces=2), exact)
    assert ours > 32.0 and ours > searched + 6.0, (ours, searched)


@pytest.mark.parametrize("meniscus", [False, True])
def test_convex_exits_of_lenses_not_tuned_on(renderer, meniscus):
    """Ours, on lenses of other forms than the presets': a plano-convex lens is a plane, a ball and a cylinder; a
    meniscus a ball's inside, another's outside and a cylinder (Mesh.face_solid). Tilted, seen 30 degrees off axis:
    exits on two-interface paths against exact (mean degrees) 0.00001 / 0.0018, searched 0.14 / 0.41; with 2
    internal bounces 49.4 / 38.3 dB of exact, searched 40.5 / 33.3 (96x96, measured)."""
    from caustica.metrics import psnr_linear
    from caustica.passes.shading.convex_exits import convex_shape
    from caustica.scene import Transform
    from caustica.scene.shapes import lens as spherical_lens

    # shapes.lens: a meniscus (convex front, concave back) or a plano-convex lens, aperture 0.3.
    mesh = spherical_lens(0.3, 0.6, 0.78, 0.12, 64, 16) if meniscus else spherical_lens(0.3, 0.545, 0.0, 0.15, 64, 16)
    lens = SceneObject("lens", mesh, Glass(ior=1.55), Transform(rotation=[-15.0, 25.0, 5.0]))
    shape = convex_shape(lens)
    assert len(shape.planes) == (0 if meniscus else 1)
    assert sorted(np.sign(shape.quadrics[:, 3]) * (1 + shape.quadrics[:, 7])) == ([-1.0, 1.0, 2.0] if meniscus else [1.0, 2.0])
    view = np.radians(30.0)
    camera = Camera(position=[0.85 * np.sin(view), -0.1, 0.85 * np.cos(view)], look_at=[0.0, 0.0, 0.0], fov_y=45.0,
                    size=(96, 96))
    scene = Scene(camera=camera, objects=[lens], environment=procedural_environment("sky-checker"))
    reference, two_interfaces = exact_exit_directions(scene, max_interfaces=2)
    errors = {}
    for exact_exits in (True, False):
        dirs, valid = renderer.exit_directions(scene, "depth-search", convex_exits=exact_exits)
        errors[exact_exits] = angular_error(dirs, reference, (valid, two_interfaces))
    assert errors[True]["count"] > 4000 and errors[True]["mean_deg"] < 0.1, errors
    assert errors[True]["mean_deg"] < 0.25 * errors[False]["mean_deg"], errors
    exact = renderer.render(scene, "exact", 4)
    ours = psnr_linear(renderer.render(scene, "depth-search", 4, internal_bounces=2, convex_exits=True), exact)
    searched = psnr_linear(renderer.render(scene, "depth-search", 4, internal_bounces=2), exact)
    assert ours > searched + 2.0, (ours, searched)


def test_face_plane_normals_are_the_meshes_shading_normals():
    """Mesh.face_plane_normals: a block's flat faces have constant fields (their plane normals); a 64-sided
    cylinder's side facets give at any point of the facet the radial direction, its caps +-y; a plane whose vertex
    normals fit no affine field (a flat square with one corner's normal tilted) gives None."""
    from caustica.scene import Mesh
    from caustica.scene.shapes import box, cylinder

    planes, fields = box((2.0, 0.5, 1.0)).face_planes(16), box((2.0, 0.5, 1.0)).face_plane_normals(16)
    assert np.allclose(fields[:, :, :3], 0.0) and np.allclose(fields[:, :, 3], planes[:, :3])
    mesh = cylinder(0.55, 0.8, 64)
    planes, fields = mesh.face_planes(128), mesh.face_plane_normals(128)
    assert planes.shape == (66, 4) and fields.shape == (66, 3, 4)
    angle = 2.0 * np.pi * 10.3 / 64  # inside facet 10
    point = np.array([0.55 * np.cos(np.pi / 64) / np.cos(angle - 2.0 * np.pi * 10.5 / 64) * np.sin(angle), 0.1,
                      0.55 * np.cos(np.pi / 64) / np.cos(angle - 2.0 * np.pi * 10.5 / 64) * np.cos(angle)])
    k = int(np.argmax(planes[:, :3] @ point - planes[:, 3]))
    normal = fields[k] @ np.append(point, 1.0)
    assert abs(planes[k, :3] @ point - planes[k, 3]) < 1e-6  # float32 vertices
    assert np.allclose(normal / np.linalg.norm(normal), [np.sin(angle), 0.0, np.cos(angle)], atol=1e-6)
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1], [0.5, -1, 0.5]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3], [0, 4, 1], [1, 4, 2], [2, 4, 3], [3, 4, 0]])[:, ::-1]
    normals = np.array([[0, 1, 0], [0, 1, 0], [0, 1, 0], [0.3, 0.954, 0], [0, -1, 0]], float)
    pyramid = Mesh(vertices, normals, faces)
    assert pyramid.face_planes(16) is not None and pyramid.face_plane_normals(16) is None


def test_same_image_at_any_scale_of_the_scene(renderer):
    """A lens 2 cm across seen from 4 cm (a spectacle lens modelled in metres) and the same scene in
    any larger unit give one image: the dT corrections stop at a fraction of the glass's size, not at
    a length in scene units. Measured: 49.8 dB between scale 0.01 and 1 (float rounding); 26.1 dB when
    the tolerance was 1e-3 scene units, 4 % of this lens's radius at scale 0.01."""
    from caustica.metrics import psnr_linear
    from caustica.scene import Transform
    from caustica.scene.shapes import biconcave_lens

    def lens_at(scale: float) -> Scene:
        camera = Camera(position=[0.0, 0.0, 4.0 * scale], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(64, 64),
                        near=0.05 * scale, far=100.0 * scale)
        lens = SceneObject("lens", biconcave_lens(1.0, 0.15, 0.6), Glass(ior=1.5),
                           Transform(scale=(scale,) * 3, rotation=(35.0, 20.0, 0.0)))
        return Scene(camera=camera, objects=[lens], environment=procedural_environment("sky-checker"))

    one, small = (renderer.render(lens_at(k), "depth-search", 4, internal_bounces=2) for k in (1.0, 0.01))
    assert psnr_linear(small, one) >= 45.0
