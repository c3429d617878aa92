"""``impostors``: reflection and refraction of nearby geometry with impostors (Hu and Qin, TVCG 2007, 2.2).

For each reflector/refractor R (glass or mirror) and each other object k
(the ``max_impostors`` nearest to R's centre), each frame (``passes/nearby/impostors.py``):

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

``merge_planes`` (ours; auto sets it): flat diffuse objects that lie in one plane share one rectangle and
texture (passes/nearby/impostors.py ``coplanar_groups``); a plane's texture is exact, so nothing is lost, and each
ray makes one lookup for them all, and the seams between separate textures are gone (docs/auto.md).

Limits (the paper's): one rectangle per object, so visibility within an object
is fixed as seen from R's centre (highly concave objects, or objects that hide
parts of each other, go wrong); a ray that misses a rectangle misses its object
(fig. 17, ``rect_offset`` moves rectangles towards R); recursive images are
distorted; two interfaces per refractor (depth-search's limits). Ours: the
parallel projection is a pinhole ``distance_factor`` radii away (<= 1.1 degrees
from parallel at 50); the textures are kept across frames until an object, material,
light or the environment changes (2.2.1: they need updating only when objects move);
impostor textures show the caustics of a composed caustic technique (``impostors+caustic-mapping``) on the
objects they stand for, so the floor seen through glass shows its caustic.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..passes.nearby.impostors import BuildImpostors, impostor_defines, world_index
from ..passes.nearby.planes import chain_defines, chain_uniforms
from ..passes.shading.lights import without_light_passes
from ..passes.shading.surfaces import ShadeSurfaces
from ..render.bindings import MAX_IMPOSTORS, bind_impostors
from ..scene.rules import MAX_COORDINATE
from .base import param
from .depth_search import DepthSearch, DepthSearchParams
from .raster import RasterTechnique


@dataclass
class ImpostorParams(DepthSearchParams):
    """Parameters of ``impostors``; the refraction itself takes depth-search's."""

    impostor_size: int = param(512, range=(16, 4096), unit="texels", paper="Hu and Qin 2.2.1",
                               help="texels a side of each impostor texture")
    depth: int = param(0, range=(0, 4), unit="levels", paper="Hu and Qin 2.2.1, fig. 24g",
                       help="recursion: reflectors' impostor textures rendered with impostors (fig. 24g: 1)")
    impostor_iterations: int = param(4, range=(0, 64), paper="Hu and Qin 2.2.2, fig. 16, section 4",
                                     help="depth-correction steps (four or five; 0: the uncorrected lookup)")
    impostor_tolerance: float = param(1e-4, range=(0.0, MAX_COORDINATE), unit="bounding radii", paper="Hu and Qin 2.2.2",
                                      help="stop once the hit distance moves less than this")
    initial_samples: int = param(8, range=(0, 64), paper="Hu and Qin 2.2.2",
                                 help="points along the ray tried as the seed (0: Prect)")
    hit_tolerance: float = param(0.05, range=(0.0, MAX_COORDINATE), unit="bounding radii",
                                 help="a final depth mismatch above this is a miss")
    rect_offset: float = param(0.0, range=(0.0, 1.0), unit="bounding radii", paper="Hu and Qin fig. 17",
                               help="rectangles moved towards the reflector (RECT'_k)")
    distance_factor: float = param(50.0, range=(4.0, MAX_COORDINATE), unit="bounding radii", paper="Hu and Qin 2.2.1",
                                   help="the parallel projection's pinhole behind the rectangle")
    max_impostors: int = param(MAX_IMPOSTORS, range=(1, MAX_IMPOSTORS), unit="objects",
                               help="nearest objects per reflector")
    merge_planes: bool = param(False, help="coplanar flat diffuse objects share one rectangle (ours: a plane's texture "
                                          "is exact, so one lookup serves them all; auto sets it)")
    reflections: bool = param(True, paper="Hu and Qin fig. 24f",
                              help="reflected rays (mirrors, glass entry) see the impostors (False: the environment)")
    write_hits: bool = param(False, help="exit_direction holds the nearby hit point (xyz, w = 1) instead (tests)")

    def __post_init__(self):
        super().__post_init__()
        if self.nearby != "none":
            raise ValueError(f"nearby {self.nearby!r}: the impostors technique is its own nearby geometry; leave it 'none'")


def impostor_view_passes(params: ImpostorParams, depth: int, output: int = 0, photon: bool = False) -> list:
    """Depth-search's passes with the impostors: the light passes, refractor buffers, BuildImpostors,
    ShadeSurfaces (NEARBY impostors). ``output``/``photon``: NEARBY_OUTPUT, PHOTON_BUFFER."""
    passes = DepthSearch().build_passes(params)
    at = next(i for i, stage in enumerate(passes) if isinstance(stage, ShadeSurfaces))
    shade = passes[at]
    shade.defines = {**shade.defines, "NEARBY": 1, "NEARBY_OUTPUT": output, "PHOTON_BUFFER": int(photon),
                     "IMPOSTOR_ITERATIONS": params.impostor_iterations, "IMPOSTOR_SAMPLES": params.initial_samples,
                     "IMPOSTOR_REFLECTIONS": int(params.reflections)}
    shade.frame_defines = chain_defines(shade.frame_defines, impostor_defines)  # MAX_IMPOSTORS: the largest group
    # Mirrors that search the rectangles are shaded once per pixel too; without reflections they
    # see the environment, as in depth-search, and stay per-fragment.
    shade.deferred = ("glass", "mirror") if params.reflections else ("glass",)

    def set_impostors(program, frame, obj):
        if obj is None:
            return
        bind_impostors(program, frame.channels.get("impostors"), world_index(frame, obj), params)

    shade.set_uniforms = chain_uniforms(shade.set_uniforms, set_impostors)
    shade.reads = (*shade.reads, "impostors")  # bound by set_impostors
    build = BuildImpostors(lambda d: texture_passes(params, d), params.impostor_size, depth, params.rect_offset,
                           params.distance_factor, params.max_impostors, params.merge_planes)
    return passes[:at] + [build, shade] + passes[at + 1:]


def texture_passes(params: ImpostorParams, depth: int) -> list:
    """Passes that render one object into its impostor texture (the frame brings light samples and
    shadow maps): depth-search with impostors ``depth`` levels deep, the environment alone at 0."""
    if depth <= 0:
        return without_light_passes(DepthSearch().build_passes(params))
    return without_light_passes(impostor_view_passes(params, depth - 1))


class Impostors(RasterTechnique):
    name = "impostors"
    summary = "Nearby objects as textured rectangles with depth: iterative lookup, recursion (Hu and Qin 2.2)"
    Params = ImpostorParams

    def build_passes(self, params):
        return impostor_view_passes(params, params.depth, output=1 if params.write_hits else 0)
