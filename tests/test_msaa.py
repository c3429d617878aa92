"""Multisampled outlines (``antialias="msaa"``, passes/post/subpixel.py): a straight edge resolves to the
coverage of 4 samples per pixel, the inside of surfaces is left bit for bit as at 1 spp, rendered outlines
move towards the supersampled image, every raster technique takes it, and a context without
multisampling is refused in one line."""
from __future__ import annotations

import numpy as np
import pytest
from test_graph import TECHNIQUE_SCENES

import caustica
from caustica import Renderer
from caustica.errors import RenderOptionError
from caustica.metrics.images import psnr_linear
from caustica.passes.post.subpixel import SAMPLES
from caustica.scene import Camera, Diffuse, DirectionalLight, Environment, Mesh, Mirror, Scene, SceneObject
from caustica.scene.environment import procedural_environment
from caustica.scene.presets import PRESETS
from caustica.scene.shapes import sphere, torus

SIZE = (96, 64)
BACKGROUND, SURFACE = 1.0, 0.25  # the constant environment, the flat grey triangle lit by it alone


def half_plane_scene(corner_x: float, corner_y: float, slope_x: float) -> Scene:
    """A flat grey triangle at z = -4, so large that one of its edges alone crosses the frame: from
    (corner_x, corner_y) along (1, slope_x) in world units, the triangle below it; a constant white
    environment, no lights, so both sides are flat colours."""
    direction = np.array([1.0, slope_x, 0.0]) / np.hypot(1.0, slope_x)
    below = np.array([direction[1], -direction[0], 0.0])
    a = np.array([corner_x, corner_y, -4.0]) - 100.0 * direction
    b = a + 200.0 * direction
    c = a + 100.0 * direction + 100.0 * below
    vertices = np.array([a, b, c], np.float32)
    faces = np.array([[0, 2, 1]], np.int32) if np.cross(b - a, c - a)[2] < 0 else np.array([[0, 1, 2]], np.int32)
    normals = np.tile(np.array([0.0, 0.0, 1.0], np.float32), (3, 1))
    triangle = SceneObject("triangle", Mesh(vertices, normals, faces, name="triangle"), Diffuse(color=[1.0] * 3))
    camera = Camera(position=[0.0, 0.0, 0.0], look_at=[0.0, 0.0, -1.0], fov_y=40.0, size=SIZE)
    white = Environment(np.full((8, 16, 3), BACKGROUND, np.float32), source="test:white")
    return Scene(camera=camera, objects=[triangle], lights=[], environment=white)


def exact_coverage(scene: Scene, samples: int = 64) -> np.ndarray:
    """(H, W) area fraction of each pixel the triangle covers, from its vertices projected to pixels,
    ``samples`` x ``samples`` points per pixel (row 0 at the top)."""
    width, height = scene.camera.size
    mesh = scene.objects[0].mesh
    clip = np.c_[mesh.vertices[mesh.faces[0]], np.ones(3)] @ scene.camera.clip_from_world().T
    ndc = clip[:, :2] / clip[:, 3:]
    px = np.c_[(ndc[:, 0] + 1.0) * 0.5 * width, (1.0 - ndc[:, 1]) * 0.5 * height]  # y down
    s = (np.arange(samples) + 0.5) / samples
    y = (np.arange(height)[:, None] + s[None, :]).reshape(-1)[:, None]
    x = (np.arange(width)[:, None] + s[None, :]).reshape(-1)[None, :]
    sides = []
    for i in range(3):  # inside: the same side of every edge as the third vertex
        (x0, y0), (x1, y1), (x2, y2) = px[i], px[(i + 1) % 3], px[(i + 2) % 3]
        side = (x1 - x0) * (y - y0) - (y1 - y0) * (x - x0)
        sides.append(side * np.sign((x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0)) > 0)
    inside = (sides[0] & sides[1] & sides[2]).astype(np.float64)
    return inside.reshape(height, samples, width, samples).mean(axis=(1, 3))


@pytest.mark.parametrize("corner_x, corner_y, slope_x", [(0.1, 0.3, 0.17), (-0.2, -0.1, -0.45), (0.05, 0.0, 2.7),
                                                         (0.3, 0.2, -0.04)])
def test_a_straight_edge_resolves_to_its_coverage_within_one_sample(renderer, corner_x, corner_y, slope_x):
    """Each pixel's grey level, read as the fraction (value - background) / (surface - background), is
    the edge's exact area fraction within 1 / SAMPLES (measured: at most 0.13 to 0.22 over these four
    edges); at 1 spp it is off by up to half a pixel (0.48 to 0.50). Away from the edge nothing changes."""
    scene = half_plane_scene(corner_x, corner_y, slope_x)
    exact = exact_coverage(scene)
    aliased = renderer.render(scene, "plain", 1)[..., 0]
    surface = float(aliased[exact == 1.0].mean())
    assert np.ptp(aliased[exact == 1.0]) < 1e-6 and surface < 0.9 * BACKGROUND  # two flat colours
    fraction = lambda image: (image - BACKGROUND) / (surface - BACKGROUND)  # noqa: E731
    resolved = renderer.render(scene, "plain", 1, antialias="msaa")[..., 0]
    error_before = np.abs(fraction(aliased) - exact)
    error_after = np.abs(fraction(resolved) - exact)
    assert error_before.max() > 0.4
    assert error_after.max() <= 1.0 / SAMPLES, error_after.max()
    assert error_after.mean() < 0.5 * error_before.mean()
    # The resolve gives a pixel whole samples: multiples of 1 / SAMPLES of the two colours.
    steps = fraction(resolved) * SAMPLES
    assert np.allclose(steps, np.round(steps), atol=1e-3)
    away = (exact == 0.0) | (exact == 1.0)
    away &= np.roll(away, 1, 0) & np.roll(away, -1, 0) & np.roll(away, 1, 1) & np.roll(away, -1, 1)
    assert np.array_equal(resolved[away], aliased[away])


def test_the_inside_of_surfaces_is_bit_identical_to_one_sample(renderer):
    """A mirror ball and a torus over a floor (a scene of our own): every pixel more than a pixel from
    an outline (object ids and depth from the labels) keeps its 1-spp colour bit for bit; only outline
    pixels change, and some do."""
    scene = caustica.load_scene("glass-sphere")
    scene.camera.size = (80, 60)
    scene.objects = [SceneObject("ball", sphere(0.6, 4), Mirror()), SceneObject("ring", torus(0.8, 0.2, 48, 24),
                                                                                Diffuse(color=[0.8, 0.3, 0.2]))]
    scene.objects[1].transform.position = np.array([1.2, 0.1, -0.5])
    scene.objects[1].transform.rotation = np.array([70.0, 0.0, 0.0])
    plain, layers = renderer.render(scene, "env-map", 1, labels=["id", "depth"])
    msaa = renderer.render(scene, "env-map", 1, antialias="msaa")
    ids, depth = layers["id"], np.nan_to_num(layers["depth"])  # the background's depth is not a number
    outline = np.zeros(ids.shape, bool)
    for axis in (0, 1):
        jump = (np.diff(ids, axis=axis) != 0) | (np.abs(np.diff(depth, axis=axis)) > 0.02 * depth.max())
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        outline[tuple(lo)] |= jump
        outline[tuple(hi)] |= jump
    near = outline.copy()
    for shift in ((1, 0), (-1, 0), (0, 1), (0, -1)):
        near |= np.roll(outline, shift, axis=(0, 1))
    changed = np.any(plain != msaa, axis=-1)
    assert changed.any()
    assert not np.any(changed & ~near), np.argwhere(changed & ~near)[:5]


def test_outlines_move_towards_supersampling():
    """A diffuse torus and ball, sun-lit, in the sky checker (not a preset; its error at 1 spp is in
    the outlines): against 64 spp, msaa gains at least 4 dB (measured: 32.9 -> 38.6 dB; edge 32.2,
    4 spp 42.1)."""
    camera = Camera(position=[0.4, 0.5, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=40.0, size=(96, 72))
    ring = SceneObject("ring", torus(0.6, 0.2, 48, 24), Diffuse(color=[0.2, 0.5, 0.9]))
    ball = SceneObject("clay", sphere(0.5, 4), Diffuse(color=[0.9, 0.2, 0.1]))
    ring.transform.position, ball.transform.position = np.array([-0.5, 0.0, 0.0]), np.array([0.8, -0.2, 0.3])
    ring.transform.rotation = np.array([60.0, 20.0, 0.0])
    scene = Scene(camera=camera, objects=[ring, ball], lights=[DirectionalLight(direction=[-0.3, -1.0, -0.4])],
                  environment=procedural_environment("sky-checker"))
    with Renderer((96, 72)) as renderer:
        reference = renderer.render(scene, "env-map", 64)
        one = psnr_linear(renderer.render(scene, "env-map", 1), reference)
        msaa = psnr_linear(renderer.render(scene, "env-map", 1, antialias="msaa"), reference)
    assert msaa - one >= 4.0, (one, msaa)


@pytest.mark.parametrize("technique", sorted(TECHNIQUE_SCENES))
def test_every_raster_technique_takes_msaa(technique):
    """Each GPU technique's outline pixels, and only a few pixels, change; at 4 spp too (test_graph's
    TECHNIQUE_SCENES names every GPU technique)."""
    scene = PRESETS[TECHNIQUE_SCENES[technique]]()
    with Renderer((48, 40)) as renderer:
        for spp in (1, 4):
            plain = renderer.render(scene, technique, spp)
            msaa = renderer.render(scene, technique, spp, antialias="msaa")
            assert np.isfinite(msaa).all()
            changed = float(np.mean(np.any(plain != msaa, axis=-1)))
            assert 0.0 < changed < 0.35, (spp, changed)


def test_a_context_without_multisampling_is_refused(renderer, monkeypatch):
    import moderngl

    monkeypatch.setattr(moderngl.Context, "max_samples", property(lambda ctx: 1))
    with pytest.raises(RenderOptionError, match=r"^antialias 'msaa' needs 4 samples per pixel and this GL "
                                                r"context offers 1; use antialias 'edge' or spp 4 instead$"):
        renderer.render(caustica.load_scene("glass-sphere"), "plain", antialias="msaa")


def test_cpu_techniques_ignore_it():
    """exact traces its own samples; msaa, like edge, applies to rasterized images only."""
    scene = caustica.load_scene("glass-sphere")
    with Renderer((24, 18)) as renderer:
        assert np.array_equal(renderer.render(scene, "exact", 1), renderer.render(scene, "exact", 1, antialias="msaa"))


def test_cli_renders_with_msaa_and_refuses_without_multisampling(tmp_path, capsys, monkeypatch):
    """``caustica render --antialias msaa`` writes the msaa image; without multisampling: one line, exit 2."""
    import moderngl
    from test_cli import assert_one_line_error, run_cli

    from caustica.images import read_image

    out = tmp_path / "door.exr"
    code, _, _ = run_cli(["render", "door-mirror", "-o", out, "--size", "48x40", "--frames", "1", "--technique",
                          "env-map", "--antialias", "msaa"], capsys)
    assert code == 0
    with Renderer((48, 40)) as renderer:
        expected = renderer.render(caustica.load_scene("door-mirror"), "env-map", 1, antialias="msaa")
    assert np.allclose(read_image(out), expected, atol=1e-3)
    monkeypatch.setattr(moderngl.Context, "max_samples", property(lambda ctx: 2))
    code, _, err = run_cli(["render", "door-mirror", "-o", tmp_path / "no.png", "--size", "48x40", "--antialias",
                            "msaa"], capsys)
    assert_one_line_error(code, err, "antialias 'msaa' needs 4 samples per pixel", "use antialias 'edge' or spp 4")
    assert not (tmp_path / "no.png").exists()


def test_its_targets_count_in_the_frame_memory_estimate():
    """msaa adds an rg32f target (8 bytes), a 4-sample one (32) and a 4-sample 32-bit depth buffer (16): 56 bytes
    a sample (spp 4 at 320x240: 640x480 samples); edge and none add nothing."""
    from caustica import frame_limits

    for size, spp, samples in (((96, 64), 1, 96 * 64), ((320, 240), 4, 640 * 480)):
        plain = frame_limits.target_bytes(size, spp)
        assert frame_limits.target_bytes(size, spp, "msaa") - plain == 56 * samples
        assert frame_limits.target_bytes(size, spp, "edge") == plain == frame_limits.BYTES_PER_SAMPLE * samples


def test_a_frame_that_fits_only_without_msaa_is_refused_with_it(monkeypatch):
    """The renderer checks the estimate with the frame's antialias mode, before it draws: a budget that holds
    the frame's targets, its one shadow map (64^2 texels of 8 bytes) and half of msaa's 56 bytes a sample."""
    from caustica import frame_limits

    scene = caustica.load_scene("glass-sphere")
    budget = (frame_limits.BYTES_PER_SAMPLE + 28) * SIZE[0] * SIZE[1] + 64 * 64 * 8
    monkeypatch.setattr(frame_limits, "MEMORY_BUDGET", budget)
    with Renderer(SIZE) as renderer:
        assert renderer.render(scene, "plain", shadow_map_size=64).shape == (SIZE[1], SIZE[0], 3)
        with pytest.raises(RenderOptionError, match=r"^a 96x64 frame at 1 spp \(1x1 samples a pixel\) "
                                                    r"with msaa needs about .* above the GL memory budget"):
            renderer.render(scene, "plain", antialias="msaa", shadow_map_size=64)
