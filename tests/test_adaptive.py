"""Adaptive anti-aliasing (``antialias="adaptive"``, passes/post/adaptive.py): the pixels it flags are the edges of
the 1-spp image, its image is the 4-spp image there and the 1-spp image elsewhere, its error against 16 spp
is 4 spp's on scenes with edges, a flat image flags nothing, and bad requests are refused in one line."""
from __future__ import annotations

import numpy as np
import pytest

import caustica
from caustica.cli import main
from caustica.errors import RenderOptionError
from caustica.scene import Camera, Diffuse, Environment, Scene, SceneObject
from caustica.scene.shapes import sphere
from caustica.viewer.state import check_view_antialias

SIZE = (96, 72)
BACKGROUND = 1.0  # the constant environment; the grey sphere lit by it alone is nearly one colour


def sphere_scene(radius: float = 1.0, size=SIZE) -> Scene:
    """A grey diffuse sphere seen whole in a constant white environment, no lights: two nearly flat colours."""
    ball = SceneObject("ball", sphere(radius, 5), Diffuse(color=[0.25] * 3))
    camera = Camera(position=[0.3, 0.2, 4.0], look_at=[0.0, 0.0, 0.0], fov_y=45.0, size=size)
    white = Environment(np.full((8, 16, 3), BACKGROUND, np.float32), source="test:white")
    return Scene(camera=camera, objects=[ball], lights=[], environment=white)


def mixed_neighbourhoods(mask: np.ndarray) -> np.ndarray:
    """(H, W) True where a pixel's 3 x 3 neighbourhood (clamped at the border) holds both values of ``mask``."""
    padded = np.pad(mask, 1, mode="edge")
    height, width = mask.shape
    windows = [padded[j:j + height, i:i + width] for j in range(3) for i in range(3)]
    return np.any(windows, axis=0) & ~np.all(windows, axis=0)


def preset_at(name: str, size=SIZE) -> Scene:
    scene = caustica.load_scene(name)
    scene.camera = scene.camera.with_size(*size)
    return scene


def test_the_flagged_pixels_are_the_outline_of_a_sphere(renderer):
    """Two flat colours: the flags are exactly the pixels whose 8-neighbourhood holds both the sphere and
    the background at 1 spp; the sphere's inside and the background are unflagged."""
    scene = sphere_scene()
    single = renderer.render(scene, "plain", 1)[..., 0]
    covered = single < 0.9 * BACKGROUND
    # Nearly flat on both sides (the sphere's shading varies by 0.009 in all), far apart across the outline.
    assert np.ptp(single[covered]) < 0.01 and np.ptp(single[~covered]) < 1e-6 and single[covered].max() < 0.85
    renderer.render(scene, "plain", 1, antialias="adaptive")
    flags = renderer.last_adaptive_flags
    edges = mixed_neighbourhoods(covered)
    assert 0 < edges.sum() < 0.2 * edges.size
    np.testing.assert_array_equal(flags, edges)
    assert renderer.last_adaptive_fraction == pytest.approx(edges.mean())


@pytest.mark.parametrize("preset, technique", [("glass-sphere", "env-map"), ("glass-sphere", "depth-search"),
                                               ("caustics-ring", "caustic-mapping"), ("door-mirror", "per-vertex"),
                                               ("spectacle-convex", "auto")])
def test_flagged_pixels_are_4_spp_and_the_rest_1_spp(renderer, preset, technique):
    """Forward (env-map, caustics-ring's receivers under caustic maps), deferred (depth-search's glass),
    per-vertex mirrors (door-mirror) and impostors' lens, whose depth search reads the front faces at other
    pixels (drawn whole under the flags, not captured from the G-buffer: it differed by up to 0.04 at 41 %
    of the flagged pixels): the depth preset leaves the flagged pixels' shading as the 4-spp frame's. (auto plans both of adaptive's frames as for 4 spp, its caustic map following the frame's size,
    so there the 1-spp pixels are those of auto's 4-spp plan, not of auto at 1 spp.)"""
    scene = preset_at(preset)
    single = renderer.render(scene, technique, 1)
    supersampled = renderer.render(scene, technique, 4)
    adaptive = renderer.render(scene, technique, 1, antialias="adaptive")
    flags = renderer.last_adaptive_flags
    assert 0.05 < flags.mean() < 0.6
    np.testing.assert_allclose(adaptive[flags], supersampled[flags], atol=1e-5)
    np.testing.assert_allclose(adaptive[~flags], single[~flags], atol=1e-6)


@pytest.mark.parametrize("preset", ["glass-sphere", "caustics-ring", "door-mirror"])
def test_the_error_against_16_spp_is_that_of_4_spp(renderer, preset):
    """Against the technique's own 16-spp image the adaptive image keeps at least 90 % of the dB 4 spp gains
    over 1 spp (measured at 96 x 72: 32.3 / 40.2 / 40.2 dB on glass-sphere, 31.6 / 42.7 / 42.7 on
    caustics-ring, 31.9 / 39.8 / 39.8 on door-mirror for 1 spp / 4 spp / adaptive)."""
    from caustica.metrics.images import psnr_linear

    scene = preset_at(preset)
    reference = renderer.render(scene, "auto", 16)
    single, four, adaptive = (psnr_linear(renderer.render(scene, "auto", 1, antialias=mode), reference)
                              if spp == 1 else psnr_linear(renderer.render(scene, "auto", spp), reference)
                              for spp, mode in ((1, "none"), (4, "none"), (1, "adaptive")))
    assert four - single > 5.0
    assert adaptive - single >= 0.9 * (four - single), (single, four, adaptive)


def test_a_flat_image_flags_nothing_and_is_the_1_spp_image(renderer):
    """The camera inside the grey sphere sees its flat inside alone: nothing flagged, no 4-spp frame."""
    scene = sphere_scene(radius=20.0)
    single = renderer.render(scene, "plain", 1)
    adaptive = renderer.render(scene, "plain", 1, antialias="adaptive")
    assert renderer.last_adaptive_fraction == 0.0 and not renderer.last_adaptive_flags.any()
    np.testing.assert_array_equal(adaptive, single)
    renderer.render(scene, "plain", 1)
    assert renderer.last_adaptive_fraction is None


def test_bad_requests_are_refused_in_one_line(renderer, tmp_path, capsys):
    scene = sphere_scene()
    with pytest.raises(RenderOptionError, match=r"^antialias 'adaptive' renders 1 spp and 4 spp .* not spp 4; "
                                                r"leave spp at 1, or use spp without adaptive$"):
        renderer.render(scene, "plain", 4, antialias="adaptive")
    with pytest.raises(RenderOptionError, match=r"^antialias 'fxaa' is unknown; choose one of none, edge, msaa, adaptive$"):
        renderer.render(scene, "plain", antialias="fxaa")
    with pytest.raises(RenderOptionError, match=r"^antialias 'adaptive' renders every frame twice .* takes none, edge, msaa"):
        check_view_antialias("adaptive")
    code = main(["render", "glass-sphere", "-t", "plain", "--size", "32x24", "--spp", "4", "--antialias", "adaptive",
                 "-o", str(tmp_path / "a.png")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "leave spp at 1" in err, err
    assert not (tmp_path / "a.png").exists()


def test_labels_are_the_1_spp_frames(renderer):
    """Labels come from the 1-spp frame: the same layers as a 1-spp render's."""
    scene = sphere_scene()
    image, layers = renderer.render(scene, "plain", 1, labels=["id", "depth"], antialias="adaptive")
    assert renderer.last_adaptive_fraction > 0.0
    _, single = renderer.render(scene, "plain", 1, labels=["id", "depth"])
    for name in ("id", "depth"):
        np.testing.assert_array_equal(layers[name], single[name])
