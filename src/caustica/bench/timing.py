"""Frame timing shared by compare and bench: median of N frames after a warm-up; and their progress."""
from __future__ import annotations

import statistics
import time

from ..progress import progress
from ..techniques import get_technique


def steps(total: int, desc: str, unit: str = "steps"):
    """The progress of compare's and bench's loops of long steps, ``update()`` after each: where they make it
    (caustica.progress's policy: a bar on a terminal, plain lines in a log, nothing when quiet or under a second)."""
    return progress(total, desc, unit=unit)


CPU_WARM_UP_SIDE = 16  # pixels: the longer side of a CPU technique's warm-up frame


def warm_up_size(size: tuple[int, int]) -> tuple[int, int]:
    """A small frame of ``size``'s shape (CPU_WARM_UP_SIDE on its longer side, never larger than it): enough for a
    CPU technique to build what it keeps per scene (Embree's BVH, the photon map, the environment's light) for
    little of a frame's cost."""
    width, height = size
    scale = min(1.0, CPU_WARM_UP_SIDE / max(width, height))
    return max(1, round(width * scale)), max(1, round(height * scale))


def warm_up(renderer, scene, technique: str, spp: int, params: dict) -> None:
    """One untimed frame that pays what ``technique`` does once per scene, so a timed frame holds only a frame's
    work: GPU techniques compile shaders and fill their caches at the renderer's size; CPU techniques build
    their per-scene caches in a small frame (:func:`warm_up_size`) of a renderer like ``renderer``."""
    if get_technique(technique).uses_gl:
        renderer.render(scene, technique, spp, **params)
    else:
        type(renderer)(warm_up_size(renderer.camera_for(scene).size)).render(scene, technique, spp, **params)


def timed_render(renderer, scene, technique: str, spp: int, frames: int, params: dict | None = None):
    """(image, median ms) of ``frames`` timed frames of a technique after an untimed warm-up (:func:`warm_up`).

    CPU techniques (``exact``, ``mitsuba``) are timed once: they are slow.
    """
    params = params or {}
    warm_up(renderer, scene, technique, spp, params)
    timings, image = [], None
    for _ in range(max(1, frames if get_technique(technique).uses_gl else 1)):
        image, ms = renderer.render_timed(scene, technique, spp, **params)
        timings.append(ms)
    return image, statistics.median(timings)


def end_to_end_seconds(setup_seconds: float, first_seconds, render_seconds) -> float:
    """A cold run's seconds from the scene: setting up (export, load), then each render's first call, which
    compiles and renders (``first_seconds``, one per render). Each counts at least as long as that render's warm
    call (``render_seconds``, alike), which a noisy first call on shared cores could undercut, since both render
    the same samples: the figure is never less than the render's."""
    return setup_seconds + sum(max(first, render) for first, render in zip(first_seconds, render_seconds, strict=True))


def timed_in_turns(renderer, scene, variants: dict, spp: int, rounds: int, baseline: str, progress=None) -> dict:
    """Frame times of GPU technique variants rendered in turns, one frame of each per round after one
    warm-up frame each, so that load on shared cores, which drifts over seconds, hits them alike.

    ``variants`` maps a name to (technique, params). Returns {name: {"ms": median ms, "fastest": min ms,
    "ratio": median over rounds of the variant's time over ``baseline``'s in the same round}}.
    ``progress(round_index)`` is called after each round.
    """
    for technique, params in variants.values():
        renderer.render(scene, technique, spp, **params)
    times = {name: [] for name in variants}
    for round_index in range(max(1, rounds)):
        for name, (technique, params) in variants.items():
            times[name].append(renderer.render_timed(scene, technique, spp, **params)[1])
        if progress is not None:
            progress(round_index)
    return {name: {"ms": statistics.median(t), "fastest": min(t),
                   "ratio": statistics.median(a / b for a, b in zip(t, times[baseline]))} for name, t in times.items()}


def fastest_in_blocks(renderer, scene, variants: dict, spp: int, rounds: int, frames: int = 3) -> dict:
    """{name: {"wall": fastest ms, "cpu": fastest process CPU ms}} of GPU technique variants timed in blocks:
    per round, each variant's warm-up frame (which refills the passes it caches across frames, since another
    variant's frame evicts them) and then ``frames`` frames. The fastest frame is the least disturbed by other
    work on shared cores: the steady per-frame cost of each variant, for ratios between them. The process's CPU
    time (every llvmpipe thread's) hardly grows with other processes' load, unlike the wall clock, which waits
    for cores. ``variants`` maps a name to (technique, params)."""
    fastest = {name: {"wall": float("inf"), "cpu": float("inf")} for name in variants}
    for _ in range(max(1, rounds)):
        for name, (technique, params) in variants.items():
            renderer.render(scene, technique, spp, **params)
            for _ in range(max(1, frames)):
                cpu = time.process_time()
                wall = renderer.render_timed(scene, technique, spp, **params)[1]
                cpu = (time.process_time() - cpu) * 1000.0
                best = fastest[name]
                best["wall"], best["cpu"] = min(best["wall"], wall), min(best["cpu"], cpu)
    return fastest
