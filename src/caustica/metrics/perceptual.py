"""Perceptual image errors: SSIM (scikit-image) and FLIP (NVIDIA's flip_evaluator).

Both work on display values: each image is clipped to [0, 1] and encoded with
the exact sRGB curve first. FLIP is LDR-FLIP (``flip_evaluator.evaluate(...,
"LDR")``) at its default 67 pixels per degree: the techniques are compared on
what a [0, 1] display shows, so HDR-FLIP's exposure sweep is not used.

Masked means average the per-pixel maps over the mask; an empty mask gives NaN.
For SSIM the map is first cropped by half a window on every side (3 pixels),
as scikit-image does for its own mean, so a full mask gives exactly the
unmasked value. Row 0 is the top in every map, as in the images.
"""
from __future__ import annotations

import numpy as np

from ..images import linear_to_srgb, srgb_to_linear
from .checks import image_pair, masked_mean, optional_module, pixel_mask

SSIM_WINDOW = 7  # scikit-image's default uniform 7x7 window


def _display(x: np.ndarray, dtype=np.float64) -> np.ndarray:
    """Linear RGB clipped to [0, 1] and sRGB-encoded, contiguous (FLIP wants float32)."""
    return np.ascontiguousarray(linear_to_srgb(np.clip(x, 0.0, 1.0)), dtype=dtype)


def ssim_map(x, ref) -> np.ndarray:
    """(H, W) float64 SSIM per pixel (mean over channels) of the sRGB-encoded clipped images.

    Raises ValueError for images smaller than 7x7 (the SSIM window).
    """
    x, ref = image_pair(x, ref)
    if min(x.shape[:2]) < SSIM_WINDOW:
        raise ValueError(f"image {x.shape[1]}x{x.shape[0]} is smaller than the {SSIM_WINDOW}x{SSIM_WINDOW} SSIM window")
    metrics = optional_module("skimage.metrics", "scikit-image")
    _, full = metrics.structural_similarity(
        _display(x), _display(ref), channel_axis=2, data_range=1.0, full=True
    )
    return full.mean(axis=2)


def _interior(mask: np.ndarray | None, shape: tuple[int, ...]) -> np.ndarray:
    """``mask`` (all pixels when None) without the border scikit-image leaves out of its mean SSIM."""
    pad = (SSIM_WINDOW - 1) // 2
    inner = np.zeros(shape[:2], bool)
    inner[pad:shape[0] - pad, pad:shape[1] - pad] = True
    return inner if mask is None else inner & mask


def ssim(x, ref, mask=None) -> float:
    """Mean SSIM (1 when identical) of the sRGB-encoded clipped images, over ``mask`` when given."""
    x, ref = image_pair(x, ref)
    mask = pixel_mask(mask, x.shape)
    return masked_ssim(ssim_map(x, ref), mask)


def masked_ssim(full_map: np.ndarray, mask: np.ndarray | None) -> float:
    """Mean of an :func:`ssim_map` over ``mask`` inside the window-cropped interior (NaN when empty)."""
    return masked_mean(full_map, _interior(mask, full_map.shape))


def _evaluate_flip(x: np.ndarray, ref: np.ndarray, magma: bool) -> np.ndarray:
    flip_evaluator = optional_module("flip_evaluator", "flip-evaluator")
    error_map, _, _ = flip_evaluator.evaluate(_display(ref, np.float32), _display(x, np.float32), "LDR", applyMagma=magma)
    return np.asarray(error_map, dtype=np.float32)


def flip_error_map(x, ref) -> np.ndarray:
    """(H, W) float32 LDR-FLIP error per pixel in [0, 1] (0 where identical)."""
    x, ref = image_pair(x, ref)
    return _evaluate_flip(x, ref, magma=False)[..., 0]


def flip(x, ref, mask=None) -> float:
    """Mean LDR-FLIP error (0 when identical, at most 1), over ``mask`` when given."""
    x, ref = image_pair(x, ref)
    mask = pixel_mask(mask, x.shape)
    return masked_mean(flip_error_map(x, ref).astype(np.float64), mask)


def flip_map(x, ref, linear: bool = False) -> np.ndarray:
    """(H, W, 3) float32 FLIP error map in FLIP's 'magma' colour map, for contact sheets.

    The colours are display (sRGB-encoded) values, as FLIP writes them. With
    ``linear=True`` they are decoded to linear RGB, so that
    :func:`caustica.images.write_image` (which encodes with sRGB) reproduces
    the exact magma colours next to other linear images.
    """
    x, ref = image_pair(x, ref)
    colours = _evaluate_flip(x, ref, magma=True)
    if linear:
        colours = srgb_to_linear(colours).astype(np.float32)
    return np.ascontiguousarray(colours)
