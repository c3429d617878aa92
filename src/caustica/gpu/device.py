"""GpuDevice: the context and the pools every pass uses (shaders, targets, meshes)."""
from __future__ import annotations

import moderngl
import numpy as np

from .context import describe, shared_context
from .meshes import MeshCache
from .shaders import ShaderLibrary
from .targets import TargetPool


class GpuDevice:
    def __init__(self, ctx=None):
        self.ctx = ctx or shared_context()
        self.shaders = ShaderLibrary(self.ctx)
        self.targets = TargetPool(self.ctx)
        self.meshes = MeshCache(self.ctx)
        self.info = describe(self.ctx)
        self.cache: dict = {}  # results reused across frames (e.g. shadow maps), keyed by scene state
        self._environments: dict[int, tuple] = {}

    @property
    def max_texture_size(self) -> int:
        return self.info["max_texture_size"]

    def environment_texture(self, environment):
        """The environment image as an RGB32F texture: linear filter, wrap in x, clamp in y."""
        key = id(environment.image)
        entry = self._environments.get(key)
        if entry is None or entry[0] is not environment.image:
            if entry is not None:
                entry[1].release()
            h, w = environment.image.shape[:2]
            tex = self.ctx.texture((w, h), 3, np.ascontiguousarray(environment.image, dtype="f4").tobytes(), dtype="f4")
            tex.repeat_x, tex.repeat_y = True, False
            tex.filter = (moderngl.LINEAR, moderngl.LINEAR)
            entry = (environment.image, tex)
            self._environments[key] = entry
        return entry[1]

    def draw_fullscreen(self, program, vertices: int = 3) -> None:
        """Triangles whose vertex stage makes them from gl_VertexID (passes/fullscreen.vert: one
        triangle over the viewport) with ``program``; its attribute-less vertex array is kept."""
        key = ("fullscreen", program.glo)
        vao = self.cache.get(key)
        if vao is None:
            vao = self.cache[key] = self.ctx.vertex_array(program, [])
        vao.render(moderngl.TRIANGLES, vertices=vertices)

    def finish(self) -> None:
        self.ctx.finish()

    def release(self) -> None:
        self.shaders.release()
        self.targets.release()
        self.meshes.release()
        for _, tex in self._environments.values():
            tex.release()
        self._environments.clear()
        release_all(list(self.cache.values()))
        self.cache.clear()


def release_all(value) -> None:
    """Release every GL object in a (nested) list, tuple, dict or dataclass of cached results."""
    if isinstance(value, (list, tuple)):
        for item in value:
            release_all(item)
    elif isinstance(value, dict):
        release_all(list(value.values()))
    elif hasattr(value, "release") and hasattr(value, "glo"):
        value.release()
    elif hasattr(value, "__dataclass_fields__"):
        release_all([getattr(value, name) for name in value.__dataclass_fields__])
