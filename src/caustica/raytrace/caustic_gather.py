"""Caustic irradiance at any surface point from exact photons: density estimation (Jensen's photon map).

:func:`caustica.raytrace.photons.trace_photons` gives the caustic hits: photons that reached a diffuse
receiver after at least one specular interaction. :class:`CausticGather` estimates the irradiance they
make at a point x with normal n from its k nearest hits on the same receiver and side (Jensen 1996,
"Global illumination using photon maps", section 4, with his cone filter):

    E(x) = sum_i Phi_i (1 - d_i / r) / ((1 - 2/3) pi r^2),

r the distance to the k-th nearest hit (the kernel follows the photon density: narrow in a focus, wide
where photons are sparse), bounded by ``max_radius`` so that no light leaks far from a caustic. The
estimate is consistent: with N photons and k = N^(1/2) or so, bias and noise both fall as N grows.
Deterministic: the photons are seeded, the gather has no randomness.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .photons import PhotonHits

CONE_NORMALIZATION = 1.0 - 2.0 / 3.0  # Jensen's cone filter with k = 1: the kernel's integral over pi r^2
QUERY_BATCH = 1 << 14


@dataclass
class CausticGather:
    """The k-nearest-photon irradiance estimate over ``hits`` (built once, queried per shading point; the
    hits themselves are not kept)."""

    hits: PhotonHits | None
    neighbours: int = 64
    max_radius: float = 0.05

    def __post_init__(self):
        from scipy.spatial import cKDTree

        hits = self.hits
        self.neighbours = int(max(1, min(self.neighbours, len(hits))))
        self._tree = cKDTree(hits.position) if len(hits) else None
        # What the estimate reads, compact (the tree holds the positions): 28 bytes a photon.
        self._flux = hits.flux.astype(np.float32)
        self._normal = hits.normal.astype(np.float32)
        self._object = hits.object_index.astype(np.int32)
        self.photons, self.emitted = hits.photons, hits.emitted
        self.hits = None

    def irradiance(self, position: np.ndarray, normal: np.ndarray, object_index: np.ndarray,
                   min_radius: np.ndarray | None = None) -> np.ndarray:
        """Caustic irradiance (N, 3) in W/m^2 at points (N, 3) with unit normals (N, 3) facing the side
        to estimate, on the objects ``object_index`` (N,): photons on other objects or arriving on the
        other side of a thin surface do not count. ``min_radius`` (N,), when given, widens the kernel to
        at least that radius (a camera sample's footprint on the surface): a focus smaller than a pixel
        then gives the pixel its mean, as a box filter would, instead of a point value of a peak."""
        out = np.zeros((len(position), 3))
        if self._tree is None or len(position) == 0:
            return out
        floor = np.zeros(len(position)) if min_radius is None else np.minimum(min_radius, self.max_radius)
        for start in range(0, len(position), QUERY_BATCH):
            sl = slice(start, start + QUERY_BATCH)
            out[sl] = self._estimate(position[sl], normal[sl], object_index[sl], floor[sl])
        return out

    def _estimate(self, position, normal, object_index, floor) -> np.ndarray:
        k = self.neighbours
        distance, index = self._tree.query(position, k=k, distance_upper_bound=self.max_radius)
        distance, index = distance.reshape(len(position), k), index.reshape(len(position), k)
        # The kernel radius: the k-th neighbour's distance, or max_radius where fewer are that near.
        radius = np.maximum(np.where(np.isfinite(distance[:, -1]), distance[:, -1], self.max_radius), 1e-12)
        rows, column = np.nonzero(np.isfinite(distance))
        out = self._cone_sum(rows, index[rows, column], distance[rows, column], radius, normal, object_index)
        wide = radius < floor  # more than k photons within the footprint: all of them count
        if wide.any():
            lists = self._tree.query_ball_point(position[wide], floor[wide])
            rows = np.repeat(np.arange(len(lists)), [len(x) for x in lists])
            members = np.concatenate([np.asarray(x, np.int64) for x in lists]) if len(rows) else np.zeros(0, np.int64)
            near = np.linalg.norm(self._tree.data[members] - position[wide][rows], axis=1)
            out[wide] = self._cone_sum(rows, members, near, floor[wide], normal[wide], object_index[wide])
        return out

    def _cone_sum(self, rows, members, distance, radius, normal, object_index) -> np.ndarray:
        """Jensen's cone-filtered estimate (N, 3) at N points with kernel radii ``radius`` (N,), over the
        photons ``members`` lying at ``distance`` from point ``rows`` (flat lists of pairs)."""
        ok = self._object[members] == object_index[rows]
        ok &= np.einsum("nj,nj->n", self._normal[members], normal[rows]) > 0.0
        weight = np.where(ok, np.maximum(1.0 - distance / radius[rows], 0.0), 0.0)
        flux = np.stack([np.bincount(rows, weight * self._flux[members, c], minlength=len(radius))
                         for c in range(3)], axis=1)
        return flux / (CONE_NORMALIZATION * np.pi * radius[:, None] ** 2)
