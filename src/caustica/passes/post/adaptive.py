"""Adaptive anti-aliasing: 2 x 2 supersampling only at the pixels where the 1-spp image has an edge.

After Whitted's adaptive supersampling ("An Improved Illumination Model for Shaded Display", CACM 1980,
section 4): sample once per pixel, and sample more only where neighbouring samples differ by more than a
threshold. Here the 1-spp frame is flagged by AdaptiveFlags; the 4-spp frame then runs with the depth
buffer set to the nearest depth at unflagged pixels (preset_depth, called by ShadeSurfaces), so an early
depth test rejects their shading; combined() keeps the box-filtered 4 samples at flagged pixels and the
1-spp pixel elsewhere (docs/antialiasing.md).
"""
from __future__ import annotations

import numpy as np

from ...gpu.meshes import set_uniform
from ...gpu.readback import read_rgba
from ...render.draw import fullscreen_pass
from ...render.frame import Channel, Frame, Pass

THRESHOLD = 0.01  # a pixel is flagged when a neighbour's compressed channel c / (1 + c) differs by more
FLAGS = Channel("adaptive_flags", "r32f", "1 where a pixel's compressed colour c / (1 + c) differs from an "
                "8-neighbour's by more than THRESHOLD in some channel, else 0 (output size)")


class AdaptiveFlags(Pass):
    """The pixels of the 1-spp colour that adaptive anti-aliasing supersamples (FLAGS)."""

    reads = ("color",)
    writes = (FLAGS,)

    def run(self, frame: Frame) -> None:
        frame.write(FLAGS.name, fullscreen_pass(frame, frame.read("color"), "passes/post/adaptive_flags.frag",
                                                {"THRESHOLD": THRESHOLD}, 1, "r32f"))


def read_flags(flags) -> np.ndarray:
    """AdaptiveFlags' ``flags`` read back: (H, W) bool, True where flagged, row 0 at the top."""
    return read_rgba(flags, copy=False)[..., 0] > 0.5


def preset_depth(frame: Frame, depth, flags) -> None:
    """``depth`` (the frame's camera depth buffer, cleared to 1) set to 0, the nearest, at the samples of
    pixels ``flags`` leaves unflagged (shaders/passes/post/adaptive_skip.frag), so that no object or background
    drawn after it with a LESS or LEQUAL test shades there."""
    import moderngl

    gpu, ctx = frame.gpu, frame.gpu.ctx
    factor = frame.camera.size[0] // flags.size[0]
    fbo = gpu.targets.framebuffer([], depth)
    fbo.use()
    ctx.enable(moderngl.DEPTH_TEST)
    ctx.depth_func = "1"
    program = gpu.shaders.program("common/fullscreen.vert", "passes/post/adaptive_skip.frag", {"K": int(factor)})
    flags.use(0)
    set_uniform(program, "adaptive_flags", 0)
    gpu.draw_fullscreen(program)
    ctx.depth_func = "<"


def combined(frame: Frame, single, averaged, flags):
    """The adaptive image: ``averaged`` (the 4-spp colour box-filtered to the output size) at the pixels
    ``flags`` flags, ``single`` (the 1-spp colour) elsewhere; a new rgba32f texture lent to ``frame``."""
    return fullscreen_pass(frame, single, "passes/post/adaptive_resolve.frag", {}, 1,
                           inputs={"averaged": averaged, "adaptive_flags": flags})
