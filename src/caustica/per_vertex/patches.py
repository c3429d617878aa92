"""Patches of a large reflector, each with its own virtual viewpoint (Kakimoto et al., 4.1, fig. 6-7).

The paper leaves adaptive subdivision for future work and states its
criterion: subdivide until the field of view of each view volume falls below a
threshold. :func:`split_patches` does that by recursive bisection of the faces
at the median of their reflected directions, along the frustum axis with the
wider field of view. Patches are sets of faces; a vertex on a cut belongs to
both sides, so adjacent patches share their boundary vertices and, with them,
the exact hit at each (the continuity condition of 4.1).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .viewpoint import ViewVolume


def unique_indices(values: np.ndarray, inverse: bool = False):
    """Sorted distinct values of an integer array (and, with ``inverse``, where each value went), by a
    sort: numpy's hashing np.unique is several times slower on these index arrays."""
    flat = np.asarray(values).reshape(-1)
    order = np.argsort(flat)
    ordered = flat[order]
    first = np.r_[True, ordered[1:] != ordered[:-1]] if len(flat) else np.zeros(0, bool)
    if not inverse:
        return ordered[first]
    where = np.empty(len(flat), np.int64)
    where[order] = np.cumsum(first) - 1
    return ordered[first], where


@dataclass
class Patch:
    faces: np.ndarray  # (m, 3) indices into the reflector's vertices
    vertices: np.ndarray  # (k,) the vertices these faces use
    volume: ViewVolume
    rows: np.ndarray | None = None  # (m,) these faces' rows in the faces that were split


def split_patches(faces: np.ndarray, directions: np.ndarray, fit: Callable[[np.ndarray], ViewVolume],
                  fov_threshold: float, max_patches: int,
                  hides: Callable[[np.ndarray, ViewVolume], bool] | None = None) -> list[Patch]:
    """Split ``faces`` until every patch's frustum field of view is at most ``fov_threshold`` degrees
    and, with ``hides``, until ``hides(vertices, volume)`` is False for every patch (its map shows
    each vertex's exact hit: the adaptive subdivision 4.1 leaves for future work).

    ``directions`` (n, 3): each vertex's line direction; ``fit(vertex_indices)`` returns the
    view volume of those vertices. At most ``max_patches`` patches.
    """
    pending = [np.arange(len(faces))]
    done: list[Patch] = []
    while pending:
        rows = pending.pop(0)
        part = faces[rows]
        vertices = unique_indices(part)
        volume = fit(vertices)
        whole = max(volume.fov_degrees) <= fov_threshold and (hides is None or not hides(vertices, volume))
        if whole or len(part) < 2 or len(done) + len(pending) + 2 > max_patches:
            done.append(Patch(part, vertices, volume, rows))
            continue
        # Bisect at the median of the faces' mean direction, projected on the wider frustum axis.
        horizontal, vertical = volume.fov_degrees
        axis = volume.view_from_world[0 if horizontal >= vertical else 1, :3]
        key = directions[part].mean(axis=1) @ axis
        order = np.argsort(key, kind="stable")
        half = len(part) // 2
        pending += [rows[order[:half]], rows[order[half:]]]
    return done
