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
- a convex polyhedron whose faces lie on at most :data:`MAX_CONVEX_PLANES` planes (``Mesh.face_planes``:
  blocks, prisms, slabs under any affine transform): the body is the intersection of the half-spaces,
  so a ray inside leaves through the nearest plane it moves towards (Haines, "Fast ray-convex
  polyhedron intersection", Graphics Gems II, 1991).

``shaders/common/convex_exits.glsl`` does the intersections; the internal bounces then follow the
reflected light from exact point to exact point, off-screen too. Other glass keeps the depth search.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform, write_uniform_array
from ..raytrace.embree_scene import world_sphere
from ..scene.transform import normal_matrix

MAX_CONVEX_PLANES = 16
SHAPE_NONE, SHAPE_PLANES, SHAPE_SPHERE = 0, 1, 2  # convex_kind in the shader


@dataclass(frozen=True)
class ConvexShape:
    """A glass object's exact shape in world space: ``planes`` (K, 4: outward unit normal, offset w with
    n . x <= w inside) or a ``sphere`` (centre, radius)."""

    planes: np.ndarray | None = None
    sphere: tuple | None = None


def convex_shape(obj) -> ConvexShape | None:
    """The exact shape of ``obj`` in world space, or None where the depth search stays (not a sphere nor a
    convex polyhedron of at most MAX_CONVEX_PLANES planes)."""
    world_from_object = obj.world_from_object()
    sphere = world_sphere(obj.mesh, world_from_object)
    if sphere is not None:
        return ConvexShape(sphere=sphere)
    planes = obj.mesh.face_planes(MAX_CONVEX_PLANES)
    if planes is None:
        return None
    m = np.asarray(world_from_object, dtype=np.float64)
    normals = planes[:, :3] @ normal_matrix(m).T
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    points = (planes[:, :3] * planes[:, 3:]) @ m[:3, :3].T + m[:3, 3]  # a point of each plane, moved
    return ConvexShape(planes=np.column_stack([normals, np.einsum("ij,ij->i", normals, points)]))


def convex_defines(frame) -> dict:
    """CONVEX_EXITS for this frame's glass shader: 1 where every glass object has an exact shape (the depth
    search is compiled out), 2 where some have (chosen per object at run time), 0 where none has."""
    glass = frame.scene.objects_of("glass")
    exact = [convex_shape(o) is not None for o in glass]
    return {"CONVEX_EXITS": 1 if exact and all(exact) else 2 if any(exact) else 0}


def bind_convex_shape(program, obj) -> None:
    """Set the shader's convex_kind, convex_planes, convex_plane_count and convex_sphere for ``obj``."""
    shape = convex_shape(obj) if obj.material.kind == "glass" else None
    if shape is None:
        set_uniform(program, "convex_kind", SHAPE_NONE)
        return
    if shape.sphere is not None:
        center, radius = shape.sphere
        set_uniform(program, "convex_kind", SHAPE_SPHERE)
        set_uniform(program, "convex_sphere", np.append(center, radius).astype("f4"))
        return
    planes = np.zeros((MAX_CONVEX_PLANES, 4), "f4")
    planes[:len(shape.planes)] = shape.planes
    set_uniform(program, "convex_kind", SHAPE_PLANES)
    set_uniform(program, "convex_plane_count", len(shape.planes))
    write_uniform_array(program, "convex_planes", planes)
