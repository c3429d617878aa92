"""How long ``caustica bench`` will take, said before it starts and corrected as it goes.

A cost model, not a measurement: seconds per frame, per exact pixel and per Mitsuba sample measured on
llvmpipe with 2 cores (a GPU is faster at the raster frames, not at exact or Mitsuba, which run on the CPU).
:class:`Pace` scales what is left by how the finished parts compared with their estimate.
"""
from __future__ import annotations

from time import perf_counter as clock  # tests put a fake clock here

from ..progress import note, status
from ..techniques import get_technique

GPU_WARM_UP_S = 3.0  # a technique's first frame of a scene: shader compiles, caches, light-map bakes
GPU_S_PER_MEGAPIXEL = 0.25  # a raster frame (auto on caustic-sphere: 60 ms at 512^2)
EXACT_S_PER_MEGAPIXEL = {False: 20.0, True: 400.0}  # without / with diffuse surfaces (their environment rays)
EXACT_PHOTONS_S = 6.0  # exact's caustic photons of a scene with glass, traced once per scene
MITSUBA_S_PER_MEGASAMPLE = 2.0  # the reference's composite renders (caustic-sphere: 0.5 s for 64^2 x 64 spp)


def _exact_seconds(scene, pixels: int) -> float:
    diffuse = any(o.material.kind == "diffuse" for o in scene.objects)
    return EXACT_S_PER_MEGAPIXEL[diffuse] * pixels / 1e6


def _frame_seconds(scene, technique: str, pixels: int, frames: int) -> float:
    """A technique's warm-up and timed frames at ``pixels`` (CPU techniques: one frame)."""
    if not get_technique(technique).uses_gl:
        return _exact_seconds(scene, pixels)
    return GPU_WARM_UP_S + (frames + 1) * GPU_S_PER_MEGAPIXEL * pixels / 1e6


def _photons_seconds(scene, techniques) -> float:
    """exact's photons, from the lights and the environment's sun, where glass can focus them."""
    glass = any(o.material.kind == "glass" for o in scene.objects)
    return EXACT_PHOTONS_S if glass and "exact" in techniques else 0.0


def speed_seconds(scene, techniques, sizes, frames: int) -> float:
    """bench's speed rows of one scene: per size, plain and each technique, the GPU ones twice more profiled."""
    total = _photons_seconds(scene, techniques)
    for size in sizes:
        pixels = size * size
        total += _frame_seconds(scene, "plain", pixels, frames)
        for name in techniques:
            total += _frame_seconds(scene, name, pixels, frames + 2 if get_technique(name).uses_gl else 1)
    return total


def quality_seconds(scene, techniques, size: int, reference_spp: int, max_spp: int, frames: int) -> float:
    """bench's time to quality of one scene: the reference (unless cached), each technique, and Mitsuba's curve
    at 1, 2, 4, ... max_spp spp, each point rendered twice (warm, then end to end)."""
    pixels = size * size
    curve_spp = sum(1 << k for k in range(max_spp.bit_length()))
    samples = pixels * (reference_spp + 2 * curve_spp)
    return (MITSUBA_S_PER_MEGASAMPLE * samples / 1e6 + _photons_seconds(scene, techniques)
            + sum(_frame_seconds(scene, name, pixels, frames) for name in techniques))


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 90 else f"{seconds / 60:.0f} min"


class Pace:
    """The bench's parts (name, estimated seconds): :meth:`start` says the whole estimate, :meth:`done` after
    each part says how far it is and about how long is left, scaled by the finished parts' real/estimated."""

    def __init__(self, parts: list[tuple[str, float]]):
        self.parts = parts
        self.finished = 0
        self.begun = clock()

    def start(self) -> None:
        total = sum(seconds for _, seconds in self.parts)
        note(f"bench: about {_minutes(total)} in all on this machine's model (llvmpipe, 2 cores): "
             + ", ".join(f"{name} ~{_minutes(seconds)}" for name, seconds in self.parts))

    def done(self) -> None:
        self.finished += 1
        elapsed = clock() - self.begun
        estimated = sum(seconds for _, seconds in self.parts[: self.finished])
        left = sum(seconds for _, seconds in self.parts[self.finished:]) * elapsed / max(estimated, 1e-9)
        tail = f", about {_minutes(left)} left" if self.finished < len(self.parts) else ""
        status(f"bench: {self.finished}/{len(self.parts)} parts done ({self.parts[self.finished - 1][0]}) "
             f"in {_minutes(elapsed)}{tail}")
