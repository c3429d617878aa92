"""Multisampled anti-aliasing of the outlines: geometry at SAMPLES samples per pixel, shading at one.

After Chajed, Lefohn and Luebke, "Subpixel Reconstruction Antialiasing for Deferred Shading" (I3D 2011),
section 3. The technique's graph shades each pixel once, at its centre, as at 1 spp. Afterwards every
object is drawn twice more with a trivial shader (labels.frag with ID_DEPTH: object id, view depth), at the pixel
centres and into a multisampled target, whose samples give each pixel its true geometric coverage: a
CPU or GPU rasterizer runs that shader once per pixel (llvmpipe included), so the multisampled draw costs
about what a single-sampled one does. The resolve (shaders/passes/post/subpixel_resolve.frag) gives each
sample the colour of a nearby centre that saw the same surface (same object, nearest depth), and averages
the samples. It fixes what the geometry makes: outlines and the edges where one object hides another
or itself. It knows nothing of edges inside the shading (a shadow, a caustic, the environment through
glass): those are the footprint filter's and supersampling's (docs/antialiasing.md).
"""
from __future__ import annotations

from ...errors import RenderOptionError
from ...gpu.meshes import set_uniform
from ...render.frame import Frame
from .labels import draw_first_surfaces, label_program

SAMPLES = 4  # geometry samples per pixel (llvmpipe's GL_MAX_SAMPLES is 4)
DEPTH_TOLERANCE = 0.02  # centres whose depth is this fraction of the sample's within the best match tie
GEOMETRY = "rg32f"  # what each centre and sample saw: object id, view depth
# The targets the reconstruction adds to a frame's, as (format, samples): its one-sample scratch depth and its
# rgba32f output reuse targets of those formats that the technique's graph gave back (frame_limits counts these).
TARGETS = ((GEOMETRY, 1), (GEOMETRY, SAMPLES), ("depth", SAMPLES))


def check_multisampling(gpu) -> None:
    """RenderOptionError unless ``gpu``'s context can draw SAMPLES samples per pixel."""
    available = int(gpu.ctx.max_samples)
    if available < SAMPLES:
        raise RenderOptionError(f"antialias 'msaa' needs {SAMPLES} samples per pixel and this GL context offers "
                                f"{available}; use antialias 'edge' or spp 4 instead")


def reconstructed(frame: Frame, color, out):
    """``color`` (rgba32f at ``frame``'s camera size, shaded at pixel centres) resolved into ``out`` with the
    coverage of SAMPLES geometry samples per pixel of ``frame.scene`` seen by ``frame.camera``. Reads the
    scene's objects alone; the centre and sample geometry it draws are lent to ``frame``."""
    from ...labels import material_indices

    check_multisampling(frame.gpu)
    camera, materials = frame.camera, material_indices(frame.scene)
    program = {False: label_program(frame, camera, {"ID_DEPTH": 1})}
    centres = frame.texture(camera.size, GEOMETRY)
    samples = frame.texture(camera.size, GEOMETRY, SAMPLES)
    draw_first_surfaces(frame, camera, [centres], program, materials)
    draw_first_surfaces(frame, camera, [samples], program, materials, samples=SAMPLES)
    resolve = frame.gpu.shaders.program("common/fullscreen.vert", "passes/post/subpixel_resolve.frag",
                                        {"SAMPLES": SAMPLES})
    for unit, (name, texture) in enumerate((("color", color), ("centre_geometry", centres),
                                            ("sample_geometry", samples))):
        texture.use(unit)
        set_uniform(resolve, name, unit)
    set_uniform(resolve, "depth_tolerance", DEPTH_TOLERANCE)
    frame.gpu.targets.framebuffer([out]).use()
    frame.gpu.draw_fullscreen(resolve)
    return out
