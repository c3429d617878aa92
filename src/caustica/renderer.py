"""Renderer: one entry point for every technique, headless."""
from __future__ import annotations

import time

import numpy as np

from .errors import SceneError
from .scene import Scene
from .techniques.base import get_technique


class Renderer:
    """Render scenes with any technique: ``Renderer((512, 512)).render(scene, technique="env-map")``.

    ``size`` (width, height) overrides the scene camera's size; None keeps it.
    The GL context is created on first use of a GPU technique.
    """

    def __init__(self, size: tuple[int, int] | None = None, keep_channels: bool = False):
        self.size = None if size is None else (int(size[0]), int(size[1]))
        self._device = None
        self._keep = keep_channels
        self.channels: dict = {}

    @property
    def device(self):
        if self._device is None:
            from .gpu.device import GpuDevice

            self._device = GpuDevice()
        return self._device

    def camera_for(self, scene: Scene):
        camera = scene.camera if self.size is None else scene.camera.with_size(*self.size)
        return camera

    def render(self, scene: Scene, technique: str = "env-map", spp: int = 1, **params) -> np.ndarray:
        """A (H, W, 3) float32 linear RGB image, row 0 at the top."""
        image, _ = self.render_timed(scene, technique, spp, **params)
        return image

    def render_timed(self, scene: Scene, technique: str = "env-map", spp: int = 1, **params):
        """Render and return (image, milliseconds), the GPU finished before the clock stops."""
        tech = get_technique(technique)
        parameters = tech.make_params(**params)
        camera = self.camera_for(scene)
        self._check_size(camera.size, spp, tech.uses_gl)
        start = time.perf_counter()
        image = tech.render(self, scene, camera, parameters, int(spp))
        if tech.uses_gl:
            self.device.finish()
        return image, (time.perf_counter() - start) * 1000.0

    def _check_size(self, size, spp: int, uses_gl: bool) -> None:
        if spp < 1:
            raise SceneError(f"samples per pixel {spp} must be at least 1")
        width, height = size
        if width < 1 or height < 1:
            raise SceneError(f"image size {width}x{height} must be at least 1x1")
        if uses_gl:
            from .techniques.raster import supersampling_factor

            k = supersampling_factor(spp)
            limit = self.device.max_texture_size
            if max(width, height) * k > limit:
                raise SceneError(
                    f"image size {width}x{height} with {spp} spp needs {width * k}x{height * k} pixels, "
                    f"above this GL's limit of {limit}; use a smaller size or fewer samples"
                )

    def keep_channels(self, frame) -> None:
        """Remember the last frame's intermediate channels (for inspection) when asked to."""
        self.channels = dict(frame.channels) if self._keep else {}
        for name in ("back_depth", "color", "depth"):
            texture = frame.channels.get(name)
            if texture is not None and not self._keep:
                frame.gpu.targets.give_back(texture)

    def info(self) -> dict:
        return self.device.info
