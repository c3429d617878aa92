"""Per-vertex rays of Kakimoto et al.: reflection (3.1 step 1) and two refractions through a lens (4.5).

All functions work on arrays of vertices at once; the exact hits come from
Embree (:class:`caustica.raytrace.embree_scene.RayScene`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..raytrace.optics import dot, fresnel_dielectric, normalize, reflect, refract
from .viewpoint import Lines


def facing(normals: np.ndarray, view_dirs: np.ndarray) -> np.ndarray:
    """Normals flipped to face against the view directions."""
    return np.where((dot(normals, view_dirs) > 0)[:, None], -normals, normals)


def reflection_rays(eye: np.ndarray, points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Step (1): the eye ray to each vertex mirrored about the vertex normal; (origins, directions)."""
    v = normalize(points - eye)
    return points, reflect(v, facing(normalize(normals), v))


def trace_lines(ray_scene, origins: np.ndarray, directions: np.ndarray) -> tuple[Lines, object]:
    """Step (3.1): the nearest exact hit of every ray (inf where it escapes), and Embree's hits."""
    hits = ray_scene.intersect(origins, directions)
    return Lines(origins, directions, np.where(hits.hit, hits.t, np.inf)), hits


@dataclass
class Refracted:
    """Rays after two refractions (front vertex, then the back surface found by Embree)."""

    origins: np.ndarray  # (n, 3) exit points
    directions: np.ndarray  # (n, 3) exit directions
    transmittance: np.ndarray  # (n,) Fresnel (1 - F) at the exits (TIR reflections weigh 1)
    path_length: np.ndarray  # (n,) distance travelled inside
    valid: np.ndarray  # (n,) the ray left the lens within ``max_interfaces``


def double_refraction(ray_scene, lens_index: int, eye: np.ndarray, points: np.ndarray, normals: np.ndarray,
                      ior: float, max_interfaces: int = 4) -> Refracted:
    """Refract the eye ray at each front vertex into the lens, then out where Embree finds the
    back surface (total internal reflection reflects and goes on, up to ``max_interfaces``)."""
    v = normalize(points - eye)
    n = facing(normalize(normals), v)
    d, _ = refract(v, n, 1.0 / ior)
    o = points.astype(np.float64).copy()
    count = len(o)
    transmittance, length = np.ones(count), np.zeros(count)
    valid = np.zeros(count, bool)
    active = np.arange(count)
    for _ in range(max_interfaces):
        if len(active) == 0:
            break
        hits = ray_scene.intersect(o[active], d[active])
        inside = hits.hit & (hits.object_index == lens_index)
        active = active[inside]
        hn = hits.normal[inside]
        # Leave through the outward normal: refract from glass into air (TIR: reflect inside).
        outward = np.where((dot(hn, d[active]) < 0)[:, None], -hn, hn)
        t, tir = refract(d[active], -outward, ior)
        f = fresnel_dielectric(dot(d[active], outward), ior, 1.0)
        length[active] += hits.t[inside]
        o[active] = hits.position[inside]
        d[active] = t
        transmittance[active] *= np.where(tir, 1.0, 1.0 - f)
        valid[active[~tir]] = True
        active = active[tir]
    return Refracted(o, d, transmittance, length, valid)
