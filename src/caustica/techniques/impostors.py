"""``impostors``: reflection and refraction of nearby geometry with impostors (Hu and Qin, TVCG 2007, 2.2).

For each reflector/refractor R (glass or mirror) and each other object k
(the ``max_impostors`` nearest to R's centre), each frame (``passes/impostors.py``):

1. RECT_k and TEX_k (2.2.1, fig. 12-13): a rectangle through the object's
   centre, perpendicular to the axis from R's centre to it (a planar object is
   its own rectangle), and a texture of the object alone rendered by a
   (near-)parallel projection along that axis: radiance, and depth along the
   axis. Light, shadows and shading are those of the camera view.
2. Recursion (2.2.1, fig. 1b, 24g): when k is itself a reflector, TEX_k is
   rendered with this technique, its own impostors seen from its centre,
   ``depth`` levels down; at the last level it reflects and refracts the environment.
3. The camera view (depth-search, 2.1): T2 leaving a refractor and, with
   ``reflections`` (fig. 24f), a mirror's reflected ray and the Fresnel
   reflection at a refractor's entry meet every rectangle (``shaders/common/impostors.glsl``):
   Prect; the initial-point rule of 2.2.2 over ``initial_samples`` points of
   the ray inside the object's depth slab (the first whose depth lies beyond
   its selected point's, else the one closest to it); ``impostor_iterations``
   steps of fig. 16 (move along the ray to the depth the texel under the point
   holds; stop once t moves less than ``impostor_tolerance``); the nearest
   rectangle hit wins; a final depth mismatch above ``hit_tolerance`` bounding
   radii, or no rectangle, sees the environment. ``impostor_iterations`` 0 is
   the uncorrected lookup of fig. 18c (Prect's texel). Glass and mirrors are
   shaded deferred (ShadeSurfaces' ``deferred``): once per visible pixel.

A glass object behind another stays visible: it is one of the front object's
impostors, and is refracted by it like any other object.

Limits (the paper's): one rectangle per object, so visibility within an object
is fixed as seen from R's centre (highly concave objects, or objects that hide
parts of each other, go wrong); a ray that misses a rectangle misses its object
(fig. 17, ``rect_offset`` moves rectangles towards R); recursive images are
distorted; two interfaces per refractor (depth-search's limits). Ours: the
parallel projection is a pinhole ``distance_factor`` radii away (<= 1.1 degrees
from parallel at 50); the textures are kept across frames until an object, material,
light or the environment changes (2.2.1: they need updating only when objects move);
impostor textures do not show caustics.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..gpu.meshes import set_uniform
from ..passes.impostors import (
    MAX_IMPOSTORS,
    BuildImpostors,
    ReleaseImpostors,
    bind_impostors,
    chain_uniforms,
    impostor_defines,
    world_index,
)
from ..scene.rules import MAX_COORDINATE
from .base import check_flags, check_integers, check_numbers
from .depth_search import DepthSearch, DepthSearchParams
from .raster import RasterTechnique


@dataclass
class ImpostorParams(DepthSearchParams):
    """Parameters of ``impostors``; the refraction itself takes depth-search's."""

    impostor_size: int = 512  # texels a side of each impostor texture
    depth: int = 0  # recursion levels: reflectors' impostor textures rendered with impostors (fig. 24g: 1)
    impostor_iterations: int = 4  # fig. 16 steps (section 4: four or five; 0: uncorrected)
    impostor_tolerance: float = 1e-3  # stop once the hit distance moves less than this (scene units)
    initial_samples: int = 8  # 2.2.2: points along the ray tried as the seed (0: Prect)
    hit_tolerance: float = 0.05  # a final depth mismatch above this many bounding radii is a miss
    rect_offset: float = 0.0  # rectangles moved towards the reflector by this many radii (fig. 17 RECT'_k)
    distance_factor: float = 50.0  # the parallel projection's pinhole, in bounding radii behind the rectangle
    max_impostors: int = MAX_IMPOSTORS  # nearest objects per reflector
    reflections: bool = True  # reflected rays (mirrors, glass entry) see the impostors (fig. 24f); False: the environment
    write_hits: bool = False  # exit_direction holds the nearby hit point (xyz, w = 1) instead (tests)

    def __post_init__(self):
        super().__post_init__()
        check_integers(self, {"impostor_size": (16, 4096), "depth": (0, 4), "impostor_iterations": (0, 64),
                              "initial_samples": (0, 64), "max_impostors": (1, MAX_IMPOSTORS)})
        check_numbers(self, {"impostor_tolerance": (0.0, MAX_COORDINATE), "hit_tolerance": (0.0, MAX_COORDINATE),
                             "rect_offset": (0.0, 1.0), "distance_factor": (4.0, MAX_COORDINATE)})
        if self.nearby != "none":
            raise ValueError(f"nearby {self.nearby!r}: the impostors technique is its own nearby geometry; leave it 'none'")
        check_flags(self, ("reflections", "write_hits"))


def impostor_view_passes(params: ImpostorParams, depth: int, output: int = 0, photon: bool = False) -> list:
    """Depth-search's passes with the impostors: ShadowMaps, refractor buffers, BuildImpostors,
    ShadeSurfaces (NEARBY impostors), ReleaseImpostors. ``output``/``photon``: NEARBY_OUTPUT, PHOTON_BUFFER."""
    passes = DepthSearch().build_passes(params)
    shade = passes[-1]
    shade.defines = {**shade.defines, "NEARBY": 1, "NEARBY_OUTPUT": output, "PHOTON_BUFFER": int(photon),
                     "IMPOSTOR_ITERATIONS": params.impostor_iterations, "IMPOSTOR_SAMPLES": params.initial_samples,
                     "IMPOSTOR_REFLECTIONS": int(params.reflections)}
    shade.frame_defines = impostor_defines  # MAX_IMPOSTORS: the frame's largest group of rectangles
    # Mirrors that search the rectangles are shaded once per pixel too; without reflections they
    # see the environment, as in depth-search, and stay per-fragment.
    shade.deferred = ("glass", "mirror") if params.reflections else ("glass",)

    def set_impostors(program, frame, obj):
        if obj is None:
            return
        bind_impostors(program, frame.channels.get("impostors"), world_index(frame, obj), params)

    shade.set_uniforms = chain_uniforms(shade.set_uniforms, set_impostors)
    build = BuildImpostors(lambda d: texture_passes(params, d), params.impostor_size, depth, params.rect_offset,
                           params.distance_factor, params.max_impostors)
    return passes[:-1] + [build, shade, ReleaseImpostors()]


def texture_passes(params: ImpostorParams, depth: int) -> list:
    """Passes that render one object into its impostor texture (the frame brings light samples and
    shadow maps): depth-search with impostors ``depth`` levels deep, the environment alone at 0."""
    if depth <= 0:
        return DepthSearch().build_passes(params)[1:]
    return impostor_view_passes(params, depth - 1)[1:]


class Impostors(RasterTechnique):
    name = "impostors"
    summary = "Nearby objects as textured rectangles with depth: iterative lookup, recursion (Hu and Qin 2.2)"
    Params = ImpostorParams

    def build_passes(self, params):
        return impostor_view_passes(params, params.depth, output=1 if params.write_hits else 0)
