"""The passes that light the diffuse receivers, in order: the light samples' shadow maps, then the environment's
lobes and light maps (each None unless the frame's parameters ask for them: auto plans them), then the glossy
receivers' reflection probes (None without glossy receivers)."""
from __future__ import annotations

from ...render.frame import Pass
from .environment import EnvironmentLightMaps, EnvironmentLobeMaps
from .reflection_probes import ReflectionProbes
from .shadows import ShadowMaps


def light_passes(shadow_map_size: int) -> list[Pass]:
    """ShadowMaps, EnvironmentLobeMaps, EnvironmentLightMaps and the glossy receivers' ReflectionProbes: what
    ShadeSurfaces reads of the light."""
    return [ShadowMaps(shadow_map_size), EnvironmentLobeMaps(), EnvironmentLightMaps(), ReflectionProbes()]


def without_light_passes(passes: list) -> list:
    """``passes`` less the light passes: what a view inside the frame (an impostor texture, a photon view) runs
    on the frame's own light samples and maps."""
    return [p for p in passes
            if not isinstance(p, (ShadowMaps, EnvironmentLobeMaps, EnvironmentLightMaps, ReflectionProbes))]
