"""Live frames: the renderer's own passes into offscreen textures, kept on the GPU for display.

A rasterized technique runs exactly the graph ``Renderer.render`` runs
(``Renderer.render_frame``: same device, same supersampled size) but skips the readback: the
window draws the ``color`` texture and the pass inspector any other channel.
CPU techniques (``exact``, ``mitsuba``) run through ``Renderer.render`` in a
worker thread; their image is uploaded when it is ready and reused until the
view changes.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import first_line
from ..renderer import Renderer
from ..techniques import get_technique
from ..techniques.raster import RasterTechnique


@dataclass
class LiveImage:
    """One technique's latest frame: its textures by channel name and how it was made."""

    technique: str
    color: object | None = None  # texture (row 0 at the bottom, GL convention), k x k supersampled
    supersampling: int = 1
    channels: dict = field(default_factory=dict)
    pass_ms: dict = field(default_factory=dict)
    render_ms: float = 0.0
    pending: bool = False  # a CPU render is still running
    error: str | None = None


def channel_textures(channels: dict) -> dict:
    """Every texture among ``channels`` by display name: lists as ``name[i]``, objects holding a ``.texture``."""
    found = {}
    for name, value in channels.items():
        items = value if isinstance(value, (list, tuple)) else [value]
        for i, item in enumerate(items):
            texture = getattr(item, "texture", item)
            if hasattr(texture, "glo") and hasattr(texture, "components") and hasattr(texture, "size"):
                found[f"{name}[{i}]" if isinstance(value, (list, tuple)) else name] = texture
    return found


class LiveRenderer:
    """Renders into textures of ``device`` (the window's context); each slot's frame keeps its textures
    lent until that slot's next frame."""

    def __init__(self, device):
        self.device = device
        self.renderer = Renderer(device=device)
        self._frames: dict = {}  # slot -> that slot's last frame (its textures stay lent for display)
        self._uploads: dict[str, object] = {}  # slot -> texture holding a CPU image
        self._jobs: dict[str, dict] = {}  # slot -> CPU render state (thread, key, result)

    def render(self, slot: str, scene, camera, technique: str, params: dict, spp: int = 1,
               profile: bool = False, state_key=None) -> LiveImage:
        """The frame of ``technique`` for ``slot`` ('main', 'second'); ``state_key`` names the view for CPU reuse."""
        tech = get_technique(technique)
        tech, parameters = self.renderer.resolve(tech, scene, camera, tech.make_params(**params), spp)
        if isinstance(tech, RasterTechnique):
            return self._render_raster(slot, tech, scene, camera, parameters, spp, profile)
        return self._render_cpu(slot, technique, scene, camera, params, spp, state_key)

    def _render_raster(self, slot, tech, scene, camera, parameters, spp, profile) -> LiveImage:
        self._give_back(slot)
        start = time.perf_counter()
        self.renderer.profile_passes = profile
        frame = self._frames[slot] = self.renderer.render_frame(tech, scene, camera, parameters, spp)
        if profile:
            self.device.finish()
        elapsed = (time.perf_counter() - start) * 1000.0
        k = frame.camera.size[0] // camera.size[0]
        return LiveImage(tech.name, frame.read("color"), k, dict(frame.channels), dict(frame.pass_ms or {}), elapsed)

    def _render_cpu(self, slot, technique, scene, camera, params, spp, state_key) -> LiveImage:
        # Start a worker for a new view; show the last finished image meanwhile.
        self._give_back(slot)
        job = self._jobs.get(slot)
        key = (technique, state_key, tuple(sorted(params.items())), spp, tuple(camera.size))
        if job is None or (job["key"] != key and not job["thread"].is_alive()):
            job = {"key": key, "result": None, "error": None, "ms": 0.0, "uploaded": False}
            job["thread"] = threading.Thread(target=self._cpu_job, args=(job, scene, camera, technique, params, spp),
                                             daemon=True)
            job["thread"].start()
            self._jobs[slot] = job
        if job["result"] is not None and not job["uploaded"]:
            self._upload(slot, job["result"])
            job["uploaded"] = True
        pending = job["thread"].is_alive() or job["key"] != key
        return LiveImage(technique, self._uploads.get(slot), 1, {}, {}, job["ms"], pending, job["error"])

    def _cpu_job(self, job, scene, camera, technique, params, spp) -> None:
        import dataclasses

        try:
            renderer = Renderer(camera.size)  # CPU only: never touches the window's context from this thread
            start = time.perf_counter()
            job["result"] = renderer.render(dataclasses.replace(scene, camera=camera), technique, spp, **params)
            job["ms"] = (time.perf_counter() - start) * 1000.0
        except Exception as exc:  # shown in the panel; the viewer keeps running
            job["error"] = first_line(exc)

    def wait(self, slot: str, timeout: float | None = None) -> None:
        """Block until the CPU render of ``slot`` finishes (scripted runs and tests)."""
        job = self._jobs.get(slot)
        if job is not None:
            job["thread"].join(timeout)

    def _upload(self, slot: str, image: np.ndarray) -> None:
        """A CPU image (row 0 at the top) into an RGBA32F texture (row 0 at the bottom)."""
        height, width = image.shape[:2]
        rgba = np.ones((height, width, 4), dtype="f4")
        rgba[..., :3] = image[::-1]
        texture = self._uploads.get(slot)
        if texture is None or tuple(texture.size) != (width, height):
            if texture is not None:
                texture.release()
            texture = self.device.ctx.texture((width, height), 4, dtype="f4")
            self._uploads[slot] = texture
        texture.write(rgba.tobytes())

    def _give_back(self, slot: str) -> None:
        frame = self._frames.pop(slot, None)
        if frame is not None:
            frame.give_back()

    def release(self) -> None:
        """Hand back every pooled texture and release the uploads (before the device is released)."""
        for job in self._jobs.values():
            job["thread"].join(5.0)
        for slot in list(self._frames):
            self._give_back(slot)
        for texture in self._uploads.values():
            texture.release()
        self._uploads.clear()
        self._jobs.clear()


def prune_meshes(device, scene) -> None:
    """Release GPU meshes no object of ``scene`` uses any more (an animation makes new ones every frame)."""
    meshes = device.meshes._meshes
    used = {obj.mesh.content_hash() for obj in scene.objects}
    for key in [k for k in meshes if k not in used]:
        meshes.pop(key).release()


def release_device(device) -> None:
    """Release everything a GpuDevice holds, cached results (shadow and caustic maps) included."""
    device.release()
