"""``depth-search``: two-interface refraction by depth search, no preprocessing.

Hu and Qin, "Interactive reflections, refractions and caustics with impostors"
(TVCG 2007), section 2.1 and the acceleration of section 4. Two camera-view
buffers hold the nearest front faces and the farthest back faces of the
refractors (outward normal and eye distance). For each glass fragment:

1. T1 = Snell refraction of the view ray at P1 (2.1, fig. 4).
2. Front or back exit (2.1.2, figs. 5-7): a binary search along the projected
   T1 (``search_steps`` steps, the first test point ``search_start`` times the
   buffer size away) finds the silhouette pixel pe; unprojected it gives Pe,
   and P2 is front-facing when the angle between V and T1 exceeds the angle
   between V and Pe - P1. With ``assume_back_first`` (section 4, the paper's
   recommendation and our default) the back-face iteration runs first and the
   search runs only where P2 left the silhouette during it; unlike the paper,
   which then declares a front exit outright, we let the angle test decide
   (overshooting back-face steps near the rim would otherwise flip to front).
3. dT (2.1.3, figs. 8-9; the figures' exact update is not in the text): S is
   the surface the chosen buffer holds where P1 + dT T1 projects (bilinear
   between texels that all hold a surface, for sub-texel P2 and N2; where
   some are empty, the covered one with the largest weight, so that a point
   less than a texel off the silhouette still finds its edge). Back
   exits drive the depth gap |S - E| - |P1 + dT T1 - E| to zero.
   ``back_iteration`` "depth-step" reads fig. 8 literally: the paper's small
   initial dT, each step the gap over T1's rate along the pixel ray (as if
   the back face were flat). "secant" (ours) starts at the refractor's
   thickness along the view ray at P1 (Wyman's d_V, read from the back
   buffer, still no preprocessing) and steps by the secant through the last
   two steps, which follows the face's tilt, each step at most twice the
   flat-face one (no overshoot off the rim): on the IOR 1.5 sphere at 512^2
   the mean / p95 exit error drop from 0.185 / 0.162 to 0.024 / 0.079
   degrees (rim pixels no longer fail). "sphere-secant" (ours, the default)
   takes the same steps from a better start: the sphere that touches the
   surface at P1 and cuts the chord d_V = 2 R cos(theta_i) from the view ray
   cuts 2 R cos(theta_t) from T1, so dT starts at d_V cos(theta_t) /
   cos(theta_i), exact on a sphere and close on any smooth convex part. On
   the IOR 1.5 sphere at 512^2 the back-face iteration then takes 1.04 steps
   per pixel on average instead of 3.4, for the same exit error;
   teapot and bunny errors are unchanged (docs/benchmarks.md). Front exits
   start from |Pe - P1| (dT -> 0 is a fixed point on the front faces), with
   "sphere-secant" from the same chord, which ends on a front face just as
   well (IOR 0.8 sphere at 512^2: mean / p95 exit error 0.48 / 0.76 -> 0.15 /
   0.25 degrees with the edge lookup above), and jump to the tangent plane at
   S. A point off the silhouette steps back halfway. ``iterations`` steps at
   most, fewer once dT moves less than ``tolerance`` (scene units): that step
   is kept, with N2 from the surface read before it, without one more lookup
   to confirm it. The plain fixed point dT <- |S - P1| we tried first needs
   about 8 steps where these need 4 to 5.
4. N2 from the front or back normal buffer at P2 (2.1.4), T2 = refract(T1, N2),
   environment lookup (fig. 10c). Where no buffer holds P2, T2 = T1.
5. Our extension, not in the paper: ``internal_bounces`` (default 0, the paper's
   two interfaces, bit for bit) follows the light reflected inside at each exit
   (weight F) to the next exit, up to that many times. First guess: the previous
   chord length (exact on a sphere, whose successive chords are equal); then
   step 3's tangent-plane correction against whichever buffer holds the surface
   nearer the point in eye distance, since the next exit may be front- or
   back-facing. At each exit (1 - F) leaves by Snell; TIR at the last exit
   leaves in the reflected direction, as the paper's single exit does.

Works for n_t < n_i (the IOR 0.8 sphere of fig. 10: T1 bends away from the
normal and often exits through a front face). Shading: exact dielectric Fresnel
at every interface, Beer-Lambert absorption over the path length inside.
Dispersion: the geometry (P2, N2, further exits) is found for the green
channel's IOR; each channel then refracts with its own IOR at every interface.
Entry TIR (IOR < 1) reflects only; exit TIR (not treated by the paper) reflects
once at the last exit and leaves to the environment. The exit direction T2 (at
P2) is written to output location 1. ``internal_bounces`` and
``assume_back_first`` are compile-time switches (shader variants): llvmpipe
runs both sides of every branch. Glass is shaded deferred (ShadeSurfaces'
``deferred``), once per visible pixel rather than per fragment of the mesh's
small triangles; the front-face buffer is written by that G-buffer draw of the
glass (drawn before the other objects), which saves drawing every refractor
once more (``captures_front_surface``; a separate pass where it cannot).

Limits: two interfaces (more with ``internal_bounces``); P2 found in screen
space, so it is only as exact as the buffers' resolution and it must lie inside
the view; one silhouette per search line and one layer per buffer (highly
concave objects and overlapping refractors give wrong exits, as the paper
states); the light reflected inside at the last exit followed is dropped (at P2
unless ``internal_bounces`` > 0); nothing nearby is seen through the glass
unless ``nearby`` (Wyman's planes or image-space search,
``passes/impostors.py``; the ``impostors`` technique is the paper's own
answer, 2.2).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..gpu.meshes import set_uniform
from ..passes.impostors import NearbyParams, chain_uniforms, nearby_option
from ..passes.lights import ShadowMaps
from ..passes.surfaces import RefractorSurfaces, ShadeSurfaces
from ..scene.rules import MAX_COORDINATE
from .base import param
from .env_map import ShadowedParams
from .raster import RasterTechnique

MAX_INTERNAL_BOUNCES = 8
BACK_ITERATIONS = ("sphere-secant", "secant", "depth-step")


@dataclass
class DepthSearchParams(NearbyParams, ShadowedParams):
    """Parameters of ``depth-search``; defaults follow Hu and Qin (2.1.2, 2.1.3, section 4)."""

    search_steps: int = param(8, range=(1, 16), paper="Hu and Qin 2.1.2",
                              help="binary-search steps for the silhouette point (eight suffice)")
    search_start: float = param(0.75, range=(0.0, 2.0), ends="(]", unit="buffer sizes", paper="Hu and Qin 2.1.2",
                                help="first test point, as a fraction of the buffer size (the paper: 75 percent)")
    iterations: int = param(5, range=(0, 32), paper="Hu and Qin 2.1.3, section 4",
                            help="dT corrections (\"four or five iterations are enough\")")
    tolerance: float = param(1e-3, range=(0.0, MAX_COORDINATE), unit="scene units", paper="Hu and Qin 2.1.3",
                             help="stop correcting once dT moves less than this")
    assume_back_first: bool = param(True, paper="Hu and Qin section 4", help="iterate on the back faces first")
    back_iteration: str = param("sphere-secant", choices=BACK_ITERATIONS, paper="Hu and Qin 2.1.3, fig. 8 (depth-step)",
                                help="back-face steps: secant from the sphere fitting d_V, secant from d_V (ours), "
                                     "or the paper's depth-step")
    internal_bounces: int = param(0, range=(0, MAX_INTERNAL_BOUNCES),
                                  help="our extension: internal reflections followed to further exits (0: the paper)")


class DepthSearch(RasterTechnique):
    name = "depth-search"
    summary = "Two-interface refraction: silhouette binary search + iterative dT against depth buffers (Hu and Qin)"
    Params = DepthSearchParams

    def build_passes(self, params):
        def set_uniforms(program, frame, obj):
            if obj is not None:
                return
            set_uniform(program, "world_from_clip", np.linalg.inv(frame.camera.clip_from_world()))
            set_uniform(program, "search_steps", params.search_steps)
            set_uniform(program, "search_start", params.search_start)
            set_uniform(program, "iterations", params.iterations)
            set_uniform(program, "tolerance", params.tolerance)

        nearby = nearby_option(params.nearby, params)  # Wyman's nearby geometry (passes/impostors.py)
        defines = {**nearby.defines, "INTERNAL_BOUNCES": params.internal_bounces,
                   "ASSUME_BACK_FIRST": int(params.assume_back_first),
                   "BACK_SECANT": int(params.back_iteration != "depth-step"),
                   "BACK_SPHERE_START": int(params.back_iteration == "sphere-secant")}
        return [
            ShadowMaps(params.shadow_map_size),
            RefractorSurfaces("back", "farthest"),
            *nearby.passes,
            # The front-surface buffer comes from the glass G-buffer draw (captures_front_surface).
            ShadeSurfaces("passes/depth_search.frag", defines,
                          inputs=("front_surface", "back_surface", *nearby.inputs),
                          set_uniforms=chain_uniforms(set_uniforms, nearby.set_uniforms), deferred=("glass",),
                          captures_front_surface=True,
                          # Back faces first: the search runs in a second resolve stage, only where needed.
                          staged=("glass",) if params.assume_back_first else ()),
        ]
