"""Distant environment: an equirectangular radiance image.

Mapping (the same as Mitsuba 3, so scenes export unchanged):
u = atan2(d.x, -d.z) / 2pi mod 1, v = acos(d.y) / pi, row 0 at +Y.
Lookups follow Mitsuba's bilinear sampling exactly: texel column at
u * W - 0.5 (wrapping) and row at v * (H - 1) (clamped).

Rotation and strength (``[environment] rotation`` / ``strength``) are baked
into the image by :meth:`Environment.rotated` and :meth:`Environment.scaled`,
so every technique, the exact oracle, the SH irradiance and the Mitsuba export
see one image; docs/scenes.md gives the convention.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import EnvironmentImageError, closest_name, short
from . import rules

PROCEDURAL_ENVIRONMENTS = ("sky-checker", "black", "white")
ENVIRONMENT_FILTERS = ("footprint", "bilinear")  # Environment.filter
MAX_ROTATION = 1e6  # degrees either way: any angle a scene means, and no float that has lost its fraction


def direction_to_uv(d: np.ndarray) -> np.ndarray:
    """(..., 3) unit directions to (..., 2) equirectangular coordinates in [0,1)."""
    d = np.asarray(d, dtype=np.float64)
    u = np.mod(np.arctan2(d[..., 0], -d[..., 2]) / (2.0 * np.pi), 1.0)
    v = np.arccos(np.clip(d[..., 1], -1.0, 1.0)) / np.pi
    return np.stack([u, v], axis=-1)


def uv_to_direction(uv: np.ndarray) -> np.ndarray:
    """Inverse of :func:`direction_to_uv`."""
    uv = np.asarray(uv, dtype=np.float64)
    phi = uv[..., 0] * 2.0 * np.pi
    theta = uv[..., 1] * np.pi
    s = np.sin(theta)
    return np.stack([s * np.sin(phi), np.cos(theta), -s * np.cos(phi)], axis=-1)


@dataclass
class Environment:
    """Radiance image (H, W, 3) float32, linear RGB, and where it came from.

    ``rotation`` (degrees) and ``strength`` record what :meth:`rotated` and :meth:`scaled` baked
    into ``image`` since ``source`` was read; they are not constructor arguments. ``filter``: how the
    raster techniques look it up, ``footprint`` (the mean over each pixel's directions, as supersampling
    gives; docs/antialiasing.md) or ``bilinear`` (one bilinear sample in the pixel's direction, as
    Mitsuba and ``exact`` take per sample).
    """

    image: np.ndarray
    source: str = "procedural:sky-checker"
    filter: str = "footprint"
    rotation: float = field(default=0.0, init=False)
    strength: float = field(default=1.0, init=False)
    _sh: np.ndarray | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """Check the image (an assigned one too) and store it as float32: (H, W, 3), at least 2x2, every value
        finite, 0 or more and at most rules.MAX_INTENSITY (checked before the cast, which would overflow to inf)."""
        try:
            image = np.asarray(self.image)
        except (TypeError, ValueError):
            image = np.zeros(0)
        if not np.issubdtype(image.dtype, np.number) or np.issubdtype(image.dtype, np.complexfloating) \
                or image.ndim != 3 or image.shape[2] != 3 or min(image.shape[:2]) < 2:
            raise EnvironmentImageError(f"environment image {self.source} must be an RGB image of at least "
                                        f"2x2 pixels (got shape {short(getattr(image, 'shape', None))})")
        low, high = float(image.min()), float(image.max())  # NaN propagates: two passes, no temporary
        if not (np.isfinite(low) and np.isfinite(high)):
            raise EnvironmentImageError(f"environment image {self.source} holds NaN or infinite values; repair the file")
        if low < 0.0:
            negative = (image < 0).any(axis=2)
            row, column = np.argwhere(negative)[0]
            raise EnvironmentImageError(
                f"environment image {self.source} has negative radiance in {int(negative.sum())} pixels (the first "
                f"at row {row}, column {column}: {short(image[row, column])}); radiance cannot be negative: clamp "
                "the image at 0 (numpy.maximum(image, 0)) or re-export it")
        if max(-low, high) > rules.MAX_INTENSITY:
            raise EnvironmentImageError(f"environment image {self.source} holds values up to {max(-low, high):.3g}, "
                                        f"above {rules.MAX_INTENSITY:g}; rescale the image")
        self.image = np.ascontiguousarray(image, dtype=np.float32)
        if self.filter not in ENVIRONMENT_FILTERS:
            raise EnvironmentImageError(f"environment filter {short(self.filter)} is unknown; choose one of "
                                        f"{', '.join(ENVIRONMENT_FILTERS)}")

    def rotated(self, degrees: float) -> "Environment":
        """This environment turned by ``degrees`` about +Y, right-handed (counter-clockwise seen from above):
        the radiance arriving from d comes from R_y(degrees) d. A new image: columns shift cyclically,
        exactly for multiples of 360 / W degrees, else linearly interpolated along each row."""
        degrees = _angle(degrees)
        h, w = self.image.shape[:2]
        # The new radiance at u is the old at u + degrees / 360 (u grows clockwise seen from above).
        shift = (degrees % 360.0) / 360.0 * w
        whole = int(np.floor(shift))
        frac = shift - whole
        if frac > 1.0 - 1e-9:
            whole, frac = whole + 1, 0.0
        image = np.roll(self.image, -whole, axis=1)
        if frac > 1e-9:
            image = (image * (1.0 - frac) + np.roll(image, -1, axis=1) * frac).astype(np.float32)
        return self._derived(image, self.rotation + degrees, self.strength)

    def scaled(self, strength: float) -> "Environment":
        """This environment with its radiance times ``strength`` (>= 0)."""
        strength = rules.number(strength, "environment.strength", 0.0, rules.MAX_INTENSITY,
                                error=EnvironmentImageError, hint=" (a radiance multiplier; 1 keeps the image)")
        return self._derived(self.image * np.float32(strength), self.rotation, self.strength * strength)

    def _derived(self, image: np.ndarray, rotation: float, strength: float) -> "Environment":
        env = Environment(image, source=self.source, filter=self.filter)
        env.rotation, env.strength = float(rotation), float(strength)
        return env

    def describe(self) -> str:
        """One line: the source and what was baked into it."""
        parts = [self.source]
        if self.rotation:
            parts.append(f"rotated {self.rotation:g} degrees about +Y")
        if self.strength != 1.0:
            parts.append(f"strength {self.strength:g}")
        return ", ".join(parts)

    def texel_coordinates(self, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Continuous texel coordinates (x, y) Mitsuba samples for directions ``d``."""
        h, w = self.image.shape[:2]
        uv = direction_to_uv(d)
        return uv[..., 0] * w - 0.5, uv[..., 1] * (h - 1)

    def lookup(self, d: np.ndarray) -> np.ndarray:
        """Bilinear radiance for (..., 3) unit directions, as Mitsuba samples it."""
        h, w = self.image.shape[:2]
        x, y = self.texel_coordinates(d)
        x0 = np.floor(x)
        y0 = np.clip(np.floor(y), 0, h - 2)
        fx = (x - x0)[..., None]
        fy = np.clip(y - y0, 0.0, 1.0)[..., None]
        x0 = x0.astype(np.int64) % w
        x1 = (x0 + 1) % w
        y0 = y0.astype(np.int64)
        y1 = y0 + 1
        img = self.image
        top = img[y0, x0] * (1 - fx) + img[y0, x1] * fx
        bottom = img[y1, x0] * (1 - fx) + img[y1, x1] * fx
        return (top * (1 - fy) + bottom * fy).astype(np.float32)

    def irradiance_sh(self) -> np.ndarray:
        """(9, 3) coefficients of the cosine-convolved environment (Ramamoorthi-Hanrahan).

        Diffuse surfaces use it as unoccluded ambient light in the rasterized techniques (and in the
        exact oracle with ``environment_samples = 0``).
        """
        if self._sh is None:
            self._sh = irradiance_sh_of(self.image)
        return self._sh

    def irradiance(self, n: np.ndarray) -> np.ndarray:
        """Irradiance E(n) from the SH fit, (..., 3); diffuse radiance is albedo / pi * E."""
        return np.maximum(np.einsum("...k,kc->...c", sh9_basis(n), self.irradiance_sh()), 0.0)


_SH_GRID: dict = {}  # the last image shape's (basis, solid angle): a new image of that shape (a rotated
# environment in a batch) skips recomputing them, most of the projection's work


def irradiance_sh_of(image: np.ndarray) -> np.ndarray:
    """(9, 3) float32 SH coefficients of the cosine-convolved equirectangular ``image`` (Environment.irradiance_sh)."""
    basis, solid_angle = _sh_grid(*image.shape[:2])
    coeffs = np.einsum("hwk,hwc,hw->kc", basis, image.astype(np.float64), solid_angle)
    band = np.array([np.pi] + [2 * np.pi / 3] * 3 + [np.pi / 4] * 5)
    return (coeffs * band[:, None]).astype(np.float32)


@lru_cache(maxsize=4)
def texel_grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """(h, w, 3) unit directions of an (h, w) equirectangular image's texel centres and (h, w) their solid angles
    (read-only, kept for the next call: every light-map bake and light split of a batch asks again)."""
    v = (np.arange(h) + 0.5) / h
    u = (np.arange(w) + 0.5) / w
    uu, vv = np.meshgrid(u, v)
    directions = uv_to_direction(np.stack([uu, vv], axis=-1))
    solid_angle = (2 * np.pi / w) * (np.pi / h) * np.sin(vv * np.pi)
    directions.flags.writeable = solid_angle.flags.writeable = False
    return directions, solid_angle


def _sh_grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """The SH basis at each texel centre of an (h, w) equirectangular image, and each texel's solid angle."""
    if (h, w) not in _SH_GRID:
        d, solid_angle = texel_grid(h, w)
        _SH_GRID.clear()
        _SH_GRID[(h, w)] = (sh9_basis(d), solid_angle)
    return _SH_GRID[(h, w)]


def sh9_basis(d: np.ndarray) -> np.ndarray:
    """Real spherical harmonics up to band 2 for (..., 3) unit directions -> (..., 9)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack(
        [
            np.full_like(x, 0.282095),
            0.488603 * y,
            0.488603 * z,
            0.488603 * x,
            1.092548 * x * y,
            1.092548 * y * z,
            0.315392 * (3 * z * z - 1),
            1.092548 * x * z,
            0.546274 * (x * x - y * y),
        ],
        axis=-1,
    )


def sky_checker(width: int = 1024, height: int = 512, sun_direction=(0.4, 0.6, -0.7)) -> np.ndarray:
    """Procedural environment: blue sky gradient, checkered ground, a sun disk.

    The ground checker has 24 squares around and 6 down to the nadir so that
    refraction bends visible straight lines; the sun (radiance 40, 2.5 degrees
    radius, smooth rim) makes Fresnel highlights, and the raster techniques light
    diffuse surfaces with it as a directional light. ``sun_direction=None``: no sun.
    """
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    uu, vv = np.meshgrid(u, v)
    d = uv_to_direction(np.stack([uu, vv], axis=-1))
    elevation = d[..., 1]
    # Sky: pale at the horizon, deep blue at the zenith.
    t = np.clip(elevation, 0.0, 1.0)[..., None] ** 0.6
    horizon, zenith = np.array([0.85, 0.9, 1.0]), np.array([0.15, 0.35, 0.85])
    sky = horizon * (1 - t) + zenith * t
    # Ground: a checker in (u, v) between two greys with a warm tint.
    checks = (np.floor(uu * 24) + np.floor(vv * 12)) % 2
    ground = np.where(checks[..., None] > 0, np.array([0.7, 0.65, 0.55]), np.array([0.12, 0.12, 0.14]))
    # Blend over a thin band around the horizon so the image has no hard step there.
    blend = np.clip(elevation / 0.02 + 0.5, 0.0, 1.0)[..., None]
    img = sky * blend + ground * (1 - blend)
    if sun_direction is None:
        return img.astype(np.float32)
    # Sun: a bright disk.
    sun = np.asarray(sun_direction, dtype=np.float64)
    sun /= np.linalg.norm(sun)
    angle = np.degrees(np.arccos(np.clip(d @ sun, -1, 1)))
    disk = np.clip((2.5 - angle) / 0.5 + 0.5, 0.0, 1.0)[..., None]
    img = img * (1 - disk) + 40.0 * disk
    return img.astype(np.float32)


def _angle(degrees) -> float:
    return rules.number(degrees, "environment.rotation", -MAX_ROTATION, MAX_ROTATION, error=EnvironmentImageError,
                        hint=" degrees about +Y")


def procedural_environment(name: str) -> Environment:
    """A built-in environment by name: 'sky-checker', 'black' or 'white' (PROCEDURAL_ENVIRONMENTS)."""
    if name == "sky-checker":
        return Environment(sky_checker(), source="procedural:sky-checker")
    if name == "black":
        return Environment(np.zeros((16, 32, 3), np.float32), source="procedural:black")
    if name == "white":
        return Environment(np.ones((16, 32, 3), np.float32), source="procedural:white")
    raise EnvironmentImageError(
        f"unknown procedural environment '{name}'{closest_name(name, PROCEDURAL_ENVIRONMENTS)}; "
        f"choose one of {', '.join(PROCEDURAL_ENVIRONMENTS)}"
    )


def load_environment(path: str | Path) -> Environment:
    """Read an equirectangular .exr or .hdr (or an 8-bit PNG/JPEG, decoded from sRGB)."""
    from ..images import read_image

    return Environment(read_image(path, error=EnvironmentImageError), source=str(path))


def environment_option(spec: str, relative_to: str = "the current directory") -> Environment:
    """The environment a command line names: a procedural name or an image file (``--environment``);
    ``relative_to`` says, in the error for a missing file, what a relative path was resolved against."""
    if spec in PROCEDURAL_ENVIRONMENTS:
        return procedural_environment(spec)
    from ..images import READ_SUFFIXES

    path = Path(spec)
    if not path.exists() and not path.suffix and len(path.parts) == 1:
        raise EnvironmentImageError(
            f"environment {short(spec)} is neither a procedural name nor a file{closest_name(spec, PROCEDURAL_ENVIRONMENTS)}; "
            f"give one of {', '.join(PROCEDURAL_ENVIRONMENTS)} or an image file ({', '.join(READ_SUFFIXES)})")
    if not path.exists():  # a directory, a FIFO or a device: load_environment says which
        raise EnvironmentImageError(f"environment file not found: {short(spec)}; check the path (relative to "
                                    f"{relative_to}) or give one of {', '.join(PROCEDURAL_ENVIRONMENTS)}")
    return load_environment(path)
