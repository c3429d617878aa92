"""Exact exits from glass of known shape: depth-search's ``convex_exits`` (ours).

Hu and Qin (TVCG 2007, 2.1) find the exit P2 in screen space, against one layer of front and one of
back faces; they note that this "could render the accurate result for a convex object" at two
interfaces, and that total internal reflection and multi-interface refraction "are still not well
supported" (section 6). In a glass block the light entering a face leaves only through that face or
the opposite one (for IOR above sqrt 2 every adjacent face reflects it totally), so most of its
paths cross three or four interfaces, and each internal exit searched in screen space lands on the
wrong face (docs/measured-defaults.md has the figures).

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
  differ only where the shading normal turns away from the ray, at grazing exits);
- a mesh whose faces lie on a few planes, balls and round cylinders (``Mesh.face_solid``: a spectacle lens's
  two caps and rim, a plano-convex lens, a meniscus), at most :data:`MAX_CONVEX_QUADRICS` of the round kinds:
  the body is the intersection of the half-spaces and of each ball's or cylinder's inside, or outside where the
  face is concave, so a ray inside leaves where it first crosses one of their boundaries (the normal there the
  ball's or cylinder's own; the facets lie within 0.2 % of the mesh's size of them).

``shaders/common/convex_exits.glsl`` does the intersections; the internal bounces then follow the
reflected light from exact point to exact point, off-screen too. Other glass keeps the depth search.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...gpu.meshes import set_uniform, write_uniform_array
from ...raytrace.embree_scene import world_sphere
from ...scene.transform import normal_matrix

MAX_CONVEX_PLANES = 128  # uniform vec4s: 4 a plane (its plane and normal field); llvmpipe allows 4096
MAX_CONVEX_QUADRICS = 4  # the round faces' balls and cylinders (a lens has two balls and a cylinder)
SHAPE_NONE, SHAPE_SOLID = 0, 1  # convex_kind in the shader
# CONVEX_EXITS: no glass object of the frame has an exact shape, every one has, some have (chosen per object)
EXITS_SEARCHED, EXITS_ALL_EXACT, EXITS_SOME_EXACT = CONVEX_EXITS_MODES = (0, 1, 2)


@dataclass(frozen=True)
class ConvexShape:
    """A glass object's exact shape in world space: the intersection of half-spaces ``planes`` (K, 4: outward
    unit normal, offset w with n . x <= w inside), whose ``normals`` (K, 3, 4) give the shading normal's affine
    field on each (unnormalised), and of the sides of balls and round cylinders ``quadrics`` (Q, 8: centre,
    signed radius r, inside where r > 0 and outside where r < 0; a cylinder's unit axis and 1, zeros for a ball)."""

    planes: np.ndarray
    normals: np.ndarray
    quadrics: np.ndarray


def convex_shape(obj) -> ConvexShape | None:
    """The exact shape of ``obj`` in world space, or None where the depth search stays: an analytic sphere, or
    a mesh bounded by at most MAX_CONVEX_PLANES planes with one normal field on each and MAX_CONVEX_QUADRICS
    balls and cylinders (Mesh.face_solid; those under a uniform scale only)."""
    world_from_object = obj.world_from_object()
    sphere = world_sphere(obj.mesh, world_from_object)
    if sphere is not None:
        return ConvexShape(np.zeros((0, 4)), np.zeros((0, 3, 4)), np.concatenate([sphere[0], [sphere[1]], np.zeros(4)])[None])
    solid = obj.mesh.face_solid(MAX_CONVEX_PLANES, MAX_CONVEX_QUADRICS)
    if solid is None:
        return None
    planes, fields, quadrics = solid
    m = np.asarray(world_from_object, dtype=np.float64)
    scales = np.linalg.norm(m[:3, :3], axis=0)
    if len(quadrics) and np.ptp(scales) > 1e-9 * scales.max():
        return None  # a ball would become an ellipsoid
    to_world = normal_matrix(m)
    normals = planes[:, :3] @ to_world.T
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-300)
    points = (planes[:, :3] * planes[:, 3:]) @ m[:3, :3].T + m[:3, 3]  # a point of each plane, moved
    # A field n(y) = A y + b in object space, y = M^-1 (x - t), is to_world (A M^-1 x + b - A M^-1 t) in the world's.
    linear = to_world @ fields[:, :, :3] @ np.linalg.inv(m[:3, :3])
    constant = np.einsum("ij,kj->ki", to_world, fields[:, :, 3]) - linear @ m[:3, 3]
    # A mirroring transform keeps a quadric's side (the radius is a length, its sign the side).
    moved = np.column_stack([quadrics[:, :3] @ m[:3, :3].T + m[:3, 3], quadrics[:, 3] * scales[0],
                             quadrics[:, 4:7] @ m[:3, :3].T / scales[0], quadrics[:, 7]])
    return ConvexShape(np.column_stack([normals, np.einsum("ij,ij->i", normals, points)]),
                       np.concatenate([linear, constant[:, :, None]], axis=2), moved)


def convex_defines(frame) -> dict:
    """CONVEX_EXITS for this frame's glass shader: 1 where every glass object has an exact shape (the depth
    search is compiled out), 2 where some have (chosen per object at run time), 0 where none has; and
    MAX_CONVEX_PLANES."""
    glass = frame.scene.objects_of("glass")
    exact = [convex_shape(o) is not None for o in glass]
    mode = EXITS_ALL_EXACT if exact and all(exact) else EXITS_SOME_EXACT if any(exact) else EXITS_SEARCHED
    return {"CONVEX_EXITS": mode,
            "MAX_CONVEX_PLANES": MAX_CONVEX_PLANES, "MAX_CONVEX_QUADRICS": MAX_CONVEX_QUADRICS}


def bind_convex_shape(program, obj) -> None:
    """Set the shader's convex_kind, convex_planes, convex_normals, convex_plane_count, convex_quadrics and
    convex_quadric_count for ``obj``."""
    shape = convex_shape(obj) if obj.material.kind == "glass" else None
    if shape is None:
        set_uniform(program, "convex_kind", SHAPE_NONE)
        return
    count = len(shape.planes)
    planes, normals = np.zeros((MAX_CONVEX_PLANES, 4), "f4"), np.zeros((3 * MAX_CONVEX_PLANES, 4), "f4")
    planes[:count], normals[:3 * count] = shape.planes, shape.normals.reshape(-1, 4)
    quadrics = np.zeros((2 * MAX_CONVEX_QUADRICS, 4), "f4")
    quadrics[:2 * len(shape.quadrics)] = shape.quadrics.reshape(-1, 4)
    set_uniform(program, "convex_kind", SHAPE_SOLID)
    set_uniform(program, "convex_plane_count", count)
    set_uniform(program, "convex_quadric_count", len(shape.quadrics))
    write_uniform_array(program, "convex_planes", planes)
    write_uniform_array(program, "convex_normals", normals)
    write_uniform_array(program, "convex_quadrics", quadrics)
