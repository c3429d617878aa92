"""Materials: glTF 2.0's metallic-roughness model (:class:`Principled`) and its special cases, the papers'
diffuse receivers, perfect mirrors and smooth dielectrics (glass, water)."""
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

    def as_principled(self) -> "Principled":
        """The same surface in the metallic-roughness model: a dielectric base with no specular layer."""
        return Principled(base_color=self.color, base_color_texture=self.texture, metallic=0.0, roughness=1.0,
                          specular=0.0)


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

    def as_principled(self) -> "Principled":
        """The same surface in the metallic-roughness model: a smooth metal whose F0 is ``color``."""
        return Principled(base_color=self.color, metallic=1.0, roughness=0.0)


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

    def as_principled(self) -> "Principled":
        """The same surface in the metallic-roughness model (KHR_materials_transmission, _ior, _volume and
        _dispersion, whose dispersion is 20 / abbe)."""
        clear = bool(np.all(self.absorption_color >= 1.0))
        return Principled(base_color=np.ones(3), metallic=0.0, roughness=0.0, transmission=1.0, ior=self.ior,
                          attenuation_color=self.absorption_color,
                          attenuation_distance=None if clear else self.absorption_distance,
                          dispersion=20.0 / self.abbe if self.abbe else 0.0, thickness=self.thickness)


TRANSMISSION_GLASS = 0.5  # a Principled transmission from which the surface is drawn as glass
MIRROR_METALLIC, MIRROR_ROUGHNESS = 0.9, 0.05  # a Principled metal this smooth is drawn as a perfect mirror
DIELECTRIC_F0 = 0.04  # glTF's normal-incidence reflectance of a dielectric base (IOR 1.5), before specular


@dataclass
class Principled:
    """glTF 2.0's metallic-roughness material with the extensions caustica draws (docs/materials.md).

    ``base_color`` (linear RGB) times ``base_color_texture``; ``metallic`` and ``roughness`` (perceptual,
    GGX alpha = roughness^2) times ``metallic_roughness_texture``'s blue and green channels;
    ``normal_texture`` (tangent space, scaled by ``normal_scale``); ``occlusion_texture``'s red channel
    (by ``occlusion_strength``); ``emission`` (W/sr/m^2 per unit, times ``emission_texture``);
    KHR_materials_specular's ``specular`` and ``specular_color`` (the dielectric F0 = 0.04 scaled);
    KHR_materials_transmission's ``transmission`` with KHR_materials_ior's ``ior``, _volume's
    ``attenuation_color``/``attenuation_distance``/``thickness`` and _dispersion's ``dispersion``.
    Textures are (H, W, 3) linear images in [0, 1] (row 0 at the top) looked up at the mesh's uvs.

    ``kind`` is how the surface is drawn: ``"glass"`` from ``transmission`` >= 0.5, ``"mirror"`` for a
    metal this smooth (metallic >= 0.9, roughness <= 0.05), else ``"diffuse"``: an opaque receiver, which
    takes caustics, shadows and the environment bake on its diffuse part and shades its specular lobe with
    GGX. :meth:`shorthand` gives the Diffuse, Mirror or Glass a surface is exactly, when it is one.
    """

    base_color: np.ndarray = field(default_factory=lambda: np.array([0.8, 0.8, 0.8]))
    base_color_texture: np.ndarray | None = field(default=None, repr=False)
    metallic: float = 0.0
    roughness: float = 0.5
    metallic_roughness_texture: np.ndarray | None = field(default=None, repr=False)
    normal_texture: np.ndarray | None = field(default=None, repr=False)
    normal_scale: float = 1.0
    occlusion_texture: np.ndarray | None = field(default=None, repr=False)
    occlusion_strength: float = 1.0
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))
    emission_texture: np.ndarray | None = field(default=None, repr=False)
    specular: float = 1.0
    specular_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    transmission: float = 0.0
    ior: float = 1.5
    attenuation_color: np.ndarray = field(default_factory=lambda: np.ones(3))
    attenuation_distance: float | None = None
    thickness: float | None = None
    dispersion: float = 0.0

    TEXTURES = ("base_color_texture", "metallic_roughness_texture", "normal_texture", "occlusion_texture",
                "emission_texture")

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check and normalize the fields (the loader and Scene.validate share these rules)."""
        self.base_color = rules.rgb(self.base_color, "base_color", 1.0)
        self.metallic = rules.number(self.metallic, "metallic", 0.0, 1.0)
        self.roughness = rules.number(self.roughness, "roughness", 0.0, 1.0)
        self.normal_scale = rules.number(self.normal_scale, "normal_scale", -1e3, 1e3)
        self.occlusion_strength = rules.number(self.occlusion_strength, "occlusion_strength", 0.0, 1.0)
        self.emission = rules.rgb(self.emission, "emission", rules.MAX_INTENSITY)
        self.specular = rules.number(self.specular, "specular", 0.0, 1.0)
        self.specular_color = rules.rgb(self.specular_color, "specular_color", rules.MAX_COLOR)
        self.transmission = rules.number(self.transmission, "transmission", 0.0, 1.0)
        self.ior = rules.ior(self.ior)
        self.attenuation_color = rules.rgb(self.attenuation_color, "attenuation_color", 1.0)
        if self.attenuation_distance is not None:
            self.attenuation_distance = rules.number(self.attenuation_distance, "attenuation_distance",
                                                     rules.MIN_LENGTH, 1e12, hint=" scene units")
        if self.thickness is not None:
            self.thickness = rules.number(self.thickness, "thickness", 0.0, 1e12, hint=" scene units")
        self.dispersion = rules.number(self.dispersion, "dispersion", 0.0, 1e6)
        present = tuple(name for name in self.TEXTURES if getattr(self, name) is not None)
        if present:  # read once per array, as meshes are (renders validate every frame)
            rules.once_per_arrays(self, present, lambda: self._check_textures(present))

    def _check_textures(self, names: tuple[str, ...]) -> None:
        for name in names:
            setattr(self, name, rules.texture(getattr(self, name), name))

    @property
    def kind(self) -> str:
        if self.transmission >= TRANSMISSION_GLASS:
            return "glass"
        smooth = self.roughness <= MIRROR_ROUGHNESS and self.metallic_roughness_texture is None
        if self.metallic >= MIRROR_METALLIC and smooth:
            return "mirror"
        return "diffuse"

    @property
    def textured(self) -> bool:
        return any(getattr(self, name) is not None for name in self.TEXTURES)

    @property
    def glossy(self) -> bool:
        """Whether the surface has a specular lobe to shade (a Diffuse shorthand has none)."""
        return self.metallic > 0.0 or self.specular > 0.0 or self.metallic_roughness_texture is not None

    @property
    def dielectric_f0(self) -> np.ndarray:
        """The dielectric share's normal-incidence reflectance: 0.04 x specular_color (capped at 1) x specular."""
        return np.minimum(DIELECTRIC_F0 * self.specular_color, 1.0) * self.specular

    @property
    def f0(self) -> np.ndarray:
        """Normal-incidence reflectance of the untextured surface: glTF's mix of the dielectric's
        (dielectric_f0) and the metal's base colour."""
        return (1.0 - self.metallic) * self.dielectric_f0 + self.metallic * self.base_color

    @property
    def diffuse_color(self) -> np.ndarray:
        """The Lambertian albedo of the untextured base: the base colour of the dielectric share."""
        return (1.0 - self.metallic) * self.base_color

    # What the drawing roles read (Diffuse's, Mirror's and Glass's fields) ----------------

    @property
    def color(self) -> np.ndarray:
        return self.base_color

    @property
    def texture(self) -> np.ndarray | None:
        return self.base_color_texture

    @property
    def absorption_color(self) -> np.ndarray:
        return self.as_glass().absorption_color

    @property
    def absorption_distance(self) -> float:
        return self.as_glass().absorption_distance

    @property
    def abbe(self) -> float | None:
        return self.as_glass().abbe

    @property
    def absorption_coefficient(self) -> np.ndarray:
        return self.as_glass().absorption_coefficient

    @property
    def ior_rgb(self) -> np.ndarray:
        return self.as_glass().ior_rgb

    @property
    def invisible(self) -> bool:
        return self.as_glass().invisible

    def as_glass(self) -> Glass:
        """The smooth dielectric a ``"glass"`` surface is drawn as (roughness and base colour aside)."""
        clear = self.attenuation_distance is None or bool(np.all(self.attenuation_color >= 1.0))
        return Glass(ior=self.ior, absorption_color=np.ones(3) if clear else self.attenuation_color,
                     absorption_distance=1.0 if clear else self.attenuation_distance,
                     abbe=20.0 / self.dispersion if self.dispersion > 0 else None, thickness=self.thickness)

    def shorthand(self) -> Diffuse | Mirror | Glass | None:
        """The Diffuse, Mirror or Glass this surface is exactly, or None."""
        untextured = all(getattr(self, name) is None for name in self.TEXTURES if name != "base_color_texture")
        no_emission = not np.any(self.emission > 0)
        if not (untextured and no_emission):
            return None
        if self.transmission == 1.0 and self.roughness == 0.0 and np.all(self.base_color >= 1.0) \
                and self.base_color_texture is None:
            return self.as_glass()
        if self.transmission > 0.0:
            return None
        if self.metallic == 1.0 and self.roughness == 0.0 and self.base_color_texture is None:
            return Mirror(color=self.base_color)
        if self.metallic == 0.0 and self.specular == 0.0:
            return Diffuse(color=self.base_color, texture=self.base_color_texture)
        return None


def water(**kwargs) -> Glass:
    """Water: glass with IOR 1.33."""
    kwargs.setdefault("ior", 1.33)
    return Glass(**kwargs)


Material = Diffuse | Mirror | Glass | Principled
