"""Adaptive subdivision of a mirror's mesh where per-vertex interpolation cannot follow its reflection.

Kakimoto et al. make the reflection exact at every vertex and let the rasterizer interpolate the
texture coordinates Q between vertices (3.4); an edge of a reflected object, a corner of it or the
border between rays that hit and rays that escape, falling between two vertices, is smeared over the
faces around them. Section 4.1 (fig. 6) leaves adaptive subdivision for future work; :func:`refine`
does it per edge of the mesh (``per-vertex``'s ``refine``). An edge longer than ``min_pixels`` on the
screen is split at its midpoint, whose ray is traced exactly like every vertex's, when

- its two rays hit different objects, or one hits and the other escapes;
- they hit faces whose normals are more than ``CREASE_DEGREES`` apart (a box's corner between them);
- it is longer than ``test_pixels`` and the midpoint's ray does either against its ends, or its exact Q
  lies more than ``tolerance`` pixels from the interpolated (Q_a + Q_b) / 2, on the edge's own scale
  (its screen length per |Q_b - Q_a|). Shorter edges between agreeing ends are not tried: on a smooth
  stretch of the reflection the interpolation error falls as the square of the edge's length, and a
  midpoint ray for every short edge would cost more rays than the mesh has vertices.

Not split: an edge whose two rays both escape (the environment between them varies smoothly), and one
whose midpoint's hit the patch's map hides (a vertex there would show the hiding surface, section 6).
Decisions are per edge, so both faces of an edge split it (no T-junctions); a face with one, two or
three split edges becomes two, three or four faces, whose new edges are tried at the next level, up
to ``levels``. Midpoints interpolate their ends' attributes linearly (positions, unnormalised
normals: the barycentric shading normal the oracle reflects about).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..raytrace.optics import dot
from .patches import unique_indices
from .viewpoint import Lines

CREASE_DEGREES = 20.0

# Children of a face (v0, v1, v2) with midpoints (m0, m1, m2) of its edges (v0 v1, v1 v2, v2 v0), in
# the order [v0, v1, v2, m0, m1, m2], turned so that the split edges come first; counter-clockwise kept.
_CHILDREN = {1: [(0, 3, 2), (3, 1, 2)], 2: [(3, 1, 4), (0, 3, 4), (0, 4, 2)],
             3: [(0, 3, 5), (3, 1, 4), (5, 4, 2), (3, 4, 5)]}


@dataclass
class Traced:
    """Rays of vertices: lines, the object each hits (-1: escapes) and the shading normal there."""

    lines: Lines
    objects: np.ndarray  # (n,) int
    normals: np.ndarray  # (n, 3) unit

    def take(self, index) -> "Traced":
        return Traced(self.lines.subset(index), self.objects[index], self.normals[index])

    def join(self, other: "Traced") -> "Traced":
        lines = Lines(*(np.concatenate([getattr(self.lines, k), getattr(other.lines, k)])
                        for k in ("origins", "directions", "distance")))
        return Traced(lines, np.concatenate([self.objects, other.objects]), np.concatenate([self.normals, other.normals]))


@dataclass
class Refined:
    faces: np.ndarray  # (f, 3)
    parents: np.ndarray  # (f,) the input face each face lies in
    attributes: dict  # name -> (n, k): the input's, then the midpoints'
    traced: Traced  # (n,)
    levels: int  # levels that split an edge


def refine(faces: np.ndarray, attributes: dict, traced: Traced, trace: Callable[[dict], Traced],
           pixels: Callable[[dict], np.ndarray], uv: Callable[[Lines, np.ndarray], np.ndarray], tolerance: float,
           min_pixels: float, test_pixels: float, levels: int, max_vertices: int,
           hidden: Callable[[Lines, np.ndarray], np.ndarray] | None = None) -> Refined:
    """Split edges (see the module) for up to ``levels`` levels and ``max_vertices`` vertices in all;
    the midpoint of an edge whose ends agree is tried only when it is longer than ``test_pixels``.

    ``attributes``: per-vertex arrays interpolated at midpoints (``trace`` and ``pixels`` read them);
    ``trace(attributes)``: the rays of new vertices; ``pixels(attributes)``: (n, 2) screen positions,
    nan where a vertex is behind the eye; ``uv(lines, faces)``: (n, 2) texture coordinates Q in the
    map of each input face's patch; ``hidden(lines, faces)``: (n,) True where that map hides the
    exact hit (viewpoint.hidden): an edge with such a midpoint is not split.
    """
    active = np.asarray(faces, np.int64)  # faces whose edges may be untried: the last level's children
    parents = np.arange(len(active))
    settled: list[tuple[np.ndarray, np.ndarray]] = []  # (faces, parents) whose edges are all kept
    attributes = {k: np.asarray(v, np.float64) for k, v in attributes.items()}
    screen = pixels(attributes)
    kept = np.zeros(0, np.int64)  # sorted keys of the edges tried and kept (a split edge leaves the mesh)
    cos_crease = np.cos(np.radians(CREASE_DEGREES))
    used = 0
    for _ in range(levels):
        count = len(screen)
        ends = np.stack([active, np.roll(active, -1, axis=1)], axis=2)  # (f, 3, 2): edges v0v1, v1v2, v2v0
        keys, inverse = unique_indices(ends.min(axis=2) * (1 << 32) + ends.max(axis=2), inverse=True)
        owner = np.zeros(len(keys), np.int64)  # an input face holding each edge
        owner[inverse] = parents[np.arange(len(inverse)) // 3]
        fresh_rows = np.nonzero(~_member(keys, kept))[0]
        a, b = keys[fresh_rows] >> 32, keys[fresh_rows] & 0xFFFFFFFF
        length = np.nan_to_num(np.linalg.norm(screen[a] - screen[b], axis=1), nan=0.0)
        objects, normals = traced.objects, traced.normals
        differ = (objects[a] != objects[b]) | (dot(normals[a], normals[b]) < cos_crease)
        tried = (length > min_pixels) & ((objects[a] >= 0) | (objects[b] >= 0)) & (differ | (length > test_pixels))
        tried = np.nonzero(tried)[0]
        a, b, length, owners = a[tried], b[tried], length[tried], owner[fresh_rows[tried]]
        chosen = np.zeros(0, np.int64)  # into the tried edges: those split
        if len(a):
            mid = {k: 0.5 * (v[a] + v[b]) for k, v in attributes.items()}
            middle = trace(mid)
            wanted = differ[tried] | (objects[a] != middle.objects) | (dot(normals[a], middle.normals) < cos_crease)
            three = Lines(*(np.concatenate([getattr(traced.lines, k)[a], getattr(traced.lines, k)[b],
                                            getattr(middle.lines, k)]) for k in ("origins", "directions", "distance")))
            qa, qb, qm = np.split(uv(three, np.tile(owners, 3)), 3)
            span = np.linalg.norm(qb - qa, axis=1)
            off = np.linalg.norm(qm - 0.5 * (qa + qb), axis=1)
            with np.errstate(divide="ignore", invalid="ignore"):
                wanted |= ~(np.where(off > 1e-9, off * length / span, 0.0) <= tolerance)
            if hidden is not None and wanted.any():
                # A midpoint the map hides would show the hiding surface: the edge stays.
                wanted[wanted] = ~hidden(middle.lines.subset(wanted), owners[wanted])
            chosen = np.nonzero(wanted)[0]
            if count + len(chosen) > max_vertices:  # the longest edges first, within the budget
                order = np.argsort(-length[chosen], kind="stable")
                chosen = np.sort(chosen[order[:max(0, max_vertices - count)]])
        split = np.zeros(len(fresh_rows), bool)
        split[tried[chosen]] = True
        kept = np.sort(np.concatenate([kept, keys[fresh_rows[~split]]]))
        if len(chosen) == 0:
            break
        midpoints = np.full(len(keys), -1, np.int64)
        midpoints[fresh_rows[split]] = count + np.arange(len(chosen))
        attributes = {k: np.concatenate([v, mid[k][chosen]]) for k, v in attributes.items()}
        traced = traced.join(middle.take(chosen))
        screen = np.concatenate([screen, pixels({k: v[chosen] for k, v in mid.items()})])
        marks = midpoints[inverse].reshape(-1, 3)
        whole = ~(marks >= 0).any(axis=1)
        settled.append((active[whole], parents[whole]))
        active, children = _split_faces(active[~whole], marks[~whole])
        parents = parents[~whole][children]
        used += 1
        if count + len(chosen) >= max_vertices:
            break
    settled.append((active, parents))
    faces, parents = (np.concatenate(part) for part in zip(*settled))
    return Refined(faces, parents, attributes, traced, used)


def _member(values: np.ndarray, sorted_set: np.ndarray) -> np.ndarray:
    """values in ``sorted_set`` (a sorted array)."""
    if len(sorted_set) == 0:
        return np.zeros(len(values), bool)
    at = np.minimum(np.searchsorted(sorted_set, values), len(sorted_set) - 1)
    return sorted_set[at] == values


def _split_faces(faces: np.ndarray, midpoints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each face with its split edges' midpoints (-1: not split) replaced by its children; (faces, the
    index of the face each came from)."""
    marked = midpoints >= 0
    count = marked.sum(axis=1)
    kept = np.nonzero(count == 0)[0]
    out, origin = [faces[kept]], [kept]
    for n, children in _CHILDREN.items():
        rows = np.nonzero(count == n)[0]
        if len(rows) == 0:
            continue
        m = marked[rows]
        # Turn each face so that its split edges are e0 (one), e0 and e1 (two; e2 kept) or all.
        turn = np.argmax(m, axis=1) if n == 1 else (np.argmin(m, axis=1) + 1) % 3 if n == 2 else np.zeros(len(rows), int)
        order = (turn[:, None] + np.arange(3)[None]) % 3
        both = np.concatenate([np.take_along_axis(faces[rows], order, axis=1),
                               np.take_along_axis(midpoints[rows], order, axis=1)], axis=1)
        out += [both[:, list(child)] for child in children]
        origin += [rows] * len(children)
    return np.concatenate(out), np.concatenate(origin)
