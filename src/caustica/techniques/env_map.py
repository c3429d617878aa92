"""``env-map``: the single-interface baseline every paper compares against.

Reflection and one refraction of the distant environment at the front
surface, exact dielectric Fresnel, Beer-Lambert tint over the front-to-back
thickness (Wyman, section 2 discusses this baseline; Hu and Qin fig. 10a).
Mirrors reflect the environment. Diffuse receivers: direct light with shadow
maps (a six-face map for point lights) plus unoccluded ambient from the
environment's SH irradiance.

Limits: one interface (the ray never leaves through the back), nothing nearby
is seen in reflections or refractions, no caustics.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..lighting.bake import MAX_BAKE_SIZE
from ..lighting.environment import MAX_LOBES
from ..passes.shading.lights import light_passes
from ..passes.shading.surfaces import RefractorSurfaces, ShadeBackground, ShadeSurfaces
from ..scene.materials import Diffuse
from .base import Params, param
from .raster import RasterTechnique


@dataclass
class ShadowedParams(Params):
    """Parameters of techniques that light diffuse receivers with shadow maps."""

    shadow_map_size: int = param(1024, range=(16, 8192), unit="texels",
                                 help="shadow map texels a side (per cube face for point lights)")
    environment_bake: int = param(0, range=(0, MAX_BAKE_SIZE), special={0: "none: the environment's SH irradiance"},
                                  unit="texels", help="light maps of the environment's light on the diffuse "
                                                      "receivers, the floor's this many texels a side (what auto "
                                                      "plans; docs/environment-light.md)")
    environment_lobes: int = param(0, range=(0, MAX_LOBES), special={0: "none"},
                                   help="the environment's light on diffuse surfaces as this many shadowed strata "
                                        "(docs/environment-light.md); light maps, where given, take their place")
    drop_invisible_glass: bool = param(False, help="leave out glass of IOR 1 that absorbs nothing, which neither "
                                                   "reflects, bends nor tints light (a path tracer renders it as air): "
                                                   "no glass pixel, shadow, caustic or impostor of it (what auto plans)")


class EnvMap(RasterTechnique):
    name = "env-map"
    summary = "Single-interface reflection/refraction of the environment with Fresnel (the baseline)"
    Params = ShadowedParams
    view_order = 10

    def build_passes(self, params):
        # The back faces only give the Beer-Lambert thickness: skipped when no glass absorbs.
        return [*light_passes(params.shadow_map_size), RefractorSurfaces("back", "farthest", absorbing_only=True),
                ShadeSurfaces(), ShadeBackground()]


class Plain(RasterTechnique):
    """``plain``: every object shaded as a grey diffuse surface (textured and glossy surfaces keep their own
    material); the cost floor benchmarks divide by."""

    name = "plain"
    summary = "Every object shaded diffuse with shadow maps: the cost floor for benchmarks"
    Params = ShadowedParams

    def build_passes(self, params):
        # Everything diffuse: no refractor buffer to draw or read.
        return [*light_passes(params.shadow_map_size), ShadeSurfaces(material_override=Diffuse(), inputs=()),
                ShadeBackground()]
