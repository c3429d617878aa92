"""``photon-splats``: image-space caustics from a photon buffer splatted into a caustic map (Wyman).

Wyman, "Approximate, Image-Space Caustics" (with Davis, I3D 2006), in the
chapter after "Approximate, Image-Space Refraction". Per light sample:

1. Rendering from the light ("Rendering From the Light"): the scene is drawn
   from the light with the image-space refraction routine of ``image-space``
   (``passes/caustics/photon_splats.py``, :class:`RefractFromLight`): T1 at the front
   surface, d~ = (theta_t/theta_i) d_V + (1 - theta_t/theta_i) d_N (eq. 6.3.1)
   with d_V from the light's front and farthest back distances and d_N per
   vertex (exact, cached), P2 = P1 + d~ T1, N2 from the back faces at P2's
   projection (eq. 6.3.2 where empty), T2, and ``tir_mode`` at the exit as in
   ``image-space`` ('keep-t1', 'clamp', 'reflect') or 'drop'. Through a sphere
   the exact paths never meet TIR, but d~ and N2 send about a fifth of the flux
   (the rim) beyond the critical angle at the estimated exit; 'keep-t1' (the
   default here) keeps those photons near their true path, where 'clamp'
   (image-space's default) scatters them far (docs/measured-defaults.md). The photon buffer
   is ``photon_buffer_size`` texels a side, fitted around the refractors (the
   paper couples it to the shadow map; fitting spends every photon on the
   refractors). Water (open meshes, not those with small holes:
   ``casters.caster_code``) refracts once; mirrors reflect once
   ("any interactive reflection or refraction scheme").
2. Photon hits (the photon buffer): each exit ray lands on the receivers found
   from a distance estimate (:class:`LandPhotons`: Newton-Raphson steps of
   Shah et al.'s intersection estimate against the receivers' light-space
   position texture, the one ``caustic-mapping`` uses). A first landing on a
   coarse view of the whole scene fits the caustic map's view tightly around
   the hits (``passes/caustics/light_space.py``: FitCausticViews in ``landing_chain``, the
   chain ``caustic-mapping`` runs too); the photons then
   land again on that view's receivers, ``land_iterations`` steps from the first hits.
3. Caustic map ("Rendering the Caustic Map"): Gaussian splats of radius
   ``splat_radius`` caustic-map texels (sigma = radius / 2; the paper's 7 x 7
   splats are radius 3) at least, widened to each photon's footprint (the area
   its photon-buffer texel lands on, from the neighbours' landing points:
   ``passes/caustics/light_space.py``, SplatPhotons; fixed splats beat against the map's
   texels where the photons spread apart), additive point sprites as in the paper or a compute
   shader with fixed-point atomics (``splat``). Energy: the paper's weights sum to
   R = pixelsInCausticMap / totalPhotons, counting photons; ours carry
   physical flux (the light's intensity times the texel's solid angle, the
   per-photon weighting the paper notes it ignores, times exact Fresnel
   transmittance (1 - F1)(1 - F2) and Beer-Lambert exp(-sigma_a d~)), and
   every splat's weights sum to one, so the map (flux / receiver texel area)
   is irradiance in W/m^2, the ``caustic_maps`` contract
   (``passes/caustics/maps.py``). RGB dispersion: one photon per channel.
4. Applying the caustic map: the view technique's surface shader projects it
   like a shadow map (``shaders/common/caustics.glsl``). The map is rebuilt only
   when a light, an object or a material changes (CachedPasses; "Putting it
   Together").

Approximate: d~ is not physically based (the exit point and N2 are off for
oblique paths, which blurs and shifts the focus: see tests/test_photon_splats.py;
through the flat faces of caustics-prism the dispersed spot lands 0.1 short of
the exact trace's, tests/test_caustics_oracle.py),
one back-face layer (farthest) for all refractors, exit TIR handled by
``tir_mode`` instead of internal bounces, the first caster layer only, the
receiver found by an estimate against one light-space layer (a receiver hidden
from the light gets no caustic), Fresnel-reflected light off glass is not
splatted, one photon per texel (where the photons spread apart the footprint
splats blur the caustic to their spacing).
Limits: at most 32 casters.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..passes.caustics.light_space import landing_chain
from ..passes.caustics.photon_splats import TIR_MODES, LandPhotons, RefractFromLight
from .base import param
from .composite import SPLATS, CausticTechnique
from .env_map import ShadowedParams


@dataclass
class PhotonSplatsParams(ShadowedParams):
    """Parameters of ``photon-splats`` (Wyman)."""

    photon_buffer_size: int = param(512, range=(8, 4096), unit="photons", paper="Wyman, Rendering From the Light",
                                    help="photons a side of the light's view of the refractors")
    caustic_map_size: int = param(256, range=(16, 4096), unit="texels", paper="Wyman, Rendering the Caustic Map",
                                  help="caustic-map texels a side (per cube face); the paper: photons at twice this")
    splat_radius: float = param(1.5, range=(0.75, 8.0), unit="texels", paper="Wyman, Rendering the Caustic Map",
                                help="Gaussian splat radius (sigma = radius / 2; the paper's 7x7: 3)")
    splat: str = param("auto", choices=SPLATS, paper="Wyman, Rendering the Caustic Map",
                       help="'points' (additive point sprites, the paper), 'compute' (fixed-point atomics) or 'auto'")
    tir_mode: str = param("keep-t1", choices=TIR_MODES, paper="Wyman, Fixing Problem Cases",
                          help="exit TIR: as image-space's, or 'drop' the photon")
    use_dn: bool = param(True, paper="Wyman, eq. 6.3.1", help="d~ interpolates d_V and d_N (False: d~ = d_V)")
    land_iterations: int = param(2, range=(0, 64), paper="Shah et al. appendix",
                                 help="Newton-Raphson steps landing the photons on the fitted map's receivers")


class PhotonSplats(CausticTechnique):
    name = "photon-splats"
    summary = "Caustics from the light: refraction routine into a photon buffer, Gaussian splats in a caustic map (Wyman)"
    Params = PhotonSplatsParams

    def caustic_passes(self, params):
        p = params
        return [landing_chain("photon-splats", p, [RefractFromLight(p.tir_mode, p.use_dn)], LandPhotons,
                              caster_size=p.photon_buffer_size, map_size=p.caustic_map_size,
                              steps=p.land_iterations, splat=p.splat, splat_radius=p.splat_radius)]
