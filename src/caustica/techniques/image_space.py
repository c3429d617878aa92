"""``image-space``: two-interface refraction (Wyman, "Approximate, Image-Space Refraction").

Follows the chapter's "Refraction Algorithm" and "Putting it Together": a pass
renders the refractors' back faces (outward normal and eye distance); the
shading pass refracts at the front surface (T1), estimates the distance to the
second interface by eq. 6.3.1, d~ = (theta_t/theta_i) d_V + (1 - theta_t/theta_i) d_N,
with d_V from the front and back eye distances and d_N, the distance along -N
to the far side, precomputed per vertex exactly with Embree and cached per mesh
("Approximating Distance d_1"); it projects P2 = P1 + d~ T1 into the back-face
buffer for N2 ("Approximating Surface Normal N2"), using eq. 6.3.2 (a normal
perpendicular to V) where that texel is empty, and refracts out with
eta = n_glass / 1 (T2). "Fixing Problem Cases": total internal reflection at the
exit takes ``tir_mode`` ('keep-t1': T2 = T1; 'clamp': T2 grazes the surface, the
critical angle's limit; 'reflect': T2 reflects and further interfaces are
ignored), and nonconvex refractors take the ``second_surface`` 'farthest' back
face (the authors' preference) or the 'nearest' one (a one-layer depth peel).
``use_dn`` False gives d~ = d_V, which the chapter suggests when the
precomputation is impossible. Added as the chapter invites: exact Fresnel at
both interfaces (F1 reflects the environment, (1 - F2) transmits at the exit;
a TIR fallback transmits all), Beer-Lambert absorption over d~, one IOR per RGB
channel (dispersion). Diffuse receivers and mirrors are shaded as in ``env-map``.
Glass is shaded deferred (ShadeSurfaces' ``deferred``): once per visible pixel,
not per fragment of the mesh's small triangles.

Limits: exactly two interfaces (rays that meet the refractor again, or another
refractor, are not followed); the environment is at infinity (nothing nearby is
seen through the glass) unless ``nearby`` intersects T2 with the diffuse planes
or searches a camera-view texture of the scene without refractors (the
chapter's "intersecting T2 with other geometry"; ``passes/nearby/impostors.py``); d~ is not physically based, so concave objects and
long protrusions are approximated and P2 may land off the refractor (the eq.
6.3.2 fallback); several refractors share one back-face buffer; the method is
designed for n_glass > 1 (for n < 1 the interpolation weight exceeds 1).
"""
from __future__ import annotations

from dataclasses import dataclass

from ..passes.nearby.planes import NearbyParams, nearby_option
from ..passes.shading.image_space import FrontDistanceAlongNormal
from ..passes.shading.lights import light_passes
from ..passes.shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from .base import param
from .env_map import ShadowedParams
from .raster import RasterTechnique

TIR_MODES = ("keep-t1", "clamp", "reflect")
SECOND_SURFACES = ("farthest", "nearest")


@dataclass
class ImageSpaceParams(NearbyParams, ShadowedParams):
    """Parameters of ``image-space``; ``shadow_map_size`` lights diffuse receivers.

    ``tir_mode`` defaults to 'clamp', one of the two the chapter recommends: through a glass
    sphere its exit directions are the closest of the three to the exact ones (tests/test_image_space.py).
    """

    tir_mode: str = param("clamp", choices=TIR_MODES, paper="Wyman, Fixing Problem Cases",
                          help="exit TIR: 'keep-t1' (T2 = T1), 'clamp' (T2 grazes the surface) or 'reflect'")
    second_surface: str = param("farthest", choices=SECOND_SURFACES, paper="Wyman, Fixing Problem Cases",
                                help="nonconvex refractors: the farthest back face (the authors') or the nearest")
    use_dn: bool = param(True, paper="Wyman, eq. 6.3.1", help="d~ interpolates d_V and d_N (False: d~ = d_V)")


class ImageSpace(RasterTechnique):
    name = "image-space"
    summary = "Two-interface refraction: d_V/d_N distance estimate, back-face normals, TIR fallbacks (Wyman)"
    Params = ImageSpaceParams
    view_order = 20

    def build_passes(self, params):
        inputs = ("back_surface", "front_dn") if params.use_dn else ("back_surface",)
        nearby = nearby_option(params.nearby, params)  # Wyman's nearby geometry (passes/nearby/impostors.py)
        defines = {"USE_DN": params.use_dn, "TIR_MODE": TIR_MODES.index(params.tir_mode), **nearby.defines}
        passes = [*light_passes(params.shadow_map_size), RefractorSurfaces("back", params.second_surface)]
        if params.use_dn:
            passes.append(FrontDistanceAlongNormal())
        passes += nearby.passes
        passes.append(ShadeSurfaces("passes/shading/image_space.frag", defines, inputs=inputs + nearby.inputs,
                                    set_uniforms=nearby.set_uniforms, deferred=("glass",),
                                    frame_defines=nearby.frame_defines))
        passes.append(ShadeBackground())
        return passes
