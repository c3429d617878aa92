"""``depth-search``: two-interface refraction by depth search, no preprocessing.

Hu and Qin, "Interactive reflections, refractions and caustics with impostors"
(TVCG 2007), section 2.1 and the acceleration of section 4. Two camera-view
buffers hold the nearest front faces and the farthest back faces of the
refractors (outward normal and eye distance). For each glass fragment:

1. T1 = Snell refraction of the view ray at P1 (2.1, fig. 4).
2. Front or back exit (2.1.2, figs. 5-7): a binary search along the projected T1
   (``search_steps`` steps from ``search_start``) finds the silhouette point Pe;
   P2 is front-facing when the angle between V and T1 exceeds the angle between
   V and Pe - P1. With ``assume_back_first`` (section 4) the back-face iteration
   runs first and the search only where P2 left the silhouette; the angle test
   still decides there.
3. dT (2.1.3, figs. 8-9): S is the surface the chosen buffer holds where
   P1 + dT T1 projects; back exits drive the depth gap |S - E| - |P1 + dT T1 - E|
   to zero, front exits jump to the tangent plane at S, for at most
   ``iterations`` steps or until dT moves less than ``tolerance`` (a fraction of the object's size).
   ``back_iteration``: "depth-step" is fig. 8 read literally; "secant" and
   "sphere-secant" (ours, the default) start at the chord of the sphere that
   fits the thickness d_V at P1 and step by secants.
4. N2 from the front or back normal buffer at P2 (2.1.4), T2 = refract(T1, N2),
   environment lookup (fig. 10c); where no buffer holds P2, T2 = T1.
5. Ours: ``internal_bounces`` follows the light reflected inside at each exit, with
   ``bounce_iterations`` dT corrections (2.1.3's tangent-plane step) from the last chord; on dispersive
   glass red and blue reuse green's lookups there (``shared_bounce_lookups``), their own at the first exit.
6. Ours: ``convex_exits`` computes every exit exactly where the glass is an analytic sphere or a mesh bounded
   by at most ``MAX_CONVEX_PLANES`` planes and ``MAX_CONVEX_QUADRICS`` spherical or cylindrical faces, convex
   or concave (a polyhedron, a lens; ``passes/shading/convex_exits.py``), the depth search elsewhere.

Works for n_t < n_i (fig. 10). Exact dielectric Fresnel at every interface,
Beer-Lambert absorption inside; with dispersion the geometry follows the green
IOR and each channel refracts with its own. T2 is written to output location 1.

Limits: two interfaces (more with ``internal_bounces``); P2 is found in screen
space, as exact as the buffers and only inside the view; one silhouette per
search line and one layer per buffer (concave objects and overlapping
refractors give wrong exits, as the paper states); nothing nearby is seen
through the glass unless ``nearby`` (``passes/nearby/impostors.py``; the ``impostors``
technique is the paper's own answer, 2.2). Design notes and measurements:
docs/benchmarks-archive.md, "depth-search design notes".
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform
from ..passes.caustics.casters import half_diagonal
from ..passes.nearby.planes import NearbyParams, chain_defines, chain_uniforms, nearby_option
from ..passes.shading.convex_exits import MAX_CONVEX_PLANES, MAX_CONVEX_QUADRICS, bind_convex_shape, convex_defines
from ..passes.shading.glass_contact import bind_contact_plane, contact_defines
from ..passes.shading.lights import light_passes
from ..passes.shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from .base import param
from .env_map import ShadowedParams
from .raster import RasterTechnique

MAX_INTERNAL_BOUNCES = 8
BACK_ITERATIONS = ("sphere-secant", "secant", "depth-step")
AS_ITERATIONS = -1  # bounce_iterations: as many dT corrections at the bounced exits as at the first


@dataclass
class DepthSearchParams(NearbyParams, ShadowedParams):
    """Parameters of ``depth-search``; defaults follow Hu and Qin (2.1.2, 2.1.3, section 4)."""

    search_steps: int = param(8, range=(1, 16), paper="Hu and Qin 2.1.2",
                              help="binary-search steps for the silhouette point (eight suffice)")
    search_start: float = param(0.75, range=(0.0, 2.0), ends="(]", unit="buffer sizes", paper="Hu and Qin 2.1.2",
                                help="first test point, as a fraction of the buffer size (the paper: 75 percent)")
    iterations: int = param(5, range=(0, 32), paper="Hu and Qin 2.1.3, section 4",
                            help="dT corrections (\"four or five iterations are enough\")")
    tolerance: float = param(1e-3, range=(0.0, 1.0), unit="glass sizes", paper="Hu and Qin 2.1.3",
                             help="stop correcting once dT moves less than this fraction of the glass object's size "
                                  "(half its bounding box's diagonal: the same image at any scale of the scene)")
    assume_back_first: bool = param(True, paper="Hu and Qin section 4", help="iterate on the back faces first")
    back_iteration: str = param("sphere-secant", choices=BACK_ITERATIONS, paper="Hu and Qin 2.1.3, fig. 8 (depth-step)",
                                help="back-face steps: secant from the sphere fitting d_V, secant from d_V (ours), "
                                     "or the paper's depth-step")
    internal_bounces: int = param(0, range=(0, MAX_INTERNAL_BOUNCES),
                                  help="our extension: internal reflections followed to further exits (0: the paper)")
    bounce_iterations: int = param(AS_ITERATIONS, range=(0, 32), special={AS_ITERATIONS: "as iterations"},
                                   help="ours, with internal_bounces: dT corrections at each bounced exit, which "
                                        "starts from the last chord (exact on a sphere)")
    shared_bounce_lookups: bool = param(True, help="ours, for dispersive glass with internal_bounces: red and blue "
                                                   "reuse green's lookups at the bounced exits (False: each channel "
                                                   "its own, 3 lookups a bounce)")
    convex_exits: bool = param(False, help="ours: exact exits, every bounce, from analytic spheres and meshes bounded by "
                                           f"at most {MAX_CONVEX_PLANES} planes and {MAX_CONVEX_QUADRICS} spherical or "
                                           "cylindrical faces (convex polyhedra, lenses; False: the depth search for all glass; "
                                           "auto sets it)")


class DepthSearch(RasterTechnique):
    name = "depth-search"
    summary = "Two-interface refraction: silhouette binary search + iterative dT against depth buffers (Hu and Qin)"
    Params = DepthSearchParams
    view_order = 30

    def build_passes(self, params):
        def set_uniforms(program, frame, obj):
            if obj is not None:
                set_uniform(program, "tolerance", params.tolerance * half_diagonal([obj]))  # a fraction of its size
                if params.convex_exits:
                    bind_convex_shape(program, obj)
                bind_contact_plane(program, frame.scene, obj)
                return
            set_uniform(program, "world_from_clip", np.linalg.inv(frame.camera.clip_from_world()))
            set_uniform(program, "search_steps", params.search_steps)
            set_uniform(program, "search_start", params.search_start)
            set_uniform(program, "iterations", params.iterations)
            set_uniform(program, "bounce_iterations", params.iterations if params.bounce_iterations == AS_ITERATIONS
                        else params.bounce_iterations)

        nearby = nearby_option(params.nearby, params)  # Wyman's nearby geometry (passes/nearby/impostors.py)
        defines = {**nearby.defines, "INTERNAL_BOUNCES": params.internal_bounces,
                   "SHARED_BOUNCES": int(params.shared_bounce_lookups),
                   "ASSUME_BACK_FIRST": int(params.assume_back_first),
                   "BACK_SECANT": int(params.back_iteration != "depth-step"),
                   "BACK_SPHERE_START": int(params.back_iteration == "sphere-secant")}
        return [
            *light_passes(params.shadow_map_size),
            RefractorSurfaces("back", "farthest"),
            *nearby.passes,
            # The front-surface buffer comes from the glass G-buffer draw (captures_front_surface).
            ShadeSurfaces("passes/shading/depth_search.frag", defines,
                          inputs=("front_surface", "back_surface", *nearby.inputs),
                          set_uniforms=chain_uniforms(set_uniforms, nearby.set_uniforms), deferred=("glass",),
                          frame_defines=chain_defines(nearby.frame_defines, contact_defines,
                                                      convex_defines if params.convex_exits else None),
                          captures_front_surface=True,
                          # Back faces first: the search runs in a second resolve stage, only where needed.
                          staged=("glass",) if params.assume_back_first else ()),
            ShadeBackground(),
        ]
