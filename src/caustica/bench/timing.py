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
