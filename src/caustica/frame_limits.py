"""What one frame may ask of the GL, checked before rendering: samples per pixel, render-target memory,
texture sides. Pure arithmetic (no GL calls): the renderer passes the GL's limits in.

The memory figure is an estimate, not an account of every allocation: ``BYTES_PER_SAMPLE`` for the
camera-sized targets at the supersampled size (colour, depth, normals and the technique's channels,
a few rgba16f/rgba32f textures), with ``antialias="msaa"`` the targets passes/post/subpixel.py adds (their
formats' bytes), plus, per light sample, each square map a technique's parameters ask
for (six faces for point lights: cube maps). Above ``MEMORY_BUDGET`` the frame is refused with the
figure; on a GPU with more memory raise ``caustica.frame_limits.MEMORY_BUDGET``.
"""
from __future__ import annotations

import dataclasses

from .errors import EnvironmentImageError, RenderOptionError
from .gpu.readback import supersampling_factor
from .scene import rules

MAX_SPP = 4096
MEMORY_BUDGET = 8 << 30  # bytes; llvmpipe allocates in system memory
BYTES_PER_SAMPLE = 64
# Square maps a technique's parameters size, and their bytes per texel: shadow maps hold r32f depth
# and a 32-bit depth buffer; caustic, photon and impostor maps rgba32f.
MAP_BYTES_PER_TEXEL = {"shadow_map_size": 8, "map_size": 16, "caustic_map_size": 16, "photon_buffer_size": 16,
                       "photon_buffer": 16, "photon_grid": 16, "caustic_size": 16, "impostor_size": 16}


def check_spp(spp) -> int:
    """Samples per pixel: an integer in [1, MAX_SPP] (not a bool, not a string)."""
    return rules.integer(spp, "samples per pixel (spp)", 1, MAX_SPP, error=RenderOptionError)


def _gib(nbytes: float) -> str:
    return f"{nbytes / (1 << 30):.1f} GiB"


def _map_sides(params) -> dict[str, int]:
    """Each map-sizing parameter of ``params`` (a dataclass or a tuple of them) and its largest side."""
    sides: dict[str, int] = {}
    for part in params if isinstance(params, tuple) else (params,):
        if not dataclasses.is_dataclass(part):
            continue
        for f in dataclasses.fields(part):
            value = getattr(part, f.name)
            if f.name in MAP_BYTES_PER_TEXEL and isinstance(value, int) and not isinstance(value, bool):
                sides[f.name] = max(sides.get(f.name, 0), value)
    return sides


def light_faces(scene) -> int:
    """Map faces over every light sample: six (a cube) per point-like sample, one per spot or directional light."""
    faces = 0
    for light in scene.lights:
        faces += 6 * getattr(light, "samples", 1) if light.kind in ("point", "line") else 1
    return max(faces, 1)


def antialias_bytes(antialias: str) -> int:
    """Bytes per sample the ``antialias`` mode's own targets add to a frame (``msaa``: passes/subpixel.TARGETS)."""
    if antialias != "msaa":
        return 0
    from .gpu.targets import format_bytes
    from .passes.post.subpixel import TARGETS

    return sum(format_bytes(fmt, samples) for fmt, samples in TARGETS)


def target_bytes(size: tuple[int, int], spp: int, antialias: str = "none") -> int:
    """The estimated bytes of a ``size`` frame's camera-sized render targets at ``spp`` with ``antialias``."""
    width, height = size
    k = supersampling_factor(spp)
    return width * height * k * k * (BYTES_PER_SAMPLE + antialias_bytes(antialias))


def check_frame_memory(size: tuple[int, int], spp: int, params, scene, budget: int | None = None,
                       antialias: str = "none") -> None:
    """RenderOptionError when the frame's render targets and maps would need more than the budget."""
    budget = MEMORY_BUDGET if budget is None else budget
    width, height = size
    k = supersampling_factor(spp)
    targets = target_bytes(size, spp, antialias)
    if targets > budget:
        raise RenderOptionError(
            f"a {width}x{height} frame at {spp} spp ({k}x{k} samples a pixel)"
            f"{' with msaa' if antialias == 'msaa' else ''} needs about {_gib(targets)} of render targets, above the GL memory budget of {_gib(budget)}; use a "
            "smaller size or fewer samples")
    faces = light_faces(scene)
    for name, side in _map_sides(params).items():
        maps = side * side * MAP_BYTES_PER_TEXEL[name] * faces
        if targets + maps > budget:
            raise RenderOptionError(
                f"{name} {side} over {faces} light map faces needs about {_gib(maps)}, with the frame's "
                f"{_gib(targets)} above the GL memory budget of {_gib(budget)}; lower {name} or use fewer lights")


def check_environment_texture(environment, limit: int) -> None:
    """EnvironmentImageError when the environment image is larger than the GL's texture limit."""
    height, width = environment.image.shape[:2]
    if max(width, height) > limit:
        raise EnvironmentImageError(
            f"environment image {environment.source} is {width}x{height} pixels, above this GL's texture limit of "
            f"{limit}; downsample it to at most {limit} pixels a side")


def check_map_sides(params, scene, limit: int) -> None:
    """RenderOptionError when a parameter's map is wider than the GL's texture limit: shadow maps of point
    lights lie as six faces side by side in one texture (passes/shading/shadows.py), the other maps are squares."""
    strip = 6 if any(light.kind in ("point", "line") for light in scene.lights) else 1
    for name, side in _map_sides(params).items():
        width = side * (strip if name == "shadow_map_size" else 1)
        if width > limit:
            layout = f" (six {side}-texel cube faces side by side for point lights)" if width != side else ""
            raise RenderOptionError(f"{name} {side} needs a texture {width} texels wide{layout}, above this GL's "
                                    f"texture limit of {limit}; use {name} <= {limit // (width // side)}")
