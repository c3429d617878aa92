"""The environment as a light for the ``exact`` oracle: a bright part sampled like area lights, and the rest.

:class:`EnvironmentLight` splits the radiance of an :class:`~caustica.scene.environment.Environment` into
two images whose bilinear lookups add up to the original exactly: the *bright* part (the texels above
``bright`` times the mean radiance over the sphere: a sun) and the *rest*. The bright part is sampled by
its power over parts of the cells of the bilinear grid (shadow rays and photons); the rest is gathered by
cosine-weighted rays. Splitting this way keeps a small, very bright sun out of the cosine rays (no
fireflies) and gives it a sharp shadow.

Grid (the lookup's, as Mitsuba samples it): texel coordinates x = u W - 0.5 (wrapping) and
y = v (H - 1); cell (j, i) spans [i, i + 1] x [j, j + 1] and is bilinear between its four texels, so a
direction in it has solid-angle density sin(theta) (pi / (H - 1)) (2 pi / W) per unit of x and y.

Sample patterns are deterministic: a Hammersley set of the asked count, rotated per shading point
(Cranley-Patterson) by a hash of the point's coordinates, so an image does not depend on how its rays
are batched.
"""
from __future__ import annotations

import numpy as np

from ..cache import array_digest, kept_on
from ..scene.environment import Environment, uv_to_direction

BRIGHT_RATIO = 10.0  # default threshold of the bright part, in multiples of the mean radiance
SUBCELLS = 4  # each bright cell is sampled as SUBCELLS^2 parts by their radiance (its bilinear varies 0 to peak)


def hammersley(count: int) -> np.ndarray:
    """(count, 2) points of the Hammersley set in [0, 1)^2 ((i + 1/2) / count, base-2 radical inverse of i)."""
    i = np.arange(count, dtype=np.uint64)
    bits = np.zeros(count, np.float64)
    scale, rest = 0.5, i.copy()
    while rest.any():
        bits += (rest & np.uint64(1)).astype(np.float64) * scale
        rest >>= np.uint64(1)
        scale /= 2.0
    return np.stack([(np.arange(count) + 0.5) / count, bits], axis=1)


def point_offsets(position: np.ndarray, salt: int) -> np.ndarray:
    """(N, 2) numbers in [0, 1) hashed from the bits of each position (N, 3) and ``salt`` (splitmix64)."""
    bits = np.ascontiguousarray(position, dtype=np.float64).view(np.uint64).reshape(-1, 3)
    with np.errstate(over="ignore"):
        h = np.full(len(bits), np.uint64(salt) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(1))
        for column in range(3):
            h = _mix(h ^ bits[:, column])
        out = []
        for _ in range(2):
            h = _mix(h + np.uint64(0x9E3779B97F4A7C15))
            out.append((h >> np.uint64(11)).astype(np.float64) * 2.0**-53)
    return np.stack(out, axis=1)


def _mix(h: np.ndarray) -> np.ndarray:
    """The splitmix64 finaliser."""
    h = (h ^ (h >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    h = (h ^ (h >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return h ^ (h >> np.uint64(31))


def rotated_pattern(position: np.ndarray, count: int, salt: int) -> np.ndarray:
    """(N, count, 2) Hammersley points shifted modulo 1 by each position's hash."""
    return np.mod(hammersley(count)[None, :, :] + point_offsets(position, salt)[:, None, :], 1.0)


def tangent_frame(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors (N, 3) completing unit normals (N, 3) to orthonormal frames (Duff et al. 2017)."""
    sign = np.where(n[:, 2] >= 0, 1.0, -1.0)
    a = -1.0 / (sign + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + sign * n[:, 0] ** 2 * a, sign * b, -sign * n[:, 0]], axis=1)
    s = np.stack([b, sign + n[:, 1] ** 2 * a, -n[:, 1]], axis=1)
    return t, s


def cosine_directions(position: np.ndarray, normal: np.ndarray, count: int) -> np.ndarray:
    """(N, count, 3) cosine-weighted unit directions about each normal, stratified (pdf cos / pi)."""
    u = rotated_pattern(position, count, salt=1)
    r, phi = np.sqrt(u[..., 0]), 2.0 * np.pi * u[..., 1]
    z = np.sqrt(np.maximum(0.0, 1.0 - u[..., 0]))
    t, s = tangent_frame(normal)
    return ((r * np.cos(phi))[..., None] * t[:, None] + (r * np.sin(phi))[..., None] * s[:, None]
            + z[..., None] * normal[:, None])


class EnvironmentLight:
    """An environment split into a bright part (sampled by power) and the rest (see the module docstring).

    ``bright``: the threshold in multiples of the mean radiance (luminance as the mean of the channels,
    weighted by solid angle); 0 or inf keeps every texel in the rest."""

    def __init__(self, environment: Environment, bright: float = BRIGHT_RATIO):
        self.bright = float(bright)
        image = environment.image.astype(np.float64)
        h, w = image.shape[:2]
        self.shape = (h, w)
        luminance = image.mean(axis=2)
        theta = np.pi * np.arange(h) / (h - 1)  # row y sits at v = y / (H - 1)
        weight = np.maximum(np.sin(theta), 0.0)[:, None] * np.ones((1, w))
        mean = float((luminance * weight).sum() / max(weight.sum(), 1e-300))
        mask = (luminance > bright * mean) if 0 < bright < np.inf and mean > 0 else np.zeros((h, w), bool)
        self.bright_image = np.where(mask[..., None], image, 0.0).astype(np.float32)
        self.rest = Environment(np.where(mask[..., None], 0.0, image).astype(np.float32), source=environment.source)
        # Cells of the bilinear grid that touch a bright texel, cut into SUBCELLS x SUBCELLS parts weighted by
        # the bilinear radiance (mean of the channels) and sin(theta) at their centres.
        j = i = np.zeros(0, np.int64)
        if mask.any():
            corners = self._corner_values(np.arange(h - 1)[:, None], np.arange(w)[None, :])
            j, i = np.nonzero(corners.max(axis=(2, 3, 4)) > 0)
        part = (np.arange(SUBCELLS) + 0.5) / SUBCELLS
        fy, fx = (g.reshape(-1) for g in np.meshgrid(part, part, indexing="ij"))
        j, i = np.repeat(j, len(fx)), np.repeat(i, len(fx))
        fx, fy = np.tile(fx, len(j) // len(fx) if len(fx) else 0), np.tile(fy, len(j) // len(fy) if len(fy) else 0)
        value = self._bilinear(self._corner_values(j, i), fx, fy).mean(axis=-1)
        power = value * self._texel_solid_angle(j + fy) / SUBCELLS**2
        keep = power > 0
        self.parts = (j[keep], i[keep], fx[keep] - 0.5 / SUBCELLS, fy[keep] - 0.5 / SUBCELLS)  # lower corners
        self.part_power = power[keep]
        total = float(self.part_power.sum())
        self.part_cdf = np.cumsum(self.part_power) / total if total > 0 else np.zeros(0)

    def _texel_solid_angle(self, y: np.ndarray) -> np.ndarray:
        """Solid angle per unit of texel coordinates x and y at rows ``y``."""
        h, w = self.shape
        return np.maximum(np.sin(np.pi * y / (h - 1)), 1e-12) * (np.pi / (h - 1)) * (2.0 * np.pi / w)

    @staticmethod
    def _bilinear(corner: np.ndarray, fx: np.ndarray, fy: np.ndarray) -> np.ndarray:
        """(..., 3) bilinear interpolation of (..., 2, 2, 3) corner values at (fx, fy) in the cell."""
        fx, fy = fx[..., None], fy[..., None]
        return ((corner[..., 0, 0, :] * (1 - fx) + corner[..., 0, 1, :] * fx) * (1 - fy)
                + (corner[..., 1, 0, :] * (1 - fx) + corner[..., 1, 1, :] * fx) * fy)

    @property
    def has_bright(self) -> bool:
        return len(self.part_power) > 0

    def _corner_values(self, j, i) -> np.ndarray:
        """(..., 2, 2, 3) bright radiance at the corners of cells (j, i): [row j / j + 1][column i / i + 1]."""
        h, w = self.shape
        b = self.bright_image.astype(np.float64)
        i0, i1 = i % w, (i + 1) % w
        top = np.stack([b[j, i0], b[j, i1]], axis=-2)
        bottom = np.stack([b[j + 1, i0], b[j + 1, i1]], axis=-2)
        return np.stack([top, bottom], axis=-3)

    def sample_bright(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions towards the bright part for numbers ``u`` (..., 2) in [0, 1): (unit direction (..., 3),
        bright radiance (..., 3), solid-angle pdf (...)). The first number picks a subcell by its power and
        places the point along x within it (the remainder of the subcell's share); the second along y."""
        h, w = self.shape
        cdf = self.part_cdf
        k = np.minimum(np.searchsorted(cdf, u[..., 0], side="right"), len(cdf) - 1)
        low = np.where(k > 0, cdf[np.maximum(k - 1, 0)], 0.0)
        share = cdf[k] - low
        across = np.clip((u[..., 0] - low) / np.maximum(share, 1e-300), 0.0, 1.0 - 1e-12)
        j, i, x0, y0 = (a[k] for a in self.parts)
        fx, fy = x0 + across / SUBCELLS, y0 + u[..., 1] / SUBCELLS
        x, y = i + fx, j + fy
        direction = uv_to_direction(np.stack([np.mod((x + 0.5) / w, 1.0), y / (h - 1)], axis=-1))
        radiance = self._bilinear(self._corner_values(j, i), fx, fy)
        pdf = share * SUBCELLS**2 / self._texel_solid_angle(y)
        return direction, radiance, pdf

    def bright_power(self) -> float:
        """Integral of the bright part's radiance (mean over channels) over the sphere, in W/m^2 per
        unit area facing each direction (the irradiance its cells add up to, cosines left out)."""
        return float(self.part_power.sum())


def environment_light(environment: Environment, bright: float = BRIGHT_RATIO) -> EnvironmentLight:
    """The :class:`EnvironmentLight` of ``environment``, kept on it for the next call with ``bright``."""
    key = (bright, array_digest(environment.image))
    return kept_on(environment, "_light_cache", key, lambda: EnvironmentLight(environment, bright))

