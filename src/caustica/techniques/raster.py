"""Shared driver for rasterized techniques: supersampling, pass wiring, readback."""
from __future__ import annotations

import math

import moderngl
import numpy as np

from ..gpu.meshes import set_uniform
from ..passes.base import Frame, run_passes
from .base import Technique


def supersampling_factor(spp: int) -> int:
    """Samples per pixel become a k x k grid (k = round(sqrt(spp)))."""
    return max(1, int(round(math.sqrt(max(1, spp)))))


def box_downsample(image: np.ndarray, k: int) -> np.ndarray:
    """Average k x k blocks: the box pixel filter of the reference renderers."""
    if k == 1:
        return image
    h, w, c = image.shape
    return image.reshape(h // k, k, w // k, k, c).mean(axis=(1, 3))


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


def read_rgba(texture) -> np.ndarray:
    """A float texture as a (H, W, components) float32 array, row 0 at the top."""
    w, h = texture.size
    data = np.frombuffer(texture.read(), dtype="f4").reshape(h, w, texture.components)
    return np.ascontiguousarray(data[::-1])


def read_rgb(texture) -> np.ndarray:
    """An RGBA32F texture as a (H, W, 3) float32 image, row 0 at the top."""
    return np.ascontiguousarray(read_rgba(texture)[:, :, :3])


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
