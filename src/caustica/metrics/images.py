"""Per-pixel image errors: PSNR (linear and sRGB) and relative MSE.

Images are float (H, W, 3) linear RGB, row 0 at the top; ``mask`` is an
optional (H, W) bool array selecting the pixels that count. A mask that
selects no pixel gives NaN. Shape or finiteness problems raise ValueError.
"""
from __future__ import annotations

import math

import numpy as np

from ..images import linear_to_srgb
from .checks import image_pair, masked_mean, pixel_mask

RELMSE_EPSILON = 0.01


def _psnr(mse: float) -> float:
    """PSNR in dB for peak 1: inf for a zero error, NaN for an empty mask."""
    if math.isnan(mse):
        return mse
    return math.inf if mse == 0.0 else -10.0 * math.log10(mse)


def psnr_linear(x, ref, mask=None) -> float:
    """PSNR (dB, peak 1) of linear values clipped to [0, 1]; inf when they are identical."""
    x, ref = image_pair(x, ref)
    mask = pixel_mask(mask, x.shape)
    diff = np.clip(x, 0.0, 1.0) - np.clip(ref, 0.0, 1.0)
    return _psnr(masked_mean(diff * diff, mask))


def psnr_srgb(x, ref, mask=None) -> float:
    """PSNR (dB, peak 1) after clipping to [0, 1] and encoding with the exact sRGB curve."""
    x, ref = image_pair(x, ref)
    mask = pixel_mask(mask, x.shape)
    diff = linear_to_srgb(np.clip(x, 0.0, 1.0)) - linear_to_srgb(np.clip(ref, 0.0, 1.0))
    return _psnr(masked_mean(diff * diff, mask))


def relmse(x, ref, mask=None) -> float:
    """Relative MSE on unclipped values: mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01)."""
    x, ref = image_pair(x, ref)
    mask = pixel_mask(mask, x.shape)
    return masked_mean((x - ref) ** 2 / (ref * ref + RELMSE_EPSILON), mask)
