"""Passes of Wyman's image-space refraction: the per-vertex d_N and its front-face buffer.

d_N (Wyman, "Approximating Distance d_1", fig. 6.3.3) is the distance from a
vertex along its negative normal to the far side of the refractor. It is
computed exactly with Embree once per mesh and cached in memory and on disk
(``$CAUSTICA_CACHE/dn`` or ``~/.cache/caustica/dn``, one ``<hash>.npy`` per mesh).

The shared surface-shading pass draws with the common mesh vertex stage, which
forwards only position and normal, so the interpolated d_N reaches the shading
shader through a screen-space buffer written here (``front_dn``).
"""
from __future__ import annotations

import numpy as np

from ...cache import LruCache
from ...gpu.meshes import set_uniform
from ...render.draw import draw_refractor_buffer
from ...render.frame import Channel, Frame, Pass

DN_ATTRIBUTE = "in_dn"
MEMORY_ENTRIES = 64  # an animated refractor has new geometry each frame
_MEMORY: LruCache = LruCache(MEMORY_ENTRIES)  # mesh geometry hash -> d_N, the MEMORY_ENTRIES most recently used


def distance_along_normal(mesh) -> np.ndarray:
    """Wyman's d_N per vertex (object space, float32), exact with Embree, cached per mesh."""
    from ...cache import cache_dir, load_array, store_array
    from ...raytrace.paths import distance_along_negative_normal

    key = mesh.geometry_hash()
    cached = _MEMORY.get(key)
    if cached is not None:
        return cached
    path = cache_dir("dn") / f"{key}.npy"
    values = load_array(path, (len(mesh.vertices),), np.float32)
    if values is None:
        values = distance_along_negative_normal(mesh).astype(np.float32)
        store_array(path, values)
    values.setflags(write=False)
    _MEMORY[key] = values
    return values


class FrontDistanceAlongNormal(Pass):
    """Nearest front faces of the refractors: interpolated d_N (world units) and eye distance."""

    reads = ()
    writes = (Channel("front_dn", "rg32f",
                      "nearest front-facing refractor surface: Wyman's d_N in world units (x), eye distance (y; 0: none)"),)

    def run(self, frame: Frame) -> None:
        gpu = frame.gpu
        # Upload d_N once per mesh as a vertex attribute.
        for obj in frame.scene.objects_of("glass"):
            gpu_mesh = gpu.meshes.get(obj.mesh)
            if DN_ATTRIBUTE not in gpu_mesh.attributes:
                gpu_mesh.set_attribute(DN_ATTRIBUTE, distance_along_normal(obj.mesh))
        program = gpu.shaders.program("passes/shading/image_space.vert", "passes/shading/image_space_dn.frag")
        set_uniform(program, "origin", frame.camera.position.astype("f4"))
        frame.write("front_dn", draw_refractor_buffer(frame, program, "rg32f", "front", "nearest"))
