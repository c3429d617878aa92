"""The environment's light in the raster techniques (issue 23): its sun as a directional light, the rest as SH.

A small, very bright region of the environment (a sun) lights diffuse surfaces through a sharp shadow and
focuses through glass into a caustic; the unoccluded SH irradiance (Ramamoorthi and Hanrahan 2001) the
raster techniques give diffuse surfaces has neither. So at frame setup the sun is taken out of the
environment as a :class:`~caustica.scene.lights.DirectionalLight` that goes through the same shadow-map and
caustic-map machinery as the scene's lights (``passes/lights.py``: ``light_samples`` appends it, flagged
``environment``), and the diffuse ambient becomes the SH irradiance of the rest. Glass and mirrors still
look the sun up in the environment; users' ``scene.lights`` never see it. docs/environment-light.md.

The bright region is the one ``exact`` samples (:class:`~caustica.raytrace.environment_light.EnvironmentLight`:
texels above ``BRIGHT_RATIO`` times the mean radiance); the split adds up to the original image exactly.
The light's irradiance is the bright part's radiance integrated over solid angle (per channel), its
direction of travel minus the power-weighted mean direction, both estimated from SUN_SAMPLES stratified
samples of ``EnvironmentLight.sample_bright`` (which samples by power, so the estimate is near exact). A
bright part spread wider than SUN_SPREAD degrees (several suns, a window) is no sun: it stays in the SH.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..cache import array_digest
from ..raytrace.environment_light import environment_light, hammersley
from ..scene.environment import Environment
from ..scene.lights import DirectionalLight

SUN_SAMPLES = 16384  # stratified samples of the bright part (its integral to about 1e-4 on sky-checker's sun)
SUN_SPREAD = 10.0  # degrees: the largest angular radius (from the mean resultant length) of a sun


@dataclass(frozen=True)
class EnvironmentSun:
    """The environment's sun as a directional light (None: it has none) and the SH irradiance of the rest."""

    light: DirectionalLight | None
    rest_sh: np.ndarray  # (9, 3): Environment.irradiance_sh of the environment without the sun


def environment_sun(environment: Environment) -> EnvironmentSun:
    """The :class:`EnvironmentSun` of ``environment``, cached on it by the image's content."""
    key = array_digest(environment.image)
    cache = getattr(environment, "_sun_cache", None)
    if cache is None or cache[0] != key:
        cache = (key, _extract_sun(environment))
        environment._sun_cache = cache
    return cache[1]


def _extract_sun(environment: Environment) -> EnvironmentSun:
    split = environment_light(environment)
    if not split.has_bright:
        return EnvironmentSun(None, environment.irradiance_sh())
    direction, radiance, pdf = split.sample_bright(hammersley(SUN_SAMPLES))
    weighted = radiance / pdf[:, None]  # per sample: the bright part's integral, per channel
    irradiance = weighted.mean(axis=0)
    resultant = (direction * weighted.mean(axis=1, keepdims=True)).mean(axis=0)
    spread = np.linalg.norm(resultant) / max(float(irradiance.mean()), 1e-300)
    if spread < np.cos(np.radians(SUN_SPREAD)):
        return EnvironmentSun(None, environment.irradiance_sh())
    light = DirectionalLight(direction=-resultant / np.linalg.norm(resultant), intensity=irradiance)
    return EnvironmentSun(light, split.rest.irradiance_sh())


def ambient_sh(environment: Environment, samples) -> np.ndarray:
    """(9, 3) SH irradiance diffuse surfaces take as ambient: the environment's without its sun where the
    ``light_samples`` (passes/lights.py) hold the sun, else the whole environment's."""
    if any(getattr(s, "environment", False) for s in samples):
        return environment_sun(environment).rest_sh
    return environment.irradiance_sh()

