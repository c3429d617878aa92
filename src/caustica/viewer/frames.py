"""Live frames: the renderer's own passes into offscreen textures, kept on the GPU for display.

A rasterized technique runs exactly the graph ``Renderer.render`` runs
(``Renderer.render_frame``: same device, same supersampled size) but skips the readback: the
window draws the ``color`` texture and the pass inspector any other channel.
CPU techniques (``exact``, ``mitsuba``) run through ``Renderer.render`` in a
worker thread (:class:`CpuJob`); their image is uploaded when it is ready and
reused until the view changes. ``exact`` renders in stages of rising
resolution (1/8, then 1/4 of the view a side, then all of it: 8% more rays), so
the view shows a coarse image within moments and its progress meanwhile.
"""
from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import first_line
from ..passes.post.resolve import resolved
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
    progress: float | None = None  # a running CPU render's fraction done (None: not known)
    preview: int = 1  # the shown CPU image is 1/preview of the view's resolution (1: all of it)


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


STAGED = ("exact",)  # CPU techniques rendered in stages of rising resolution (mitsuba is a cached reference)
PREVIEW_SCALES = (8, 4)  # their previews: 1/8 then 1/4 of the view a side
MIN_PREVIEW = 8  # pixels: a preview smaller than this a side is skipped


def stage_sizes(size, scales=PREVIEW_SCALES) -> list[tuple[int, int]]:
    """The sizes a staged CPU render goes through: each preview (1/scale a side), coarsest first, then ``size``."""
    width, height = (int(v) for v in size)
    stages = []
    for scale in sorted(scales, reverse=True):
        small = (max(1, round(width / scale)), max(1, round(height / scale)))
        if min(small) >= MIN_PREVIEW and small not in stages and small != (width, height):
            stages.append(small)
    return [*stages, (width, height)]


class CpuJob:
    """One CPU render in a worker thread, in stages: ``render(size)`` is called for each of ``sizes``.

    ``image`` is the last stage finished (``done`` of them), ``ms`` its render time; ``cancel()`` ends
    the job after the running stage. ``clock`` is the time source (tests pass their own)."""

    def __init__(self, key, render, sizes, clock=time.perf_counter):
        self.key, self.sizes = key, [tuple(size) for size in sizes]
        self.image, self.done, self.ms, self.error = None, 0, 0.0, None
        self.cancelled, self.uploaded = False, 0  # uploaded: stages the LiveRenderer has put in a texture
        self._render, self._clock = render, clock
        self._stage_start, self._rate = clock(), None  # the rate: pixels a second of the last stage
        self.thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> "CpuJob":
        self.thread.start()
        return self

    def cancel(self) -> None:
        self.cancelled = True

    @property
    def alive(self) -> bool:
        return self.thread.is_alive()

    def _run(self) -> None:
        try:
            for index, size in enumerate(self.sizes):
                if self.cancelled:
                    return
                start = self._stage_start = self._clock()
                image = self._render(size)
                end = self._clock()
                self._rate = size[0] * size[1] / max(end - start, 1e-9)
                self.image, self.ms, self._stage_start = image, (end - start) * 1000.0, end
                self.done = index + 1
        except Exception as exc:  # shown in the panel; the viewer keeps running
            self.error = first_line(exc)

    def progress(self) -> float:
        """The fraction of the job's pixels rendered: the stages done, and of the running one what the last
        stage's rate gives for its time so far (at most 95% of it)."""
        pixels = [w * h for w, h in self.sizes]
        done = sum(pixels[:self.done])
        if self.done < len(pixels) and self._rate:
            done += min(0.95 * pixels[self.done], (self._clock() - self._stage_start) * self._rate)
        return done / sum(pixels)

    @property
    def preview(self) -> int:
        """How many times coarser than the last stage the shown image is, a side (1: the full size)."""
        if self.image is None:
            return 1
        return max(1, round(self.sizes[-1][0] / self.image.shape[1]))


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
               profile: bool = False, state_key=None, antialias: str = "none") -> LiveImage:
        """The frame of ``technique`` for ``slot`` ('main', 'second'); ``state_key`` names the view for CPU reuse;
        ``antialias`` as ``Renderer.render``'s (CPU techniques ignore it)."""
        tech = get_technique(technique)
        tech, parameters = self.renderer.resolve(tech, scene, camera, tech.make_params(**params), spp)
        if isinstance(tech, RasterTechnique):
            return self._render_raster(slot, tech, scene, camera, parameters, spp, profile, antialias)
        return self._render_cpu(slot, technique, tech.name, scene, camera, params, spp, state_key)

    def _render_raster(self, slot, tech, scene, camera, parameters, spp, profile, antialias="none") -> LiveImage:
        self._give_back(slot)
        start = time.perf_counter()
        self.renderer.profile_passes = profile
        frame = self._frames[slot] = self.renderer.render_frame(tech, scene, camera, parameters, spp)
        k = frame.camera.size[0] // camera.size[0]
        color = frame.read("color")
        if antialias != "none":  # resolved as Renderer.render resolves it: at the view's size
            color, k = resolved(frame, color, k, antialias), 1
        if profile:
            self.device.finish()
        elapsed = (time.perf_counter() - start) * 1000.0
        return LiveImage(tech.name, color, k, dict(frame.channels), dict(frame.pass_ms or {}), elapsed)

    def _render_cpu(self, slot, technique, resolved, scene, camera, params, spp, state_key) -> LiveImage:
        # Start a worker for a new view (a stale one stops after its stage); show the last image meanwhile.
        self._give_back(slot)
        job = self._jobs.get(slot)
        key = (technique, state_key, tuple(sorted(params.items())), spp, tuple(camera.size))
        if job is None or (job.key != key and not job.alive):
            sizes = stage_sizes(camera.size) if resolved in STAGED else [tuple(camera.size)]
            job = self._jobs[slot] = CpuJob(key, _cpu_render(scene, camera, technique, params, spp), sizes).start()
        elif job.key != key:
            job.cancel()
        if job.done > job.uploaded:
            self._upload(slot, job.image)
            job.uploaded = job.done
        pending = job.alive or job.key != key
        return LiveImage(technique, self._uploads.get(slot), 1, {}, {}, job.ms, pending, job.error,
                         job.progress() if pending and job.key == key and len(job.sizes) > 1 else None,
                         job.preview if job.key == key else 1)

    def wait(self, slot: str, timeout: float | None = None) -> None:
        """Block until the CPU render of ``slot`` finishes (scripted runs and tests)."""
        job = self._jobs.get(slot)
        if job is not None:
            job.thread.join(timeout)

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
            job.cancel()
            job.thread.join(5.0)
        for slot in list(self._frames):
            self._give_back(slot)
        for texture in self._uploads.values():
            texture.release()
        self._uploads.clear()
        self._jobs.clear()


def _cpu_render(scene, camera, technique: str, params: dict, spp: int):
    """``render(size)``: ``technique`` of ``scene`` seen by ``camera`` at that size (a CpuJob's stage)."""
    def render(size):
        # CPU only: never touches the window's context from the worker thread.
        return Renderer(size).render(replace(scene, camera=camera.with_size(*size)), technique, spp, **params)
    return render


def prune_meshes(device, scene) -> None:
    """Release GPU meshes no object of ``scene`` uses any more (an animation makes new ones every frame)."""
    meshes = device.meshes._meshes
    used = {obj.mesh.content_hash() for obj in scene.objects}
    for key in [k for k in meshes if k not in used]:
        meshes.pop(key).release()


def release_device(device) -> None:
    """Release everything a GpuDevice holds, cached results (shadow and caustic maps) included."""
    device.release()
