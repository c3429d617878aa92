"""Materials: diffuse receivers, mirrors, and dielectrics (glass, water)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, short
from . import rules


@dataclass
class Diffuse:
    """Lambertian receiver with albedo ``color``, times ``texture`` where given.

    ``texture`` is an (H, W, 3) float32 linear-RGB image in [0, 1] (row 0 at the top), looked
    up at the mesh's ``uvs``; a mesh without uvs ignores it.
    """

    color: np.ndarray = field(default_factory=lambda: np.array([0.8, 0.8, 0.8]))
    texture: np.ndarray | None = field(default=None, repr=False)
    kind = "diffuse"

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.color = rules.rgb(self.color, "color", rules.MAX_COLOR)
        if self.texture is not None:  # read once per array, as meshes are (renders validate every frame)
            rules.once_per_arrays(self, ("texture",),
                                  lambda: setattr(self, "texture", rules.texture(self.texture, "texture")))


@dataclass
class Mirror:
    """Perfect specular reflector with reflectance ``color``."""

    color: np.ndarray = field(default_factory=lambda: np.array([0.95, 0.95, 0.95]))
    kind = "mirror"

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.color = rules.rgb(self.color, "color", rules.MAX_COLOR)


INVISIBLE_TOLERANCE = 1e-6  # an IOR and a transmittance this close to 1 count as air's (Glass.invisible)


@dataclass
class Glass:
    """Smooth dielectric in air.

    ``absorption_color`` is the transmittance after ``absorption_distance`` scene
    units inside (Beer-Lambert: T(d) = color ** (d / distance)); white means clear.
    ``abbe`` (optional) spreads ``ior`` into one IOR per RGB channel. ``thickness``
    (optional, scene units) is glTF's KHR_materials_volume thicknessFactor, kept for
    export; caustica traces the real geometry and does not read it.
    """

    ior: float = 1.5
    absorption_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    absorption_distance: float = 1.0
    abbe: float | None = None
    thickness: float | None = None
    kind = "glass"

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules): the IOR and,
        with ``abbe``, each channel's IOR in rules.IOR_RANGE."""
        self.ior = rules.ior(self.ior)
        self.absorption_color = rules.rgb(self.absorption_color, "absorption_color", 1.0)  # a transmittance
        self.absorption_distance = rules.number(self.absorption_distance, "absorption_distance", rules.MIN_LENGTH,
                                                1e12, hint=" scene units")
        if self.thickness is not None:
            self.thickness = rules.number(self.thickness, "thickness", 0.0, 1e12, hint=" scene units")
        if self.abbe is not None:
            self.abbe = rules.number(self.abbe, "abbe", 0.0, 1e6, open_low=True,
                                     hint=" (crown glass is about 60, dense flint 30)")
            with np.errstate(all="ignore"):
                channels = self.ior_rgb
            low, high = rules.IOR_RANGE
            if not np.all(np.isfinite(channels) & (channels >= low) & (channels <= high)):
                raise SceneError(f"abbe {self.abbe:g} spreads ior {self.ior:g} to per-channel IORs "
                                 f"{short(np.round(channels, 3))} outside [{low:g}, {high:g}]; use a larger abbe "
                                 "number (crown glass is about 60)")

    @property
    def invisible(self) -> bool:
        """IOR 1 in every channel and no absorption: the glass neither reflects (F = 0), bends nor tints light,
        so a path tracer renders it as the air around it (Hu and Qin fig. 18's refractors of index 1)."""
        return bool(np.all(np.abs(self.ior_rgb - 1.0) <= INVISIBLE_TOLERANCE)
                    and np.all(self.absorption_color >= 1.0 - INVISIBLE_TOLERANCE))

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
