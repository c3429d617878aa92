"""Deferred shading of ShadeSurfaces' ``deferred`` kinds: a G-buffer, then one shading per visible pixel.

A CPU rasterizer (llvmpipe) shades each triangle's partly covered pixel blocks whole, so a costly
surface shader on small triangles runs at many pixels it never writes. The deferred kinds draw a
G-buffer instead (DEFERRED_SHADING in common/surface_inputs.glsl: the eye-facing normal times the
object's id, the distance along the ray); the resolve turns each pixel's id into a depth key and
draws one screen rectangle per object at its key, depth test EQUAL: each visible pixel is shaded
once. A ``staged`` kind resolves in two stages: the first flags the pixels that need a costlier
path, the second shades those alone (a CPU rasterizer skips every pixel failing an early depth
test, not a branch no pixel of its vector takes).

``shade`` below is the ShadeSurfaces run: its ``fragment``, ``staged``, ``deferred_unit`` (a free
texture unit), ``set_frame_uniforms`` and ``set_object_uniforms``.
"""
from __future__ import annotations

import moderngl
import numpy as np

from ...gpu.meshes import set_uniform
from ...render.draw import screen_rect
from ...render.frame import Frame

DEFER_SHADE_NOW, DEFER_GBUFFER, DEFER_RESOLVE = 1, 2, 3  # DEFERRED_SHADING (common/surface_inputs.glsl)
MAX_DEFERRED = 255  # G-buffer ids 1..255 keyed as depth id / 256
SECOND_STAGE_KEY = 1.0 / 512.0  # a staged object's second-stage pixels: depth id / 256 + this, between the ids


def defers(drawn: list, kinds: tuple[str, ...]) -> bool:
    """Whether a run drawing ``drawn`` ((object, material) pairs) defers ``kinds``: some are drawn, and
    at most MAX_DEFERRED (G-buffer ids); beyond, every object is shaded per fragment."""
    return 0 < sum(1 for _, material in drawn if material.kind in kinds) <= MAX_DEFERRED


def gbuffer_targets(gpu, color, exit_direction, g_buffer, depth, front=None) -> dict:
    """The framebuffer each DEFERRED_SHADING mode draws into; with ``front`` (the front-surface buffer),
    'glass': the glass G-buffer draw that fills it too (ShadeSurfaces' captures_front_surface)."""
    targets = {DEFER_SHADE_NOW: gpu.targets.framebuffer([color, exit_direction, g_buffer], depth),
               DEFER_GBUFFER: gpu.targets.framebuffer([g_buffer], depth)}
    if front is not None:
        targets["glass"] = gpu.targets.framebuffer([g_buffer, front], depth)
    return targets


def resolve(frame: Frame, shade, deferred: list, color, exit_direction, g_buffer) -> None:
    """Shade each deferred object ((object, material, defines) in G-buffer id order) at its visible
    pixels: a depth key per pixel from the G-buffer's ids (deferred_key.frag, drawn over each object's
    screen rectangle), then one screen rectangle per object at its key, depth test EQUAL.
    Objects of a ``staged`` kind flag pixels for a second stage (resolve_second_stage)."""
    gpu, ctx = frame.gpu, frame.gpu.ctx
    key_depth = frame.texture(frame.camera.size, "depth")
    g_unit = shade.deferred_unit
    key_fbo = gpu.targets.framebuffer([], key_depth)
    key_fbo.use()
    key_fbo.clear(depth=1.0)
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "1"
    g_buffer.use(g_unit)
    rects = [screen_rect(obj.world_mesh().bounds, frame.camera) for obj, _, _ in deferred]
    keys = gpu.shaders.program("passes/shading/deferred_resolve.vert", "passes/shading/deferred_key.frag")
    set_uniform(keys, "deferred_surface", g_unit)
    set_uniform(keys, "deferred_key", 0.5)  # the quad's depth: unused, the shader writes its key
    for rect in rects:  # each object's screen rectangle, not the whole viewport
        set_uniform(keys, "deferred_rect", rect)
        gpu.draw_fullscreen(keys, vertices=6)

    resolve_fbo = gpu.targets.framebuffer([color, exit_direction], key_depth)
    staged = [(index, obj, material, variant_defines, rect)
              for index, ((obj, material, variant_defines), rect) in enumerate(zip(deferred, rects), start=1)
              if material.kind in shade.staged]
    refine = frame.zeroed(frame.camera.size, "r32f") if staged else None  # stage-1 flags: the key
    ctx.depth_func = "=="
    for index, ((obj, material, variant_defines), rect) in enumerate(zip(deferred, rects), start=1):
        stage = 1 if material.kind in shade.staged else 0
        fbo = gpu.targets.framebuffer([color, exit_direction, refine], key_depth) if stage else resolve_fbo
        fbo.use()
        fbo.depth_mask = False
        draw_resolve(frame, shade, obj, material, {**variant_defines, "DEFER_STAGE": stage}, index / 256.0, rect)
    if staged:
        resolve_second_stage(frame, shade, staged, refine, key_fbo, resolve_fbo)
    resolve_fbo.depth_mask = True
    ctx.depth_func = "<"


def resolve_second_stage(frame: Frame, shade, staged: list, refine, key_fbo, resolve_fbo) -> None:
    """The second stage of ``staged`` objects ((index, object, material, defines, screen rectangle)):
    the pixels the first flagged in ``refine`` (their object's key, index / 256) get the key
    index / 256 + SECOND_STAGE_KEY in ``key_fbo``'s depth (deferred_refine_key.frag, within the
    object's rectangle), then DEFER_STAGE 2 shades them, drawn at that key with the EQUAL test of
    ``resolve_fbo``."""
    gpu, ctx = frame.gpu, frame.gpu.ctx
    refine_unit = shade.deferred_unit + 1
    refine.use(refine_unit)
    keys = gpu.shaders.program("passes/shading/deferred_resolve.vert", "passes/shading/deferred_refine_key.frag")
    set_uniform(keys, "deferred_refine", refine_unit)
    key_fbo.use()
    key_fbo.depth_mask = True
    ctx.depth_func = "1"
    for index, _, _, _, rect in staged:
        set_uniform(keys, "deferred_key", index / 256.0)
        set_uniform(keys, "second_stage_key", index / 256.0 + SECOND_STAGE_KEY)
        set_uniform(keys, "deferred_rect", rect)
        gpu.draw_fullscreen(keys, vertices=6)
    resolve_fbo.use()
    resolve_fbo.depth_mask = False
    ctx.depth_func = "=="
    for index, obj, material, variant_defines, rect in staged:
        draw_resolve(frame, shade, obj, material, {**variant_defines, "DEFER_STAGE": 2},
                     index / 256.0 + SECOND_STAGE_KEY, rect)


def draw_resolve(frame: Frame, shade, obj, material, defines: dict, key: float, rect) -> None:
    """One deferred object's resolve rectangle ``rect`` (screen_rect), drawn at depth ``key`` into
    the bound framebuffer."""
    gpu = frame.gpu
    program = gpu.shaders.program("passes/shading/deferred_resolve.vert", shade.fragment,
                                  {**defines, "DEFERRED_SHADING": DEFER_RESOLVE})
    shade.set_frame_uniforms(frame, program, frame.optional("caustic_maps"))
    set_uniform(program, "deferred_surface", shade.deferred_unit)
    set_ray_uniforms(program, frame.camera)
    set_uniform(program, "deferred_key", key)
    set_uniform(program, "deferred_rect", rect)
    shade.set_object_uniforms(frame, program, obj, material)
    gpu.draw_fullscreen(program, vertices=6)


def set_ray_uniforms(program, camera) -> None:
    """What deferred_pixel_ray (common/surface_inputs.glsl) needs to rebuild a pixel's ray."""
    set_uniform(program, "deferred_world_from_clip", np.linalg.inv(camera.clip_from_world()))
    set_uniform(program, "deferred_viewport", np.array(camera.size, "f4"))


