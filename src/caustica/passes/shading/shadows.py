"""Light samples and shadow maps (distance maps) for diffuse receivers.

Directional lights: orthographic map fitted around the scene. Spot lights: a
perspective map over the outer cone. Point lights (and each point of a line
light): a six-face atlas, 6N x N, in the face layout of ``CUBE_FORWARD`` /
``CUBE_UP``. Every map stores the distance to the light in r32f. Receivers
(common/lighting.glsl) filter 3x3 texels, comparing each texel's distance with
where that texel's ray from the light meets the receiver's tangent plane, moved
SHADOW_NORMAL_OFFSET texel widths along the normal: no self-shadowing at grazing
angles, and the shadow of an occluder resting on the receiver stays attached.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...cache import scene_state_key
from ...gpu.meshes import set_uniform
from ...lighting.samples import CUBE_FORWARD, CUBE_UP, LightSample, light_samples, scene_sphere
from ...render.draw import draw_objects
from ...render.frame import Channel, Frame, Pass
from ...scene.codes import LIGHT_DIRECTIONAL, LIGHT_POINT
from ...scene.transform import look_at_view_from_world, perspective_clip_from_view


class ShadowMaps(Pass):
    """Distance-to-light maps for every light sample (reused while lights and objects stay put)."""

    reads = ()
    writes = (
        Channel("light_samples", "host[light]", "point/directional/spot samples with their shadow projections"),
        Channel("shadow_maps", "r32f[light]", "per light sample: distance to the light (6-face atlas for points)"),
    )

    def __init__(self, size: int = 1024):
        self.size = size

    def cache_key(self, frame: Frame):
        return (self.size, scene_state_key(frame.scene))

    def run(self, frame: Frame) -> None:
        samples = light_samples(frame.scene)
        frame.write("light_samples", samples)
        frame.write("shadow_maps", [distance_map(frame, [s], frame.scene.objects, self.size) for s in samples])

def distance_map(frame: Frame, samples: list[LightSample], objects, n: int):
    """One distance map of ``objects``, ``n`` texels a side per face: a point sample's six-face atlas, or the
    directional and spot ``samples`` as tiles side by side."""
    ctx, gpu = frame.gpu.ctx, frame.gpu
    sample = samples[0]
    faces = 6 if sample.type == LIGHT_POINT else len(samples)
    color = frame.own(ctx.texture((n * faces, n), 1, dtype="f4"))  # nearest filtered, unlike pooled ones
    depth = frame.own(ctx.depth_renderbuffer((n * faces, n)))
    fbo = frame.own(ctx.framebuffer([color], depth))
    along = 1 if sample.type == LIGHT_DIRECTIONAL else 0
    program = gpu.shaders.program("common/mesh_vertex.glsl", "passes/shading/distance.frag", {"ALONG_DIRECTION": along})
    fbo.use()
    fbo.clear(1e30, 1e30, 1e30, 1e30, depth=1.0)
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.disable(moderngl.CULL_FACE)
    center, radius = scene_sphere(frame.scene)
    for face in range(faces):
        fbo.viewport = (face * n, 0, n, n)
        if sample.type == LIGHT_POINT:
            p = sample.position
            view = look_at_view_from_world(p, p + CUBE_FORWARD[face], CUBE_UP[face])
            far = np.linalg.norm(p - center) + 2 * radius
            clip = perspective_clip_from_view(90.0, 1.0, 1e-3 * radius, far) @ view
        else:
            sample = samples[face]
            clip = sample.clip_from_world
        set_uniform(program, "origin", sample.position.astype("f4"))
        set_uniform(program, "direction", sample.direction.astype("f4"))
        draw_objects(frame, program, objects, clip)
    color.filter = (moderngl.NEAREST, moderngl.NEAREST)
    return color


