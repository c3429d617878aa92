"""Post-process edge anti-aliasing (passes/post/resolve.py, shaders/passes/edge_antialias.frag): coverage of
straight edges against their exact area, flat and axis-aligned images untouched, a rendered scene moved
towards its supersampled image, and bad modes refused."""
from __future__ import annotations

import numpy as np
import pytest

import caustica
from caustica.errors import RenderOptionError
from caustica.gpu.readback import read_rgb
from caustica.metrics.images import psnr_linear
from caustica.passes.post.resolve import resolved
from caustica.render.frame import Frame

SIZE = (96, 64)


def half_plane(slope: float, offset: float, samples: int) -> np.ndarray:
    """(H, W) fraction of each pixel above the line y = slope * x + offset (pixel units, row 0 at y = 0),
    averaged over samples x samples points per pixel (samples = 1: the aliased image)."""
    height, width = SIZE[1], SIZE[0]
    s = (np.arange(samples) + 0.5) / samples
    y = (np.arange(height)[:, None] + s[None, :]).reshape(-1)
    x = (np.arange(width)[:, None] + s[None, :]).reshape(-1)
    inside = (y[:, None] > slope * x[None, :] + offset).astype(np.float64)
    return inside.reshape(height, samples, width, samples).mean(axis=(1, 3))


def edge_resolved(renderer, image: np.ndarray) -> np.ndarray:
    """``image`` (H, W) grey, through the edge pass on the GPU."""
    gpu = renderer.device
    frame = Frame(gpu, None, None, None)
    try:
        source = frame.texture(SIZE, "rgba32f")
        rgba = np.ones((SIZE[1], SIZE[0], 4), np.float32)
        rgba[..., :3] = image[..., None]
        source.write(rgba[::-1].tobytes())  # GL row 0 is the bottom; the image's row 0 the top
        return read_rgb(resolved(frame, source, 1, "edge"))[..., 0]
    finally:
        frame.give_back()


@pytest.mark.parametrize("slope, offset", [(0.18, 20.3), (-0.3, 50.7), (3.5, -120.0), (0.05, 30.6)])
def test_edge_coverage_approaches_the_exact_area(renderer, slope, offset):
    exact = half_plane(slope, offset, 64)
    aliased = half_plane(slope, offset, 1)
    blended = edge_resolved(renderer, aliased)
    interior = (slice(2, -2), slice(2, -2))  # the image border clamps the neighbourhood
    before = np.sqrt(np.mean((aliased - exact)[interior] ** 2))
    after = np.sqrt(np.mean((blended - exact)[interior] ** 2))
    assert after < 0.6 * before, (before, after)
    # Only pixels the edge crosses (or that neighbour it) change.
    far = np.abs(half_plane(slope, offset, 16) - 0.5) == 0.5
    far &= np.roll(far, 1, 0) & np.roll(far, -1, 0) & np.roll(far, 1, 1) & np.roll(far, -1, 1)
    assert np.allclose(blended[far], aliased[far])


def test_flat_and_pixel_aligned_images_are_unchanged(renderer):
    flat = np.full((SIZE[1], SIZE[0]), 0.37)
    assert np.allclose(edge_resolved(renderer, flat), flat, atol=1e-6)
    aligned = np.zeros((SIZE[1], SIZE[0]))
    aligned[:, 40:] = 1.0  # an edge along pixel boundaries is already exact
    assert np.allclose(edge_resolved(renderer, aligned), aligned, atol=1e-6)


def test_glass_ball_outline_moves_towards_supersampling(renderer):
    """Edge anti-aliasing's own gain, on point-sampled (bilinear) lookups: with the default footprint
    filter the ball's inside is already smooth, and the edge pass then costs 0.4-0.9 dB there
    (docs/antialiasing.md's table: 33.9 -> 33.5 dB on glass-sphere at 160 x 120)."""
    scene = caustica.load_scene("glass-sphere")
    scene.camera.size = (120, 90)
    scene.environment.filter = "bilinear"
    reference = renderer.render(scene, "depth-search", 36)
    plain = renderer.render(scene, "depth-search", 1)
    edge = renderer.render(scene, "depth-search", 1, antialias="edge")
    gain = psnr_linear(edge, reference) - psnr_linear(plain, reference)
    assert gain > 0.5, gain


def test_unknown_mode_is_refused(renderer):
    with pytest.raises(RenderOptionError, match="antialias 'fxaa' is unknown; choose one of none, edge"):
        renderer.render(caustica.load_scene("glass-sphere"), "plain", antialias="fxaa")
