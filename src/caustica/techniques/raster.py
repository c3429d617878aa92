"""Shared driver for rasterized techniques: pass wiring, supersampling (averaged on the GPU), readback of the colour."""
from __future__ import annotations

import moderngl
import numpy as np

from ..gpu.meshes import set_uniform
from ..gpu.readback import box_downsample, read_rgb, read_rgba, supersampling_factor  # noqa: F401 (re-exported)
from ..passes.base import Frame, run_passes
from .base import Technique


def gpu_box_downsample(frame: Frame, texture, k: int):
    """``texture`` (rgba32f) averaged over k x k blocks on the GPU: a pooled texture k times smaller."""
    gpu = frame.gpu
    width, height = texture.size
    out = gpu.targets.texture((width // k, height // k), "rgba32f")
    gpu.targets.framebuffer([out]).use()
    gpu.ctx.disable(moderngl.DEPTH_TEST | moderngl.BLEND)
    program = gpu.shaders.program("passes/fullscreen.vert", "passes/box_downsample.frag", {"K": int(k)})
    texture.use(0)
    set_uniform(program, "source", 0)
    gpu.draw_fullscreen(program)
    return out


class RasterTechnique(Technique):
    """A technique made of GPU passes; ``build_passes`` wires them for given parameters."""

    def build_passes(self, params) -> list:
        raise NotImplementedError

    def render(self, renderer, scene, camera, params, spp):
        k = supersampling_factor(spp)
        width, height = camera.size
        frame = Frame(renderer.device, scene, camera.with_size(width * k, height * k), params,
                      pass_ms={} if renderer.profile_passes else None)
        run_passes(self.build_passes(params), frame)
        if k == 1:
            image = read_rgb(frame.read("color"))
        else:  # averaged on the GPU: a k^2 smaller readback, no CPU pass over every sample
            averaged = gpu_box_downsample(frame, frame.read("color"), k)
            image = read_rgb(averaged)
            frame.gpu.targets.give_back(averaged)
        renderer.keep_channels(frame)
        renderer.last_pass_ms = dict(frame.pass_ms or {})
        return image.astype(np.float32)
