"""The rectangles that stand in for nearby objects (Hu and Qin 2.2.1): a planar object or a thin slab is its own
rectangle, any other object a square through its centre facing the reflector; coplanar groups and the atlas's
cells."""
from __future__ import annotations

import numpy as np

from ...raytrace.environment_bake import same_plane

SLAB_RATIO = 0.1  # a diffuse object at most this thick for its width is its own rectangle (its near face)


def object_sphere(obj) -> tuple[np.ndarray, float]:
    """Bounding-box centre of the world mesh and the farthest vertex's distance from it."""
    vertices = obj.world_mesh().vertices.astype(np.float64)
    center = 0.5 * (vertices.min(axis=0) + vertices.max(axis=0))
    return center, float(np.linalg.norm(vertices - center, axis=1).max()) + 1e-9


def planar_rectangle(obj, tolerance: float = 1e-6):
    """(centre, unit normal, half_u, half_v) when the object's world mesh is a flat rectangle-like patch, else None."""
    return flat_patch(obj.world_mesh().vertices.astype(np.float64), tolerance)


def _principal_frame(vertices: np.ndarray):
    """(mean, singular values, (u, v, n) the principal axes with n the thinnest, (a, b, c) the points'
    coordinates along them) of world points; None when they span fewer than three axes."""
    center = vertices.mean(axis=0)
    _, s, vt = np.linalg.svd(vertices - center, full_matrices=False)
    if len(s) < 3:
        return None
    return center, s, vt, tuple((vertices - center) @ axis for axis in vt)


def _face(center, u, v, n, a, b, depth: float):
    """(centre, n, half_u, half_v): the rectangle bounding coordinates ``a``, ``b`` at ``depth`` along n."""
    center = center + 0.5 * (a.max() + a.min()) * u + 0.5 * (b.max() + b.min()) * v + depth * n
    return center, n, 0.5 * (a.max() - a.min()) * u, 0.5 * (b.max() - b.min()) * v


def flat_patch(vertices: np.ndarray, tolerance: float = 1e-6):
    """planar_rectangle of a set of world points: their plane and the rectangle that bounds them in it."""
    frame = _principal_frame(vertices)
    if frame is None or frame[1][2] > tolerance * max(frame[1][0], 1e-12):
        return None
    center, _, (u, v, n), (a, b, _) = frame
    return _face(center, u, v, n, a, b, 0.0)


def axis_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([0.0, 1.0, 0.0]) if abs(axis[1]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(u, axis)


def slab_rectangle(obj, reflector_center: np.ndarray):
    """(centre, unit normal away from the reflector, half_u, half_v, thickness) of the face towards
    ``reflector_center`` when the world mesh is flat or a thin slab (a floor, a table top, a wall as a box
    at most SLAB_RATIO as thick as it is wide), else None. Also None when the reflector's centre lies
    within the slab's thickness (it would see its sides)."""
    frame = _principal_frame(obj.world_mesh().vertices.astype(np.float64))
    if frame is None:
        return None
    center, _, (u, v, n), (a, b, c) = frame
    width, thickness = min(np.ptp(a), np.ptp(b)), float(np.ptp(c))
    if thickness > SLAB_RATIO * width:
        return None
    side = float(np.dot(reflector_center - center, n))
    if c.min() <= side <= c.max() and thickness > 0.0:
        return None
    if side > 0.0:
        n, c = -n, -c
    # The face nearest the reflector: the smallest depth along n (which points away from it).
    return (*_face(center, u, v, n, a, b, c.min()), thickness)


def coplanar_groups(world, indices: list[int], tolerance: float = 1e-6) -> list[list[int]]:
    """``indices`` (nearest first) in groups that share one rectangle: flat diffuse patches that lie in one plane
    (normals parallel, offsets equal within ``tolerance`` of the scene's size) together, in the order of their
    nearest member, every other object alone. A plane's texture is exact (Hu and Qin 2.2.1), so one texture of
    the union sees what the separate ones saw, with one lookup instead of one per patch: a chart of six colour
    groups before a lens costs a sixth."""
    size = float(np.linalg.norm(np.ptp(world.bounds(), axis=0))) or 1.0
    groups, planes = [], []
    for i in indices:
        obj = world.objects[i]
        plane = planar_rectangle(obj) if obj.material.kind == "diffuse" else None
        for k, known in enumerate(planes):
            if plane is not None and known is not None and same_plane(plane, known, tolerance * size, tolerance):
                groups[k].append(i)
                break
        else:
            groups.append([i])
            planes.append(plane)
    return groups


def atlas_grid(count: int, size: int, limit: int) -> tuple[int, int]:
    """Columns and rows of an atlas of ``count`` (>= 1) squares of ``size`` texels: one row when it fits
    under the texture ``limit`` (no cell unused), else as near a square as whole rows allow."""
    columns = count if count * size <= limit else int(np.ceil(np.sqrt(count)))
    return columns, -(-count // columns)


def atlas_cell(k: int, columns: int, size: int) -> tuple[int, int]:
    """Texel offset of square ``k`` in an atlas of ``columns`` squares of ``size`` texels a row."""
    return (k % columns) * size, (k // columns) * size
