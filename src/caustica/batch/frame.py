"""The worker side of a batch: one Renderer (one GL context) that renders a job's frames, writes each
frame's files atomically and returns its manifest row. Every backend (in-process, spawned
processes, Ray) runs frames through this class, so a frame is the same whoever renders it.
"""
from __future__ import annotations

import os
import time
from pathlib import Path

from ..errors import CausticaError, GLUnavailableError, first_line
from ..gpu.egl_devices import env_device_or_first


class FrameWorker:
    """Renders frames of ``job``; ``close()`` releases the GL objects."""

    def __init__(self, job):
        from ..renderer import Renderer
        from ..techniques import get_technique
        from .edits import SceneEditor

        self.job = job
        self.editor = SceneEditor(job.base_scene(), job.base_dir)
        self.renderer = Renderer(job.size)
        self.uses_gl = get_technique(job.technique).uses_gl
        # The EGL device index of this process's context (batch/devices.py): None for CPU techniques.
        self.device = env_device_or_first() if self.uses_gl else None
        self._where: str | None = None
        self._first = True  # the next frame is this worker's first: it compiles shaders, fills caches

    def render(self, index: int) -> dict:
        """Frame ``index``'s manifest row: its values, files, sizes and times, or its error.
        GLUnavailableError passes through (no frame can render)."""
        job = self.job
        values = job.values(index)
        row = {"index": index, "values": values, "seed": job.seed}
        try:
            row.update(self._render(index, values))
        except GLUnavailableError:
            raise
        except Exception as exc:  # any failure of one frame is its row; the run goes on
            message = first_line(exc)
            row["error"] = message if isinstance(exc, CausticaError) else f"{type(exc).__name__}: {message}"
        row.update(time=round(time.time(), 3), worker=os.getpid(), device=self.device)
        return row

    def _render(self, index: int, values: dict) -> dict:
        from ..images import write_image

        job, renderer = self.job, self.renderer
        scene = self.editor.apply(values)
        start = time.perf_counter()
        if job.labels:
            image, layers = renderer.render(scene, job.technique, job.spp, labels=list(job.labels),
                                            antialias=job.antialias)
            ms = (time.perf_counter() - start) * 1000.0
        else:
            image, ms = renderer.render_timed(scene, job.technique, job.spp, antialias=job.antialias)
        wrote = time.perf_counter()
        files = job.files(index)
        out = Path(job.out_dir)
        (out / files["image"]).parent.mkdir(parents=True, exist_ok=True)
        write_image(out / files["image"], image)
        if job.labels:
            from ..labels import write_labels

            write_labels(out / files["labels"], layers, job.labels_format)
        plan = renderer.last_plan
        first, self._first = self._first, False
        return {"files": files, "sizes": {k: (out / v).stat().st_size for k, v in files.items()},
                "ms": round(ms, 3), "warmup": first, "write_ms": round((time.perf_counter() - wrote) * 1000.0, 3),
                "renderer": self._renderer_name(), "technique": plan.technique if plan is not None else job.technique}

    def _renderer_name(self) -> str:
        if self._where is None:
            self._where = self.renderer.info()["renderer"] if self.uses_gl else "CPU (Embree)"
        return self._where

    def close(self) -> None:
        self.renderer.close()
