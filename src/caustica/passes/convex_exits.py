"""Exact exits from convex glass of known shape: depth-search's ``convex_exits`` (ours).

Hu and Qin (TVCG 2007, 2.1) find the exit P2 in screen space, against one layer of front and one of
back faces; they note that this "could render the accurate result for a convex object" at two
interfaces, and that total internal reflection and multi-interface refraction "are still not well
supported" (section 6). In a glass block the light entering a face leaves only through that face or
the opposite one (for IOR above sqrt 2 every adjacent face reflects it totally), so most of its
paths cross three or four interfaces, and each internal exit searched in screen space lands on the
wrong face (env-slab: 18.5 dB on the glass pixels against Mitsuba, docs/benchmarks.md).

Where a glass object's shape is known in closed form the shader computes every exit exactly instead:

- an analytic sphere (``Mesh.analytic_sphere`` under a uniform scale): the far root of the ray-sphere
  quadratic;
- a convex mesh whose faces lie on at most :data:`MAX_CONVEX_PLANES` planes (``Mesh.face_planes``:
  blocks, slabs, prisms and cylinders of up to 126 sides, cones, under any affine transform): the body
  is the intersection of the half-spaces, so a ray inside leaves through the nearest plane it moves
  towards (Haines, "Fast ray-convex polyhedron intersection", Graphics Gems II, 1991). The normal
  there is the mesh's shading normal, an affine field per plane (``Mesh.face_plane_normals``: the
  smooth side of a 64-sided cylinder, as the rasterized entry, ``exact`` and Mitsuba have it), or
  the plane's own where the shading normal would send the light to the wrong side of the face (exact,
  ``raytrace/paths.py``, lets the shading normal decide the side there instead, as Mitsuba does: the two
  differ only where the shading normal turns away from the ray, at grazing exits).

``shaders/common/convex_exits.glsl`` does the intersections; the internal bounces then follow the
reflected light from exact point to exact point, off-screen too. Other glass keeps the depth search.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform, write_uniform_array
from ..raytrace.embree_scene import world_sphere
from ..scene.transform import normal_matrix

MAX_CONVEX_PLANES = 128  # uniform vec4s: 4 a plane (its plane and normal field); llvmpipe allows 4096
SHAPE_NONE, SHAPE_PLANES, SHAPE_SPHERE = 0, 1, 2  # convex_kind in the shader


@dataclass(frozen=True)
class ConvexShape:
    """A glass object's exact shape in world space: ``planes`` (K, 4: outward unit normal, offset w with
    n . x <= w inside) with ``normals`` (K, 3, 4: the shading normal's affine field on each, unnormalised),
    or a ``sphere`` (centre, radius)."""

    planes: np.ndarray | None = None
    sphere: tuple | None = None
    normals: np.ndarray | None = None


def convex_shape(obj) -> ConvexShape | None:
    """The exact shape of ``obj`` in world space, or None where the depth search stays (not a sphere, nor a
    convex mesh of at most MAX_CONVEX_PLANES planes with one normal field on each)."""
    world_from_object = obj.world_from_object()
    sphere = world_sphere(obj.mesh, world_from_object)
    if sphere is not None:
        return ConvexShape(sphere=sphere)
    planes, fields = obj.mesh.face_planes(MAX_CONVEX_PLANES), obj.mesh.face_plane_normals(MAX_CONVEX_PLANES)
    if planes is None or fields is None:
        return None
    m = np.asarray(world_from_object, dtype=np.float64)
    to_world = normal_matrix(m)
    normals = planes[:, :3] @ to_world.T
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = (planes[:, :3] * planes[:, 3:]) @ m[:3, :3].T + m[:3, 3]  # a point of each plane, moved
    # A field n(y) = A y + b in object space, y = M^-1 (x - t), is to_world (A M^-1 x + b - A M^-1 t) in the world's.
    linear = to_world @ fields[:, :, :3] @ np.linalg.inv(m[:3, :3])
    constant = np.einsum("ij,kj->ki", to_world, fields[:, :, 3]) - linear @ m[:3, 3]
    return ConvexShape(planes=np.column_stack([normals, np.einsum("ij,ij->i", normals, points)]),
                       normals=np.concatenate([linear, constant[:, :, None]], axis=2))


def convex_defines(frame) -> dict:
    """CONVEX_EXITS for this frame's glass shader: 1 where every glass object has an exact shape (the depth
    search is compiled out), 2 where some have (chosen per object at run time), 0 where none has; and
    MAX_CONVEX_PLANES."""
    glass = frame.scene.objects_of("glass")
    exact = [convex_shape(o) is not None for o in glass]
    return {"CONVEX_EXITS": 1 if exact and all(exact) else 2 if any(exact) else 0,
            "MAX_CONVEX_PLANES": MAX_CONVEX_PLANES}


def bind_convex_shape(program, obj) -> None:
    """Set the shader's convex_kind, convex_planes, convex_normals, convex_plane_count and convex_sphere for ``obj``."""
    shape = convex_shape(obj) if obj.material.kind == "glass" else None
    if shape is None:
        set_uniform(program, "convex_kind", SHAPE_NONE)
        return
    if shape.sphere is not None:
        center, radius = shape.sphere
        set_uniform(program, "convex_kind", SHAPE_SPHERE)
        set_uniform(program, "convex_sphere", np.append(center, radius).astype("f4"))
        return
    count = len(shape.planes)
    planes, normals = np.zeros((MAX_CONVEX_PLANES, 4), "f4"), np.zeros((3 * MAX_CONVEX_PLANES, 4), "f4")
    planes[:count], normals[:3 * count] = shape.planes, shape.normals.reshape(-1, 4)
    set_uniform(program, "convex_kind", SHAPE_PLANES)
    set_uniform(program, "convex_plane_count", count)
    write_uniform_array(program, "convex_planes", planes)
    write_uniform_array(program, "convex_normals", normals)
