"""Photometric glTF light units to caustica's radiometric ones, at 683 lm/W (KHR_lights_punctual).

Point and spot lights: candela (lm/sr) / 683 = W/sr, caustica's radiant intensity. Directional lights:
lux (lm/m^2) / 683 = W/m^2, caustica's irradiance. glTF's ``color`` times ``intensity`` gives the RGB value.
"""
from __future__ import annotations

import numpy as np

LUMENS_PER_WATT = 683.0


def radiometric(color, intensity: float) -> np.ndarray:
    """RGB W/sr (or W/m^2) of a glTF light's linear ``color`` and photometric ``intensity``."""
    return np.asarray(color, dtype=np.float64) * float(intensity) / LUMENS_PER_WATT


def photometric(rgb) -> tuple[list[float], float]:
    """The inverse of :func:`radiometric`: (color with its largest channel 1, intensity in cd or lux)."""
    rgb = np.asarray(rgb, dtype=np.float64)
    peak = float(rgb.max())
    if peak <= 0.0:
        return [1.0, 1.0, 1.0], 0.0
    return [float(c) for c in rgb / peak], peak * LUMENS_PER_WATT
