"""Reading GL textures back into numpy, and the k x k box filter of supersampling.

No technique knowledge: the renderer, the techniques' raster driver and the viewer read frames
back through these.
"""
from __future__ import annotations

import math

import numpy as np


def supersampling_factor(spp: int) -> int:
    """Samples per pixel become a k x k grid (k = round(sqrt(spp)))."""
    return max(1, int(round(math.sqrt(max(1, spp)))))


def box_downsample(image: np.ndarray, k: int) -> np.ndarray:
    """Average k x k blocks: the box pixel filter of the reference renderers."""
    if k == 1:
        return image
    h, w, c = image.shape
    return image.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))


def read_rgba(texture, copy: bool = True) -> np.ndarray:
    """A float texture as a (H, W, components) float32 array, row 0 at the top (``copy`` False: a
    flipped read-only view of the bytes read, for a caller that derives new arrays from it anyway)."""
    w, h = texture.size
    data = np.frombuffer(texture.read(), dtype="f4").reshape(h, w, texture.components)
    return np.ascontiguousarray(data[::-1]) if copy else data[::-1]


def read_rgb(texture) -> np.ndarray:
    """An RGBA32F texture as a (H, W, 3) float32 image, row 0 at the top."""
    return np.ascontiguousarray(read_rgba(texture)[:, :, :3])
