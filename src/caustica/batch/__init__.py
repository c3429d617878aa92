"""Batch rendering of datasets: ``caustica.batch(scene_or_sweep, out_dir, ...)`` and ``caustica batch``.

sweep.py reads sweep files, edits.py applies a frame's values to a scene, job.py holds the job and its
frame loop, manifest.py the output folder's records, frame.py the worker that renders, workers.py the
backends (in-process, spawned processes, Ray). docs/batch.md describes it all.
"""
from __future__ import annotations

import sys
import types


def batch(scene_or_sweep, out_dir, frames: int | None = None, *, orbit: float | None = None, size=None,
          spp: int | None = None, antialias: str | None = None, technique: str | None = None, labels=None,
          labels_format: str | None = None, image_format: str | None = None, seed: int | None = None,
          environment: str | None = None, camera: str | None = None, workers: int | None = None,
          ray: str | None = None, devices=None, force: bool = False, progress=None) -> list[dict]:
    """Render ``frames`` frames of a scene (preset, file, Scene) or a sweep file into ``out_dir`` and
    return every frame's manifest row. Finished frames of the same job there are kept; ``progress``
    is called with a :class:`caustica.batch.job.Progress` after each frame. Arguments given win over
    the sweep file's settings; ``workers`` spawned processes (default: 1, this process; one per device
    with ``devices``) placed round robin on the EGL devices ``devices`` (indices, e.g. [0, 1]; default:
    the machine's GPUs), or a Ray cluster (``ray``: an address or 'local') render. ``antialias``: as
    ``Renderer.render``'s (default ``none``). Rows of failed
    frames hold ``error``."""
    from ..errors import CausticaError
    from .devices import placement
    from .job import make_job, run_job

    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 1):
        raise CausticaError(f"workers must be a positive integer (got {workers!r})")
    if ray is not None and (workers not in (None, 1) or devices is not None):
        raise CausticaError("give workers and devices, or ray, not both (Ray sizes its own workers and "
                            "gives each a GPU)")
    spread = None if ray is not None else placement(devices)
    if workers is None:
        workers = len(spread) if devices is not None else 1
    job, base = make_job(scene_or_sweep, out_dir, frames=frames, orbit=orbit, size=size, spp=spp,
                         antialias=antialias, technique=technique, labels=labels, labels_format=labels_format,
                         image_format=image_format, seed=seed, environment=environment, camera=camera)
    return run_job(job, base, workers=workers, ray=ray, devices=spread if devices is not None or workers > 1 else None,
                   force=force, progress=progress)


class _CallableModule(types.ModuleType):
    """``caustica.batch`` is this package and the function: ``caustica.batch(...)`` calls :func:`batch`."""

    def __call__(self, *args, **kwargs):
        return batch(*args, **kwargs)


sys.modules[__name__].__class__ = _CallableModule
