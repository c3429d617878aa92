"""Input checks shared by the metrics: image pairs, pixel masks, optional packages."""
from __future__ import annotations

import importlib

import numpy as np


def image_pair(x, ref) -> tuple[np.ndarray, np.ndarray]:
    """``x`` and ``ref`` as float64 (H, W, 3) arrays of the same shape, every value finite.

    Raises ValueError (one line) otherwise.
    """
    x = np.asarray(x, dtype=np.float64)
    ref = np.asarray(ref, dtype=np.float64)
    for name, arr in (("image", x), ("reference", ref)):
        if arr.ndim != 3 or arr.shape[2] != 3 or arr.shape[0] == 0 or arr.shape[1] == 0:
            raise ValueError(f"{name} has shape {arr.shape}; metrics need (H, W, 3) RGB images")
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} holds NaN or infinite values; metrics need finite pixels")
    if x.shape != ref.shape:
        raise ValueError(f"image shape {x.shape} differs from reference shape {ref.shape}")
    return x, ref


def pixel_mask(mask, shape: tuple[int, ...]) -> np.ndarray | None:
    """``mask`` as an (H, W) bool array for images of ``shape`` (H, W, ...); None stays None."""
    if mask is None:
        return None
    mask = np.asarray(mask)
    if mask.shape != tuple(shape[:2]):
        raise ValueError(f"mask has shape {mask.shape}; it must be (H, W) = {tuple(shape[:2])}")
    return mask if mask.dtype == bool else mask != 0


def masked_mean(values: np.ndarray, mask: np.ndarray | None) -> float:
    """Mean of ``values`` (H, W) or (H, W, C) over the pixels in ``mask`` (all when None); NaN when empty."""
    if mask is not None:
        values = values[mask]
    return float(values.mean()) if values.size else float("nan")


def optional_module(name: str, package: str):
    """Import ``name``, or raise MissingExtraError (an ImportError) naming the pip package to install."""
    from ..errors import MissingExtraError

    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise MissingExtraError(f"{name} is not installed; install it with `pip install {package}` "
                                f"(or `pip install 'caustica[metrics]'`)") from exc
