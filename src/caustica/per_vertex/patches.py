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


@dataclass
class Patch:
    faces: np.ndarray  # (m, 3) indices into the reflector's vertices
    vertices: np.ndarray  # (k,) the vertices these faces use
    volume: ViewVolume


def split_patches(faces: np.ndarray, directions: np.ndarray, fit: Callable[[np.ndarray], ViewVolume],
                  fov_threshold: float, max_patches: int) -> list[Patch]:
    """Split ``faces`` until every patch's frustum field of view is at most ``fov_threshold`` degrees.

    ``directions`` (n, 3): each vertex's line direction; ``fit(vertex_indices)`` returns the
    view volume of those vertices. At most ``max_patches`` patches.
    """
    pending = [faces]
    done: list[Patch] = []
    while pending:
        part = pending.pop(0)
        vertices = np.unique(part)
        volume = fit(vertices)
        fov = max(volume.fov_degrees)
        if fov <= fov_threshold or len(part) < 2 or len(done) + len(pending) + 2 > max_patches:
            done.append(Patch(part, vertices, volume))
            continue
        # Bisect at the median of the faces' mean direction, projected on the wider frustum axis.
        horizontal, vertical = volume.fov_degrees
        axis = volume.view_from_world[0 if horizontal >= vertical else 1, :3]
        key = directions[part].mean(axis=1) @ axis
        order = np.argsort(key, kind="stable")
        half = len(part) // 2
        pending += [part[order[:half]], part[order[half:]]]
    return done
