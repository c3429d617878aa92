"""Angular error of directions, and the exact exit directions it is measured against."""
from __future__ import annotations

import numpy as np

from ..raytrace.embree_scene import ray_scene_for
from ..raytrace.paths import exit_directions
from .hits import objects_of_kind


def _valid_mask(valid, shape: tuple[int, ...]) -> np.ndarray:
    """One mask, or a sequence of masks ANDed together (e.g. the estimate's and the reference's)."""
    if valid is None:
        return np.ones(shape, bool)
    masks = list(valid) if isinstance(valid, (list, tuple)) else [valid]
    out = np.ones(shape, bool)
    for m in masks:
        m = np.asarray(m)
        if m.shape != shape:
            raise ValueError(f"valid mask has shape {m.shape}; it must be {shape}, the directions' shape without the last axis")
        out &= m if m.dtype == bool else m != 0
    return out


def angular_error(dirs, ref_dirs, valid=None) -> dict:
    """Angle between ``dirs`` and ``ref_dirs`` in degrees: dict(mean_deg, p95_deg, count).

    ``dirs`` and ``ref_dirs`` are (H, W, 3) or (N, 3) vectors (need not be unit
    length). ``valid`` is one mask of shape (H, W) or (N,), or a pair of masks
    (the estimate's and the reference's) that are ANDed: only pixels valid in
    all count. The angle is atan2(|a x b|, a . b), accurate for tiny angles as
    well as near 180 degrees. With no valid pixel the mean and p95 are NaN.
    Raises ValueError for mismatched shapes and for counted vectors that are
    not finite or have zero length.
    """
    a = np.asarray(dirs, dtype=np.float64)
    b = np.asarray(ref_dirs, dtype=np.float64)
    if a.ndim not in (2, 3) or a.shape[-1] != 3:
        raise ValueError(f"directions have shape {a.shape}; they must be (H, W, 3) or (N, 3)")
    if a.shape != b.shape:
        raise ValueError(f"directions shape {a.shape} differs from reference shape {b.shape}")
    use = _valid_mask(valid, a.shape[:-1])
    a, b = a[use], b[use]
    if not (np.all(np.isfinite(a)) and np.all(np.isfinite(b))):
        raise ValueError("valid directions hold NaN or infinite values; mark those pixels invalid")
    if np.any(np.linalg.norm(a, axis=1) == 0) or np.any(np.linalg.norm(b, axis=1) == 0):
        raise ValueError("valid directions include zero vectors; mark those pixels invalid")
    if len(a) == 0:
        return {"mean_deg": float("nan"), "p95_deg": float("nan"), "count": 0}
    angles = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b)))
    return {"mean_deg": float(angles.mean()), "p95_deg": float(np.percentile(angles, 95)), "count": int(len(angles))}


def exact_exit_directions(scene, camera=None, max_interfaces: int = 16) -> tuple[np.ndarray, np.ndarray]:
    """Exact exit directions of the pixel-centre rays through glass: (dirs (H, W, 3) float64, valid (H, W) bool).

    Each pixel-centre primary ray of ``camera`` (default ``scene.camera``) whose
    first hit is a glass object follows its refracted branch (total internal
    reflection reflects) until it leaves all glass
    (:func:`caustica.raytrace.paths.exit_directions`). ``valid`` is False where
    the first hit is not glass or the path is invalid (leaks, hits an opaque
    object inside glass, or exceeds ``max_interfaces``); there ``dirs`` holds
    the primary direction.
    """
    camera = scene.camera if camera is None else camera
    width, height = camera.size
    origins, dirs = (a.reshape(-1, 3) for a in camera.primary_rays(1))
    ray_scene = ray_scene_for(scene)
    glass = objects_of_kind(scene, "glass")[ray_scene.intersect(origins, dirs).object_index]
    out = dirs.copy()
    valid = np.zeros(len(dirs), bool)
    if glass.any():
        exit_dirs, ok, _ = exit_directions(ray_scene, scene, origins[glass], dirs[glass], max_interfaces)
        out[glass] = exit_dirs
        valid[glass] = ok
    return out.reshape(height, width, 3), valid.reshape(height, width)
