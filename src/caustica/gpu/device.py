"""GpuDevice: the context and the pools every pass uses (shaders, targets, meshes).

Every pool is bounded, so that a process rendering new scenes for ever keeps a flat footprint:
render targets and meshes not used for ``IDLE_FRAMES`` frames are released (targets.py,
meshes.py), environment textures are kept by image content for the ``ENVIRONMENT_TEXTURES``
most recent images, albedo textures by content too, at most ``ALBEDO_TEXTURES`` and none unused
for ``IDLE_FRAMES`` frames, and ``cache`` (results reused across frames) holds at most
``CACHE_ENTRIES`` entries, least recently used first out. ``release`` frees all of it; the
context stays (shared), and so do the shader programs, which belong to it (gpu/shaders.py).
"""
from __future__ import annotations

import os

import moderngl
import numpy as np

from ..cache import LruCache, array_digest
from ..errors import SceneError
from .context import collect_dropped, describe, is_inherited, shared_context
from .meshes import IDLE_FRAMES, MeshCache
from .shaders import ShaderLibrary
from .targets import TargetPool


CACHE_ENTRIES = 128  # results kept across frames in GpuDevice.cache (a frame stores about ten)
ENVIRONMENT_TEXTURES = 4  # environment images kept on the GPU, by content
ALBEDO_TEXTURES = 64  # diffuse receivers' textures kept on the GPU, by content


class GpuDevice:
    def __init__(self, ctx=None):
        self.ctx = ctx or shared_context()
        self.pid = os.getpid()  # a forked child must not call into this device's (inherited) context
        collect_dropped(self.ctx)
        self.shaders = ShaderLibrary(self.ctx)
        self.targets = TargetPool(self.ctx)
        self.meshes = MeshCache(self.ctx)
        self.info = describe(self.ctx)
        # Results reused across frames (e.g. shadow maps), keyed by scene state.
        self.cache = LruCache(CACHE_ENTRIES, lambda value: release_all(value, self.targets))
        self._environments = LruCache(ENVIRONMENT_TEXTURES, lambda texture: texture.release())
        self._albedos = LruCache(ALBEDO_TEXTURES, lambda entry: entry[0].release())  # [texture, frame last used]
        self._fullscreen: dict[int, object] = {}  # program GL name -> attribute-less vertex array

    @property
    def max_texture_size(self) -> int:
        return self.info["max_texture_size"]

    def environment_texture(self, environment):
        """The environment image as an RGB32F texture, wrap in x, clamp in y: mipmapped for the footprint
        filter (common/environment.glsl), one level for ``bilinear`` (kept by the image's content and
        filter, so that reloading a scene finds the texture of an equal image)."""
        key = (array_digest(environment.image), environment.filter)
        texture = self._environments.get(key)
        if texture is None:
            h, w = environment.image.shape[:2]
            texture = self.ctx.texture((w, h), 3, np.ascontiguousarray(environment.image, dtype="f4").tobytes(),
                                       dtype="f4")
            texture.repeat_x, texture.repeat_y = True, False
            if environment.filter == "footprint":
                texture.build_mipmaps()
                texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
            else:
                texture.filter = (moderngl.LINEAR, moderngl.LINEAR)
            self._environments[key] = texture
        return texture

    def albedo_texture(self, image: np.ndarray):
        """A diffuse receiver's texture (scene/textures.py: (H, W, 3) linear RGB, row 0 at the top) as an
        RGB16F texture, rows uploaded top first so that GL's (u, v) is glTF's: trilinear (mipmaps),
        repeating (kept by the image's content, as environments are, and released after IDLE_FRAMES
        frames unused, as meshes are). SceneError above this GL's texture size."""
        key = array_digest(image)
        entry = self._albedos.get(key)
        if entry is not None:
            entry[1] = self.meshes.frame
            return entry[0]
        h, w = image.shape[:2]
        if max(w, h) > self.max_texture_size:
            raise SceneError(f"a {w}x{h} texture is above this GL's limit of {self.max_texture_size} pixels "
                             "a side; downscale it")
        # Half floats: 8-bit sources' values within 2^-11 relative, half the memory of RGB32F (a 4096^2
        # texture with mipmaps: 134 MB).
        texture = self.ctx.texture((w, h), 3, np.ascontiguousarray(image, dtype="f2").tobytes(), dtype="f2")
        texture.build_mipmaps()
        texture.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        texture.repeat_x = texture.repeat_y = True
        self._albedos[key] = [texture, self.meshes.frame]
        return texture

    def draw_fullscreen(self, program, vertices: int = 3) -> None:
        """Triangles whose vertex stage makes them from gl_VertexID (common/fullscreen.vert: one
        triangle over the viewport) with ``program``; its attribute-less vertex array is kept."""
        vao = self._fullscreen.get(program.glo)
        if vao is None or vao.program is not program:  # a GL name is reused once its program is gone
            if vao is not None:
                vao.release()
            vao = self._fullscreen[program.glo] = self.ctx.vertex_array(program, [])
        vao.render(moderngl.TRIANGLES, vertices=vertices)

    def finish(self) -> None:
        """Wait for the GPU; end the frame: release what was dropped unreleased and what sat idle in the pools."""
        self.ctx.finish()
        collect_dropped(self.ctx)
        self.targets.end_frame()
        self.meshes.end_frame()
        # Least recently used first: stop at the first texture drawn in the last IDLE_FRAMES frames.
        while self._albedos and self.meshes.frame - next(iter(self._albedos.values()))[1] > IDLE_FRAMES:
            self._albedos.pop_release(next(iter(self._albedos)))

    def counts(self) -> dict[str, int]:
        """How many entries each pool and cache holds (for leak checks; see also census.live_gl_names)."""
        return {"programs": self.shaders.count(), **self.targets.counts(), "meshes": len(self.meshes),
                "environments": len(self._environments), "albedo_textures": len(self._albedos),
                "cached": len(self.cache),
                "fullscreen_arrays": len(self._fullscreen)}

    def release(self) -> None:
        """Release every GL object the pools and caches hold. In a process forked after this device
        was made, only forget them: the inherited context must not be called."""
        if os.getpid() == self.pid and not is_inherited(self.ctx):
            release_all(list(self.cache.values()), self.targets)
            release_all([list(self._environments.values()), [entry[0] for entry in self._albedos.values()],
                         list(self._fullscreen.values())])
            self.shaders.release()
            self.targets.release()
            self.meshes.release()
        else:
            self.ctx.gc_mode = None  # dropped wrappers must not release (gc_mode 'auto') or queue anything
        self.cache.clear()
        self._environments.clear()
        self._albedos.clear()
        self._fullscreen.clear()


def gl_objects(value, seen: set | None = None):
    """The GL objects in a (nested) list, tuple, dict or dataclass of results, each once (``pooled()``
    lists an object's pooled textures, e.g. an ImpostorSet's atlases)."""
    seen = set() if seen is None else seen
    if value is None or isinstance(value, (str, bytes, int, float, np.ndarray)) or id(value) in seen:
        return
    seen.add(id(value))
    if isinstance(value, (list, tuple)):
        for item in value:
            yield from gl_objects(item, seen)
    elif isinstance(value, dict):
        for item in value.values():
            yield from gl_objects(item, seen)
    elif hasattr(value, "release") and hasattr(value, "glo"):
        yield value
    elif hasattr(value, "pooled"):
        # Item by item: the list pooled() makes is temporary, and a later one may be given its id once it is freed.
        for item in value.pooled():
            yield from gl_objects(item, seen)
    elif hasattr(value, "__dataclass_fields__"):
        for name in value.__dataclass_fields__:
            yield from gl_objects(getattr(value, name), seen)


def release_all(value, targets=None) -> None:
    """Release every GL object in ``value`` (:func:`gl_objects`); with ``targets`` (a TargetPool), give
    its lent textures back to it instead."""
    for obj in list(gl_objects(value)):
        if targets is not None and targets.is_lent(obj):
            targets.give_back(obj)
        else:
            obj.release()
