"""Materials: diffuse receivers, mirrors, and dielectrics (glass, water)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


def _rgb(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.size == 1:
        arr = np.repeat(arr, 3)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be three non-negative numbers [r, g, b]")
    return arr


@dataclass
class Diffuse:
    """Lambertian receiver with albedo ``color``."""

    color: np.ndarray = field(default_factory=lambda: np.array([0.8, 0.8, 0.8]))
    kind = "diffuse"

    def __post_init__(self):
        self.color = _rgb(self.color, "diffuse color")


@dataclass
class Mirror:
    """Perfect specular reflector with reflectance ``color``."""

    color: np.ndarray = field(default_factory=lambda: np.array([0.95, 0.95, 0.95]))
    kind = "mirror"

    def __post_init__(self):
        self.color = _rgb(self.color, "mirror color")


@dataclass
class Glass:
    """Smooth dielectric in air.

    ``absorption_color`` is the transmittance after ``absorption_distance`` scene
    units inside (Beer-Lambert: T(d) = color ** (d / distance)); white means clear.
    ``abbe`` (optional) spreads ``ior`` into one IOR per RGB channel.
    """

    ior: float = 1.5
    absorption_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    absorption_distance: float = 1.0
    abbe: float | None = None
    kind = "glass"

    def __post_init__(self):
        self.ior = float(self.ior)
        if not np.isfinite(self.ior) or self.ior <= 0:
            raise ValueError(f"ior {self.ior} must be positive (glass is about 1.5, water 1.33)")
        self.absorption_color = _rgb(self.absorption_color, "absorption color")
        if np.any(self.absorption_color > 1):
            raise ValueError("absorption color is a transmittance and must lie in [0, 1]")
        self.absorption_distance = float(self.absorption_distance)
        if not self.absorption_distance > 0:
            raise ValueError("absorption distance must be positive")
        if self.abbe is not None:
            self.abbe = float(self.abbe)
            if not self.abbe > 0:
                raise ValueError("abbe number must be positive (crown glass is about 60)")

    @property
    def absorption_coefficient(self) -> np.ndarray:
        """sigma_a per channel, so that T(d) = exp(-sigma_a d)."""
        return -np.log(np.clip(self.absorption_color, 1e-6, 1.0)) / self.absorption_distance

    @property
    def ior_rgb(self) -> np.ndarray:
        """One IOR per channel from the Abbe number (Cauchy fit through the F, d, C lines)."""
        if self.abbe is None:
            return np.full(3, self.ior)
        # n(lambda) = A + B / lambda^2, with n_d at 587.6 nm and V = (n_d - 1) / (n_F - n_C).
        lam_f, lam_d, lam_c = 0.4861, 0.5876, 0.6563
        b = (self.ior - 1.0) / self.abbe / (1.0 / lam_f**2 - 1.0 / lam_c**2)
        a = self.ior - b / lam_d**2
        lam_rgb = np.array([0.6100, 0.5500, 0.4650])
        return a + b / lam_rgb**2


def water(**kwargs) -> Glass:
    """Water: glass with IOR 1.33."""
    kwargs.setdefault("ior", 1.33)
    return Glass(**kwargs)


Material = Diffuse | Mirror | Glass
