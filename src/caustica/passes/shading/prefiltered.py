"""Image-based lighting of glossy opaque surfaces with the split-sum method (Karis, SIGGRAPH 2013 course): the
environment (less its sun where that is a light) prefiltered with GGX's lobe per roughness level
(common/environment.glsl prefiltered_radiance), and the (A, B) table of scene/microfacet.py on the GPU
(common/microfacet.glsl split_sum).

Both are computed once and kept in GpuDevice.cache: the prefiltered atlas by the environment image's content,
the table once per device."""
from __future__ import annotations

import moderngl
import numpy as np

from ...cache import array_digest
from ...raytrace.environment_light import environment_light
from ...scene.microfacet import brdf_table

PREFILTER_LEVELS = 6  # roughness 0, 0.2, ..., 1
PREFILTER_WIDTH = 256  # each level's width (texels; half as many rows), at most the environment's own
PREFILTER_SAMPLES = 128  # GGX half vectors per texel (filtered importance sampling)


def reflected_environment(environment, samples):
    """The environment a glossy receiver's split sum reflects: without its sun where the light samples hold
    that sun (passes/shading/environment.py), whose light then comes as a directional light's, shadowed."""
    if any(getattr(sample, "environment", False) for sample in samples):
        return environment_light(environment).rest
    return environment


def prefiltered_environment(gpu, environment):
    """The prefiltered atlas of ``environment`` (PREFILTER_LEVELS bands of width x width / 2, rgba32f,
    linear, repeating in x), computed on first use (passes/shading/prefilter_environment.frag) and kept by
    the image's content."""
    key = ("prefiltered_environment", array_digest(environment.image))
    atlas = gpu.cache.get(key)
    if atlas is not None:
        return atlas
    image = np.ascontiguousarray(environment.image, dtype="f4")
    height, width = image.shape[:2]
    source = gpu.ctx.texture((width, height), 3, image.tobytes(), dtype="f4")
    source.repeat_x, source.repeat_y = True, False
    source.build_mipmaps()
    source.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
    try:
        atlas = prefilter_atlas(gpu, source, min(PREFILTER_WIDTH, max(2 * (width // 2), 4)))
    finally:
        source.release()
    gpu.cache[key] = atlas
    return atlas


def prefilter_atlas(gpu, source, band: int):
    """A new atlas of PREFILTER_LEVELS bands of ``band`` x ``band`` / 2 texels (rgba32f, linear, repeating in
    x): ``source``, a mipmapped equirect texture of the environment's mapping, prefiltered per roughness level
    (passes/shading/prefilter_environment.frag). Draws into its own framebuffer: bind the caller's again."""
    atlas = gpu.ctx.texture((band, band // 2 * PREFILTER_LEVELS), 4, dtype="f4")
    atlas.repeat_x, atlas.repeat_y = True, False
    atlas.filter = (moderngl.LINEAR, moderngl.LINEAR)
    fbo = gpu.ctx.framebuffer(color_attachments=[atlas])
    try:
        fbo.use()  # no depth attachment: the depth test passes every fragment
        program = gpu.shaders.program("common/fullscreen.vert", "passes/shading/prefilter_environment.frag")
        source.use(0)
        program["source"].value = 0
        program["levels"].value = PREFILTER_LEVELS
        program["width"].value = band
        program["samples"].value = PREFILTER_SAMPLES
        gpu.draw_fullscreen(program)
    finally:
        fbo.release()
    return atlas


def brdf_table_texture(gpu):
    """scene/microfacet.py's split-sum table as an rg32f texture, (cos_v, roughness) its (s, t), linear,
    clamped: texel centres where the table's samples are."""
    texture = gpu.cache.get(("brdf_table",))
    if texture is None:
        table = brdf_table()
        texture = gpu.ctx.texture((table.shape[1], table.shape[0]), 2, np.ascontiguousarray(table, "f4").tobytes(),
                                  dtype="f4")
        texture.repeat_x = texture.repeat_y = False
        texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
        gpu.cache[("brdf_table",)] = texture
    return texture
