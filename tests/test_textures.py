"""Textured diffuse receivers (issue 20, materials): Diffuse.texture looked up at Mesh.uvs by every raster
technique and by the exact oracle, in one convention (scene/textures.py: glTF TEXCOORD_0, (0, 0) the
image's top-left corner, row 0 its top row, GL texel centres, bilinear, repeating).

Scenes are 96x72. The floor is a 4 x 4 plane (u along +X, v along +Z) with a texture of 4 x 4 coloured
squares (8 texels each), magnified on screen, so GL's mipmaps stay at level 0 and GPU and CPU lookups agree.
"""
from __future__ import annotations

import dataclasses
import struct
import zlib

import numpy as np
import pytest
from PIL import Image

import caustica
from caustica.cli import main as cli_main
from caustica.errors import SceneError
from caustica.metrics.images import psnr_linear
from caustica.renderer import Renderer
from caustica.scene import (Camera, Diffuse, Glass, Mirror, PointLight, Scene, SceneObject, Transform,
                            procedural_environment)
from caustica.scene.mesh import Mesh
from caustica.scene.shapes import plane, sphere
from caustica.scene.textures import checker, load_texture, sample_texture
from caustica.techniques.exact import ExactParams

SIZE = (96, 72)
FLOOR = 4.0  # the floor's side (scene units)
RNG = np.random.default_rng(3)
SQUARES = np.repeat(np.repeat(RNG.uniform(0.1, 0.95, (4, 4, 3)), 8, axis=0), 8, axis=1).astype(np.float32)
GREY = [0.8] * 3  # plain's override colour: plain keeps a receiver's texture over it
# exact's own caustics off where it has them (raster techniques here render none)
EXACT_WITHOUT_CAUSTICS = ({"caustic_photons": 0} if "caustic_photons" in {f.name for f in dataclasses.fields(ExactParams)}
                          else {})
FRONT = Camera(position=[0.0, 3.0, 3.5], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=SIZE)
LIGHT = PointLight([1.0, 4.0, 1.0], [30.0] * 3)


def floor(texture=SQUARES, color=GREY) -> SceneObject:
    return SceneObject("floor", plane((FLOOR, FLOOR)), Diffuse(list(color), texture=texture))


def flat_floor() -> SceneObject:
    """The floor with the texture's mean colour as a flat albedo."""
    return floor(None, np.asarray(GREY) * SQUARES.reshape(-1, 3).mean(axis=0))


def scene_of(objects, camera=FRONT, light=LIGHT, environment="sky-checker") -> Scene:
    env = procedural_environment(environment)
    env.filter = "bilinear"  # per-sample comparisons with exact: the same environment lookup per sample
    return Scene(camera=camera, objects=objects, lights=[light], environment=env)


def sphere_mask(camera: Camera, center, radius: float) -> np.ndarray:
    """Pixels whose primary ray meets the sphere."""
    origin, direction = (a[:, :, 0] for a in camera.primary_rays())
    oc = origin - np.asarray(center, np.float64)
    b = np.einsum("hwk,hwk->hw", oc, direction)
    c = np.einsum("hwk,hwk->hw", oc, oc) - radius * radius
    return b * b - c > 0.0


def floor_uv(camera: Camera) -> np.ndarray:
    """Per pixel, the uv where the primary ray meets the floor plane y = 0."""
    origin, direction = (a[:, :, 0] for a in camera.primary_rays())
    hit = origin - (origin[..., 1] / direction[..., 1])[..., None] * direction
    return np.stack([hit[..., 0] / FLOOR + 0.5, hit[..., 2] / FLOOR + 0.5], axis=-1)


# The convention ------------------------------------------------------------------------------------


def test_lookup_convention_texel_centres_bilinear_and_repeat():
    texture = np.zeros((2, 4, 3), np.float32)
    texture[0, 0] = [1.0, 0.0, 0.0]  # top-left texel
    texture[1, 3] = [0.0, 0.0, 1.0]  # bottom-right texel
    uv = np.array([[0.125, 0.25],  # texel (0, 0)'s centre: (0 + 0.5) / 4, (0 + 0.5) / 2
                   [0.875, 0.75],  # texel (3, 1)'s centre
                   [1.125, -0.75],  # (0, 0) again, one period away in u and v
                   [0.0, 0.25],  # halfway between column 0 and (wrapping) column 3, row 0
                   [0.125, 0.5]])  # halfway between rows 0 and 1, column 0
    got = sample_texture(texture, uv)
    np.testing.assert_allclose(got, [[1, 0, 0], [0, 0, 1], [1, 0, 0], [0.5, 0, 0], [0.5, 0, 0]], atol=1e-12)


@pytest.mark.parametrize("turned", [False, True])
def test_red_quadrant_lands_in_the_same_corner_on_gpu_and_in_exact(renderer, turned):
    """uv (0, 0) is the image's top-left corner: the plane's -X, -Z corner. Seen from above with -Z up
    on the screen, a texture whose top-left quadrant is red shows red in the image's top-left quadrant;
    the floor turned 90 degrees about +Y (-X, -Z to -X, +Z), in the bottom-left one."""
    texture = np.full((8, 8, 3), 0.8, np.float32)
    texture[:4, :4] = [0.9, 0.05, 0.05]
    camera = Camera(position=[0.0, 6.0, 0.0], look_at=[0.0, 0.0, 0.0], up=[0.0, 0.0, -1.0], fov_y=40.0, size=SIZE)
    tile = floor(texture)
    tile.transform = Transform(rotation=[0.0, 90.0 if turned else 0.0, 0.0])
    scene = scene_of([tile], camera, PointLight([0.0, 3.0, 0.0], [20.0] * 3), "black")
    height, width = SIZE[1], SIZE[0]
    for image in (renderer.render(scene, "plain"), renderer.render(scene, "exact")):
        red = (image[..., 0] > 3.0 * image[..., 1]) & (image[..., 0] > 0.02)
        red = red[::-1] if turned else red
        rows, cols = np.nonzero(red)
        assert red.sum() > 100
        assert rows.max() < height / 2 and cols.max() < width / 2  # all of it in the top-left quadrant
        assert red[: height // 2, : width // 2].mean() > 0.4


# Direct view and exact ----------------------------------------------------------------------------


def test_plain_matches_exact_on_a_textured_floor_and_a_flat_albedo_does_not(renderer):
    """Known answer: both shade albedo / pi (direct + SH ambient) with the same lookup; measured 68.6 dB
    against 10.1 dB for the texture's mean colour as a flat albedo."""
    exact = renderer.render(scene_of([floor()]), "exact")
    textured = renderer.render(scene_of([floor()]), "plain")
    flat = renderer.render(scene_of([flat_floor()]), "plain")
    assert psnr_linear(textured, exact) > 50.0
    assert psnr_linear(flat, exact) < 20.0


def test_repeated_texture_wraps_alike_on_gpu_and_in_exact(renderer):
    """plane(repeat=(3, 2)): uvs up to 3 and 2, the texture repeating on the GPU (GL_REPEAT) as in exact
    (measured 41.0 dB; the far rows are minified there, where the mipmaps blur what exact aliases)."""
    tiled = SceneObject("floor", plane((FLOOR, FLOOR), repeat=(3.0, 2.0)), Diffuse(GREY, texture=SQUARES))
    assert np.allclose(tiled.mesh.uvs.max(axis=0), [3.0, 2.0])
    exact = renderer.render(scene_of([tiled]), "exact")
    assert psnr_linear(renderer.render(scene_of([tiled]), "plain"), exact) > 36.0
    assert psnr_linear(renderer.render(scene_of([floor()]), "plain"), exact) < 20.0  # untiled: 14.0 dB


def test_untextured_scenes_render_as_before(renderer):
    """uvs alone change nothing: a plane with uvs (no texture) renders bit-identically to the same mesh
    without them; a texture on a mesh without uvs is ignored (Diffuse's contract)."""
    with_uvs = plane((FLOOR, FLOOR))
    without = Mesh(with_uvs.vertices, with_uvs.normals, with_uvs.faces, name="plane")
    assert with_uvs.uvs is not None and without.uvs is None
    images = [renderer.render(scene_of([SceneObject("floor", mesh, Diffuse(GREY, texture=texture))]), "env-map")
              for mesh, texture in ((with_uvs, None), (without, None), (without, SQUARES))]
    assert np.array_equal(images[0], images[1]) and np.array_equal(images[0], images[2])


def test_toml_texture_file_and_procedural_checker(tmp_path, renderer):
    """texture = 'floor.png' (sRGB PNG, relative to the scene file) and texture = 'checker' load as linear
    images; the file's texels come back decoded from sRGB."""
    pixels = np.zeros((4, 4, 3), np.uint8)
    pixels[:2, :2] = [255, 0, 0]
    pixels[2:, 2:] = [188, 188, 188]  # sRGB 188 is linear 0.5029
    (tmp_path / "tex").mkdir()
    Image.fromarray(pixels).save(tmp_path / "tex" / "floor.png")
    (tmp_path / "s.toml").write_text(
        '[camera]\nsize = [32, 24]\n'
        '[[objects]]\nshape = "plane"\nrepeat = [2, 1]\nmaterial = { type = "diffuse", texture = "tex/floor.png" }\n'
        '[[objects]]\nshape = "box"\nposition = [0, 0.5, 0]\nmaterial = { type = "diffuse", texture = "checker" }\n')
    scene = caustica.load_scene(tmp_path / "s.toml")
    texture = scene.objects[0].material.texture
    np.testing.assert_allclose(texture[0, 0], [1.0, 0.0, 0.0], atol=1e-6)
    np.testing.assert_allclose(texture[3, 3], [0.5029] * 3, atol=1e-4)
    assert np.allclose(scene.objects[0].mesh.uvs.max(axis=0), [2.0, 1.0])
    np.testing.assert_array_equal(scene.objects[1].material.texture, checker())
    assert renderer.render(scene, "env-map").shape == (24, 32, 3)


def test_mesh_file_uvs_are_read_with_v_from_the_top(tmp_path, renderer):
    """An OBJ's vt has v upwards (v = 1 is the image's top row): the quad's far-left corner, vt (0, 1),
    becomes uv (0, 0), so the texture's red top-left quadrant shows in the image's top-left corner."""
    (tmp_path / "quad.obj").write_text("v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nvt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n"
                                       "f 1/1 4/4 3/3\nf 1/1 3/3 2/2\n")
    texture = np.full((8, 8, 3), 0.8, np.float32)
    texture[:4, :4] = [0.9, 0.05, 0.05]
    Image.fromarray((texture * 255).astype(np.uint8)).save(tmp_path / "red.png")
    (tmp_path / "s.toml").write_text(
        '[camera]\nposition = [0, 6, 0]\nup = [0, 0, -1]\nsize = [32, 24]\n[[lights]]\ntype = "point"\n'
        'position = [0, 3, 0]\n[[objects]]\nmesh = "quad.obj"\nmaterial = { type = "diffuse", texture = "red.png" }\n')
    scene = caustica.load_scene(tmp_path / "s.toml")
    mesh = scene.objects[0].mesh
    np.testing.assert_allclose(mesh.uvs[np.argmin(mesh.vertices[:, 0] + mesh.vertices[:, 2])], [0.0, 0.0])
    for image in (renderer.render(scene, "env-map"), renderer.render(scene, "exact")):
        red = image[..., 0] > 3.0 * image[..., 1]
        assert red[:12, :16].mean() > 0.4 and red[12:].sum() == 0 and red[:, 16:].sum() == 0


def test_embedded_bytes_decode_as_the_file_does(tmp_path):
    """decode_texture (a glTF's embedded image) gives what load_texture gives for the same PNG; a JPEG
    decodes from sRGB too (a flat sRGB 188 image is linear 0.503 within JPEG's rounding)."""
    from caustica.scene.textures import decode_texture

    Image.fromarray((SQUARES * 255).astype(np.uint8)).save(tmp_path / "a.png")
    np.testing.assert_array_equal(decode_texture((tmp_path / "a.png").read_bytes(), "image 0"),
                                  load_texture(tmp_path / "a.png"))
    Image.new("RGB", (16, 16), (188, 188, 188)).save(tmp_path / "b.jpg", quality=95)
    np.testing.assert_allclose(load_texture(tmp_path / "b.jpg"), 0.5029, atol=0.01)
    with pytest.raises(SceneError, match="cannot read image 0"):
        decode_texture(b"not an image", "image 0")


# Seen through glass and in mirrors ------------------------------------------------------------------


@pytest.mark.parametrize("technique, options, measured", [("impostors", {}, (25.0, 14.1)),
                                                           ("depth-search", {"nearby": "search-secant"}, (18.5, 14.1)),
                                                           ("depth-search", {"nearby": "planes"}, (25.0, 14.1))])
def test_textured_floor_through_a_glass_ball_matches_exact(renderer, technique, options, measured):
    """A black-and-white checker floor under a glass ball: in the ball's pixels (refraction and
    reflection of the floor) the textured render is closer to exact's than the render with the
    checker's mean grey as a flat albedo (``measured``: dB, textured and flat). Wyman's planes map the
    floor's uvs affinely onto the shader's rectangle."""
    board = checker(32, 4, dark=0.05, light=0.95)
    ball = SceneObject("ball", sphere(0.6, 4), Glass(1.5), Transform(position=[0.0, 0.6, 0.0]))
    behind = PointLight([0.5, 4.0, -2.5], [30.0] * 3)  # the ball's caustic lies in front of it, not seen through it
    exact = renderer.render(scene_of([floor(board), ball], light=behind), "exact", **EXACT_WITHOUT_CAUSTICS)
    mask = sphere_mask(FRONT, [0.0, 0.6, 0.0], 0.6)
    textured = psnr_linear(renderer.render(scene_of([floor(board), ball], light=behind), technique, **options), exact,
                           mask)
    mean = np.asarray(GREY) * board.reshape(-1, 3).mean(axis=0)
    flat = psnr_linear(renderer.render(scene_of([floor(None, mean), ball], light=behind), technique, **options), exact,
                       mask)
    assert mask.sum() > 300
    assert textured > flat + 3.0 and textured > measured[0] - 1.5


@pytest.mark.parametrize("technique", ["per-vertex", "impostors"])
def test_textured_floor_in_a_mirror(renderer, technique):
    """A mirror leaning over the floor shows it: per-vertex's reflection map and impostors' textures are
    shaded with the texture (measured 40.2 / 42.2 dB against exact, 20.6 dB with the flat albedo)."""
    camera = Camera(position=[0.0, 1.2, 3.5], look_at=[0.0, 0.5, -1.0], fov_y=45.0, size=SIZE)
    mirror = SceneObject("mirror", plane((3.0, 1.6), resolution=8), Mirror([0.95] * 3),
                         Transform(position=[0.0, 0.9, -1.4], rotation=[112.0, 0.0, 0.0]))
    light = PointLight([1.5, 6.0, -2.5], [30.0] * 3)  # behind the mirror: it reflects no light onto the floor
    # exact without its caustics: the light reaches the mirror's back, whose reflection (a caustic) neither
    # technique renders.
    exact = renderer.render(scene_of([floor(), mirror], camera, light), "exact", **EXACT_WITHOUT_CAUSTICS)
    textured = renderer.render(scene_of([floor(), mirror], camera, light), technique)
    flat = renderer.render(scene_of([flat_floor(), mirror], camera, light), technique)
    assert psnr_linear(textured, exact) > 32.0
    assert psnr_linear(flat, exact) < psnr_linear(textured, exact) - 10.0


# Caustics ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("technique", ["caustic-mapping", "photon-splats", "impostor-caustics", "transport-table"])
def test_caustic_light_is_scaled_by_the_texel_albedo(renderer, technique):
    """A ball focuses a point light onto a floor whose texture is 0.3 on the left half and 0.9 on the
    right, the caustic across the seam. Against the same floor with a white texture, each caustic pixel
    is scaled by its texel's albedo (the lookup at the pixel's floor point), on both sides."""
    halves = np.full((16, 16, 3), 0.9, np.float32)
    halves[:, :8] = 0.3
    ball = SceneObject("ball", sphere(0.5, 4), Glass(1.5), Transform(position=[0.0, 1.0, 0.0]))
    light = PointLight([0.0, 3.5, 0.0], [20.0] * 3)
    images = {name: renderer.render(scene_of([floor(texture), ball], light=light, environment="black"), name_tech)
              for name, texture, name_tech in (("halves", halves, technique), ("white", np.ones((1, 1, 3), np.float32),
                                                                               technique),
                                               ("direct", np.ones((1, 1, 3), np.float32), "env-map"))}
    caustic = (images["white"] - images["direct"])[..., 1] > 0.3
    caustic &= ~sphere_mask(FRONT, [0.0, 1.0, 0.0], 0.5)
    expected = sample_texture(halves, floor_uv(FRONT).reshape(-1, 2))[:, 1].reshape(caustic.shape)
    ratio = images["halves"][..., 1] / np.maximum(images["white"][..., 1], 1e-9)
    assert (caustic & (expected < 0.31)).sum() >= 8 and (caustic & (expected > 0.89)).sum() >= 8  # 12, 12 of 48
    np.testing.assert_allclose(ratio[caustic], expected[caustic], atol=1e-3)  # measured 3e-6


# GPU resources ----------------------------------------------------------------------------------


def test_texture_uploaded_once_per_content_and_released_with_the_device():
    from caustica.gpu.census import live_gl_names

    second = SceneObject("floor2", plane((1.0, 1.0)), Diffuse(GREY, texture=SQUARES.copy()),
                         Transform(position=[0.0, 0.01, 0.0]))
    with Renderer(SIZE) as renderer:
        renderer.render(scene_of([floor(), second]), "env-map")
        renderer.render(scene_of([floor(SQUARES.copy()), second]), "env-map")  # equal content, new arrays
        assert renderer.device.counts()["albedo_textures"] == 1
        renderer.render(scene_of([floor(checker()), second]), "env-map")
        assert renderer.device.counts()["albedo_textures"] == 2
        device = renderer.device
        names = live_gl_names(device.ctx)["total"]
    assert device.counts()["albedo_textures"] == 0
    assert live_gl_names(device.ctx)["total"] < names


def test_textures_unused_for_idle_frames_are_released_and_reloads_stay_flat(tmp_path):
    """A textured TOML scene reloaded every frame (new arrays, equal content) keeps one texture; once
    no frame draws it for IDLE_FRAMES frames, it goes, as idle meshes do."""
    from caustica.gpu.meshes import IDLE_FRAMES

    Image.fromarray((SQUARES * 255).astype(np.uint8)).save(tmp_path / "floor.png")
    (tmp_path / "s.toml").write_text('[camera]\nsize = [32, 24]\n[[lights]]\ntype = "point"\nposition = [0, 3, 0]\n'
                                     '[[objects]]\nshape = "plane"\nmaterial = { type = "diffuse", texture = "floor.png" }\n')
    with Renderer((32, 24)) as renderer:
        counts = []
        for _ in range(12):
            renderer.render(caustica.load_scene(tmp_path / "s.toml"), "env-map")
            counts.append(renderer.device.counts())
        assert counts[-1] == counts[3] and counts[-1]["albedo_textures"] == 1
        untextured = scene_of([floor(None)], FRONT.with_size(32, 24))
        for frame in range(IDLE_FRAMES + 1):
            renderer.render(untextured, "env-map")
            assert renderer.device.counts()["albedo_textures"] == (1 if frame < IDLE_FRAMES - 1 else 0)


# Bad input --------------------------------------------------------------------------------------


def _png_header_claiming(path, width: int, height: int) -> None:
    """A PNG whose header says width x height (its data is one 1x1 image's): decoding would be huge."""
    Image.new("RGB", (1, 1)).save(path)
    data = bytearray(path.read_bytes())
    ihdr = struct.pack(">II", width, height) + bytes(data[24:29])
    data[16:29] = ihdr
    data[29:33] = struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    path.write_bytes(bytes(data))


def test_bad_texture_files_are_one_line_scene_errors(tmp_path):
    (tmp_path / "cut.png").write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00")
    Image.new("RGB", (2, 2)).save(tmp_path / "image.gif")
    (tmp_path / "named.png").write_bytes((tmp_path / "image.gif").read_bytes())  # a GIF named .png
    _png_header_claiming(tmp_path / "huge.png", 20000, 20000)
    cases = {"missing.png": "not found", "cut.png": "cannot read", "image.gif": "not a PNG or JPEG",
             "named.png": "is a GIF image", "huge.png": "downscale it"}
    for name, message in cases.items():
        with pytest.raises(SceneError, match=message) as info:
            load_texture(tmp_path / name)
        assert "\n" not in str(info.value)


def test_bad_texture_keys_in_a_scene_file(tmp_path, capsys):
    Image.new("RGB", (2, 2)).save(tmp_path / "ok.png")
    cases = {'{ type = "diffuse", texture = "nothere.png" }': "objects[0].material.texture file not found",
             '{ type = "diffuse", texture = "chequer" }': "did you mean 'checker'",
             '{ type = "diffuse", texture = 3 }': "must be a string",
             '{ type = "mirror", texture = "ok.png" }': "unknown key 'texture'"}
    for material, message in cases.items():
        (tmp_path / "s.toml").write_text(f'[[objects]]\nshape = "plane"\nmaterial = {material}\n')
        with pytest.raises(SceneError, match=message.replace("[", r"\[").replace("]", r"\]")):
            caustica.load_scene(tmp_path / "s.toml")
    (tmp_path / "s.toml").write_text('[[objects]]\nshape = "sphere"\nmaterial = { type = "diffuse", texture = "ok.png" }\n')
    assert cli_main(["render", str(tmp_path / "s.toml"), "-o", str(tmp_path / "out.png")]) == 2
    assert "needs texture coordinates" in capsys.readouterr().err
    assert not (tmp_path / "out.png").exists()


def test_bad_texture_arrays_and_a_texture_above_the_gl_limit(renderer, monkeypatch):
    for value, message in ((np.zeros((4, 4)), "RGB image"), (np.full((2, 2, 3), 2.0), r"in \[0, 1\]"),
                           (np.full((2, 2, 3), np.nan), r"in \[0, 1\]")):
        with pytest.raises(SceneError, match=message):
            Diffuse(GREY, texture=value)
    monkeypatch.setitem(renderer.device.info, "max_texture_size", 100)
    with pytest.raises(SceneError, match="128x128 texture is above this GL's limit of 100"):
        renderer.device.albedo_texture(np.ones((128, 128, 3), np.float32))
