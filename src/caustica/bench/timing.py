"""Frame timing shared by compare and bench: median of N frames after a warm-up."""
from __future__ import annotations

import statistics

from ..techniques import get_technique


def timed_render(renderer, scene, technique: str, spp: int, frames: int, params: dict | None = None):
    """(image, median ms) for a technique; GPU techniques get one untimed warm-up frame.

    CPU techniques (``exact``, ``mitsuba``) are timed once: they compile nothing and are slow.
    """
    params = params or {}
    if not get_technique(technique).uses_gl:
        return renderer.render_timed(scene, technique, spp, **params)
    renderer.render(scene, technique, spp, **params)
    timings, image = [], None
    for _ in range(max(1, frames)):
        image, ms = renderer.render_timed(scene, technique, spp, **params)
        timings.append(ms)
    return image, statistics.median(timings)
