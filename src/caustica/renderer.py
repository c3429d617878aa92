"""Renderer: one entry point for every technique, headless."""
from __future__ import annotations

import os
import time

import numpy as np

from . import frame_limits
from .errors import GLUnavailableError, RendererClosedError, RenderOptionError, SceneError
from .gpu.readback import read_rgb, read_rgba, supersampling_factor
from .labels import check_labels, check_technique_gives, raster_layers, traced_layers
from .passes.post.adaptive import FLAGS, AdaptiveFlags, combined, read_flags
from .passes.post.labels import label_pass, read_label_buffers
from .passes.post.resolve import check_antialias, resolved
from .passes.post.subpixel import check_multisampling
from .progress import progress_policy
from .render.frame import Frame, frame_setting
from .render.graph import run_graph
from .scene import Scene, rules
from .scene.scene import check_scene, recentred, without_invisible_glass
from .techniques import get_technique
from .techniques.base import check_spp


class Renderer:
    """Render scenes with any technique: ``Renderer((512, 512)).render(scene)`` (``auto``), or ``technique="env-map"``.

    ``size`` (width, height) overrides the scene camera's size; None keeps it.
    The GL context is created on first use of a GPU technique, unless ``device``
    (a :class:`caustica.gpu.device.GpuDevice`, e.g. over a window's context) is given. With
    ``profile_passes``, ``last_pass_ms`` holds each pass's milliseconds.

    A Renderer owns the GPU device it makes (its own pools of shaders, render targets, meshes and
    cached results over the process's one context): ``close()``, or leaving ``with Renderer(size)
    as r:``, releases all of it (a ``device`` given by the caller stays the caller's); a closed
    Renderer raises RendererClosedError. One dropped unclosed leaks nothing either: its GL objects
    are released at the end of the next frame any Renderer draws. In a process forked after this
    Renderer drew, it starts over on the child's fresh context (see gpu/context.py).

    ``progress``: the long steps of a render (``exact``'s rows, photons, light-map bakes) show their progress on
    stderr: None (the default) on a terminal only, True always (a notebook, a log: plain lines), False never
    (caustica/progress.py).
    """

    def __init__(self, size: tuple[int, int] | None = None, keep_channels: bool = False, profile_passes: bool = False,
                 device=None, progress: bool | None = None):
        self.size = None if size is None else rules.image_size(size, "Renderer size", error=RenderOptionError)
        self._device = device
        self._owns_device = device is None
        self.closed = False
        self._keep = keep_channels
        self.channels: dict = {}  # the last frame's channels (keep_channels), lent until the next frame
        self._kept: Frame | None = None
        self.profile_passes = profile_passes  # fill last_pass_ms (adds a sync per pass on llvmpipe)
        self.progress = progress
        self.last_pass_ms: dict[str, float] = {}
        self.last_plan = None  # the Plan auto rendered the last frame with
        # antialias 'adaptive''s last frame: the (H, W) bool pixels it supersampled, and their fraction (else None)
        self.last_adaptive_flags: np.ndarray | None = None
        self.last_adaptive_fraction: float | None = None

    def _check_open(self) -> None:
        if self.closed:
            raise RendererClosedError("this Renderer was closed; make a new Renderer (or render inside its with block)")

    @property
    def device(self):
        self._check_open()
        if self._device is not None and self._device.pid != os.getpid():
            if not self._owns_device:
                raise GLUnavailableError("this Renderer's GpuDevice was made before this process was forked and its "
                                         "context cannot be used here; make the device in the worker, or use "
                                         "multiprocessing's 'spawn' start method")
            self._device.release()  # forgets the inherited objects without calling into them
            self._device, self.channels, self._kept = None, {}, None
        if self._device is None:
            from .gpu.device import GpuDevice

            self._device = GpuDevice()
        return self._device

    def close(self) -> None:
        """Release the GPU device this Renderer made (a caller's device is left as it is); idempotent."""
        if self.closed:
            return
        if self._device is not None:
            self._give_back_kept()
        if self._owns_device and self._device is not None:
            self._device.release()
        self._device, self.channels, self.closed = None, {}, True

    def __enter__(self):
        self._check_open()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def camera_for(self, scene: Scene):
        camera = scene.camera if self.size is None else scene.camera.with_size(*self.size)
        return camera

    def render(self, scene: Scene, technique: str = "auto", spp: int = 1, *, labels=None, antialias: str = "none",
               **params):
        """A (H, W, 3) float32 linear RGB image, row 0 at the top. ``technique``: a name (``caustica
        techniques`` lists them) or a Technique instance. ``antialias``: ``none``, ``edge`` (a
        post-process), ``msaa`` (outlines from multisampled coverage) or ``adaptive`` (4 spp at the
        pixels a 1-spp frame flags; spp 1; ``last_adaptive_fraction``) on rasterized images
        (passes/post/resolve.py; CPU techniques ignore it). ``labels``: a
        list of names from caustica.labels.LABELS; then ``(image, layers)``, layers a {name: array}
        at the output size (docs/labels.md)."""
        result, _ = self.render_timed(scene, technique, spp, labels=labels, antialias=antialias, **params)
        return result

    def render_timed(self, scene: Scene, technique: str = "auto", spp: int = 1, *, labels=None,
                     antialias: str = "none", **params):
        """Render and return (image, milliseconds), the GPU finished before the clock stops; with
        ``labels``, ((image, layers), milliseconds), the layers' time included."""
        with progress_policy(self.progress):
            return self._render_timed(scene, technique, spp, labels, antialias, params)

    def _render_timed(self, scene: Scene, technique, spp: int, labels, antialias: str, params: dict):
        self._check_open()  # exact never touches the device
        check_antialias(antialias)
        if antialias == "adaptive" and spp != 1:
            raise RenderOptionError(f"antialias 'adaptive' renders 1 spp and 4 spp at the edges itself, not spp {spp}; "
                                    "leave spp at 1, or use spp without adaptive")
        self.last_adaptive_flags = self.last_adaptive_fraction = None
        names = None if labels is None else check_labels(labels)
        tech = get_technique(technique)
        parameters = tech.make_params(**params)
        adaptive = antialias == "adaptive" and tech.uses_gl
        frame_spp = 4 if adaptive else spp  # adaptive plans and checks its frames as its 4-spp one
        scene, shift, camera = self._placed(tech, scene, frame_spp)
        tech, parameters = self.resolve(tech, scene, camera, parameters, frame_spp)
        self._check_frame(tech, scene, camera, parameters, frame_spp, "none" if adaptive else antialias)
        if names is not None:
            check_technique_gives(tech, names)
        if antialias == "msaa" and tech.uses_gl:
            check_multisampling(self.device)
        start = time.perf_counter()
        if adaptive:
            image, buffers = self._render_adaptive(tech, scene, camera, parameters, names)
            self.device.finish()
        elif tech.uses_gl:
            image, buffers = self._render_graph(tech, scene, camera, parameters, int(spp), antialias, names)
            self.device.finish()
        else:
            image = tech.render(scene, camera, parameters, int(spp))
        if names is None:
            return image, (time.perf_counter() - start) * 1000.0
        if tech.uses_gl:
            layers = raster_layers(buffers, names, scene, camera, supersampling_factor(spp))
        else:
            layers = traced_layers(scene, camera, int(spp), names, tech, parameters)
        if "flow_point" in layers and shift.any():  # world points of the moved scene, back in the caller's
            landed = layers["flow_object"][..., None] >= 0
            layers["flow_point"] = np.where(landed, layers["flow_point"] - shift, 0.0).astype(layers["flow_point"].dtype)
        return (image, layers), (time.perf_counter() - start) * 1000.0

    def resolve(self, tech, scene: Scene, camera, parameters, spp: int = 1):
        """The technique and parameters that render ``scene``: ``tech`` itself, or a planner's (``auto``)
        choice, whose budget candidates are checked against the frame limits and timed here
        (:meth:`frame_ms`); the plan is kept in ``last_plan`` (None for a named technique)."""
        def measured(candidate, values) -> float:
            self._check_frame(candidate, scene, camera, values, spp)
            return self.frame_ms(candidate, scene, camera, values, int(spp))

        k = supersampling_factor(spp)
        frame_size = (camera.size[0] * k, camera.size[1] * k)
        resolved, values = tech.for_scene(scene, parameters, measured, frame_size=frame_size)
        self.last_plan = getattr(tech, "plan_used", None)
        return resolved, values

    def plan(self, scene: Scene, quality: str = "balanced", budget_ms: float = 0.0, spp: int = 1):
        """auto's Plan (planning/rules.py) for ``scene`` at this renderer's size and ``spp``: at ``quality``,
        or with ``budget_ms`` the highest quality whose frame time here (measured, cached) fits it; a budget
        below the cheapest plan's is a TechniqueError naming the smallest that works."""
        self._check_open()
        tech = get_technique("auto")
        parameters = tech.make_params(quality=quality, budget_ms=budget_ms)
        scene, _, camera = self._placed(tech, scene, spp)
        self.resolve(tech, scene, camera, parameters, spp)
        return self.last_plan

    def _placed(self, tech, scene: Scene, spp: int):
        """(scene, shift, camera): ``scene`` checked and moved to the origin where it is far (float32 on the GPU
        and in Embree), its camera at this renderer's size, size and ``spp`` checked for ``tech``."""
        check_scene(scene)
        scene, shift = recentred(scene)
        camera = self.camera_for(scene)
        self._check_size(camera.size, spp, tech.uses_gl)
        check_spp(tech, spp)
        return scene, shift, camera

    def render_frame(self, tech, scene: Scene, camera, parameters, spp: int = 1, keep=None) -> Frame:
        """Run a rasterized technique's graph (a planner's resolved first) at the supersampled size
        (``supersampling_factor(spp)`` times ``camera``'s) and return its frame, whose channels stay lent
        until ``frame.give_back()`` (``keep``: the channels wanted afterwards; None keeps all).
        ``pass_ms`` holds the per-pass milliseconds when ``profile_passes``. A far scene runs moved to the
        origin as in :meth:`render_timed` (the frame's scene and camera are the moved ones)."""
        scene, shift = recentred(scene)
        camera = camera.translated(shift) if shift.any() else camera
        tech, parameters = self.resolve(tech, scene, camera, parameters, spp)
        return self._run_frame(tech, scene, camera, parameters, spp, keep)

    def _run_frame(self, tech, scene: Scene, camera, parameters, spp: int, keep, extra=(), channels=None) -> Frame:
        """render_frame for a resolved technique; ``extra``: passes run after the technique's (labels);
        ``channels``: what the frame starts with (the caller's, not lent to it)."""
        k = supersampling_factor(spp)
        width, height = camera.size
        if frame_setting(parameters, "drop_invisible_glass"):  # the passes never see it (labels still do)
            scene = without_invisible_glass(scene)
        frame = Frame(self.device, scene, camera.with_size(width * k, height * k), parameters,
                      channels=dict(channels or {}), pass_ms={} if self.profile_passes else None)
        try:
            run_graph([*tech.build_passes(parameters), *extra], frame, keep=keep)
        except BaseException:
            frame.give_back()
            raise
        self.last_pass_ms = dict(frame.pass_ms or {})
        return frame

    def frame_ms(self, tech, scene: Scene, camera, parameters, spp: int = 1) -> float:
        """Milliseconds per frame of a rasterized technique here (after a warm-up frame), cached on
        disk by device, scene, camera, spp, technique and parameters (``$CAUSTICA_CACHE/costs``)."""
        import hashlib
        import json

        from .cache import atomic_write_bytes, cache_dir
        from .reference.render import cache_key

        key = hashlib.sha1(json.dumps([self.device.info["renderer"], cache_key(scene, camera, spp, 0, "cost", False),
                                       tech.name, repr(parameters)]).encode()).hexdigest()[:24]
        path = cache_dir("costs") / f"{key}.json"
        try:
            return float(json.loads(path.read_text())["ms"])
        except (OSError, ValueError, KeyError, TypeError):
            pass
        times = []
        for _ in range(3):  # the first compiles shaders and fills caches
            start = time.perf_counter()
            self._render_graph(tech, scene, camera, parameters, spp)
            self.device.finish()
            times.append((time.perf_counter() - start) * 1000.0)
        ms = min(times[1:])
        try:
            atomic_write_bytes(path, json.dumps({"ms": ms, "technique": tech.name}).encode())
        except OSError:
            pass  # a cache that cannot be written only costs a measurement
        return ms

    def _render_graph(self, tech, scene: Scene, camera, parameters, spp: int, antialias: str = "none",
                      labels=None):
        """The technique's image: its graph run, the colour resolved on the GPU (averaged over k x k
        samples, edge anti-aliased with ``antialias``), read back; every texture given back but those kept
        for inspection (``keep_channels``). Returns (image, label buffers): with ``labels`` (checked
        names), passes/post/labels.py's pass runs last and its buffers are read back too, else None."""
        self._give_back_kept()
        k = supersampling_factor(spp)
        extra = [] if labels is None else [label_pass(scene, labels, k)]
        keep = None if self._keep else ("color", *(c.name for p in extra for c in p.writes))
        frame = self._run_frame(tech, scene, camera, parameters, spp, keep=keep, extra=extra)
        try:
            # Resolved on the GPU: a k^2 smaller readback, no CPU pass over every sample.
            image = read_rgb(resolved(frame, frame.read("color"), k, antialias))
            buffers = read_label_buffers(frame, labels) if extra else None
        except BaseException:
            frame.give_back()
            raise
        if self._keep:
            self._kept, self.channels = frame, dict(frame.channels)
        else:
            frame.give_back()
        return image.astype(np.float32), buffers

    def _render_adaptive(self, tech, scene: Scene, camera, parameters, labels=None):
        """antialias 'adaptive' (passes/post/adaptive.py): the graph at 1 spp and its flags, then, when any pixel
        is flagged, at 4 spp with the flagged pixels alone shaded, the two combined on the GPU and read
        back. Sets ``last_adaptive_flags`` and ``last_adaptive_fraction``; returns (image, label buffers) as :meth:`_render_graph`,
        the labels at 1 spp."""
        self._give_back_kept()
        extra = [AdaptiveFlags()] + ([] if labels is None else [label_pass(scene, labels, 1)])
        keep = None if self._keep else ("color", *(c.name for p in extra for c in p.writes))
        frames = [self._run_frame(tech, scene, camera, parameters, 1, keep=keep, extra=extra)]
        single = frames[0]
        try:
            flags, color = single.read(FLAGS.name), single.read("color")
            self.last_adaptive_flags = read_flags(flags)
            self.last_adaptive_fraction = float(self.last_adaptive_flags.mean())
            if self.last_adaptive_fraction > 0.0:  # else the 1-spp image is the answer
                frames.append(self._run_frame(tech, scene, camera, parameters, 4, keep=None if self._keep else ("color",),
                                              channels={FLAGS.name: flags}))
                refined = frames[1]
                color = combined(single, color, resolved(refined, refined.read("color"), 2), flags)
            image = read_rgb(color)
            buffers = read_label_buffers(single, labels) if labels is not None else None
        except BaseException:
            for frame in frames:
                frame.give_back()
            raise
        if self._keep:  # the last frame's channels (the flags were the 1-spp frame's)
            for frame in frames[:-1]:
                frame.give_back()
            self._kept, self.channels = frames[-1], dict(frames[-1].channels)
            if len(frames) > 1:
                self.channels.pop(FLAGS.name, None)
        else:
            for frame in frames:
                frame.give_back()
        return image.astype(np.float32), buffers

    def _give_back_kept(self) -> None:
        """Give back the textures of the frame kept for inspection (the previous one)."""
        if self._kept is not None:
            self._kept.give_back()
        self._kept, self.channels = None, {}

    def _check_frame(self, tech, scene: Scene, camera, parameters, spp: int, antialias: str = "none") -> None:
        """A rasterized frame's memory (``antialias``'s targets included), map sides and environment texture
        within this GL's limits."""
        if tech.uses_gl:
            frame_limits.check_frame_memory(camera.size, spp, parameters, scene, antialias=antialias)
            frame_limits.check_map_sides(parameters, scene, self.device.max_texture_size)
            frame_limits.check_environment_texture(scene.environment, self.device.max_texture_size)

    def _check_size(self, size, spp: int, uses_gl: bool) -> None:
        frame_limits.check_spp(spp)
        width, height = size  # at least 1x1: checked with the camera (rules.image_size)
        if uses_gl:
            k = supersampling_factor(spp)
            limit = self.device.max_texture_size
            if max(width, height) * k > limit:
                raise SceneError(
                    f"image size {width}x{height} with {spp} spp needs {width * k}x{height * k} pixels, "
                    f"above this GL's limit of {limit}; use a smaller size or fewer samples"
                )

    def exit_directions(self, scene: Scene, technique: str, **params):
        """Per-pixel exit directions (H, W, 3) and validity (H, W) at pixel centres, or None.

        Defined for techniques whose passes write the ``exit_direction`` channel.
        """
        keep, self._keep = self._keep, True
        try:
            self.render(scene, technique, spp=1, **params)
            texture = self.channels.get("exit_direction")
            result = None
            if texture is not None:
                data = read_rgba(texture)
                result = (data[..., :3].copy(), data[..., 3] > 0.5)
            self._give_back_kept()
            return result
        finally:
            self._keep = keep

    def info(self) -> dict:
        return self.device.info


