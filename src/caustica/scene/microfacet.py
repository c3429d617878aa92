"""GGX microfacet reflection of the material model (materials.Principled) on the CPU: the distribution, Smith
masking, Schlick's Fresnel, visible-normal sampling and the split-sum table (docs/materials.md).

The surfaces of :class:`~caustica.scene.materials.Principled` follow glTF 2.0's BRDF (Appendix B of the
specification): ``alpha = roughness ** 2``, the Trowbridge-Reitz (GGX) distribution, height-correlated
Smith masking-shadowing and Schlick's Fresnel. The ray tracer samples it with Heitz's visible normals (JCGT
2018); the real-time shaders use the split-sum table (Karis, SIGGRAPH 2013 course) with Fdez-Aguera's
multiple-scattering compensation (JCGT 2019). Pure numpy, in a frame whose normal is +z unless a function
says otherwise; cosines are clamped to [0, 1].
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

MIN_ALPHA = 1e-4  # GGX alpha floor: a roughness of 0 would make D a delta (a mirror draws that case)
BRDF_TABLE_SIZE = 32  # the split-sum table's cos(theta_v) x roughness resolution
BRDF_TABLE_SAMPLES = 1024  # visible normals per table texel (a fixed Hammersley set: the table is deterministic)


def alpha_of(roughness) -> np.ndarray:
    """GGX alpha of glTF's perceptual roughness (squared), floored at MIN_ALPHA."""
    return np.maximum(np.asarray(roughness, np.float64) ** 2, MIN_ALPHA)


def distribution(n_dot_h, alpha) -> np.ndarray:
    """GGX's D(h): the density of microfacet normals per projected area, normalised so that
    the integral of D(h) cos(theta_h) over the hemisphere is 1."""
    cos2 = np.clip(n_dot_h, 0.0, 1.0) ** 2
    a2 = np.asarray(alpha, np.float64) ** 2
    return a2 / (np.pi * (cos2 * (a2 - 1.0) + 1.0) ** 2)


def _lambda(n_dot_x, alpha) -> np.ndarray:
    cos2 = np.maximum(np.clip(n_dot_x, 0.0, 1.0) ** 2, 1e-12)
    tan2 = (1.0 - cos2) / cos2
    return 0.5 * (np.sqrt(1.0 + np.asarray(alpha, np.float64) ** 2 * tan2) - 1.0)


def masking(n_dot_v, alpha) -> np.ndarray:
    """Smith's G1: the share of microfacets facing v that v sees."""
    return 1.0 / (1.0 + _lambda(n_dot_v, alpha))


def masking_shadowing(n_dot_l, n_dot_v, alpha) -> np.ndarray:
    """Smith's height-correlated G2 of light and view directions (glTF's choice)."""
    return 1.0 / (1.0 + _lambda(n_dot_l, alpha) + _lambda(n_dot_v, alpha))


def schlick(f0, cos_theta) -> np.ndarray:
    """Schlick's Fresnel: F0 + (1 - F0)(1 - cos)^5, with F0 per channel (broadcast)."""
    c = np.clip(np.asarray(cos_theta, np.float64), 0.0, 1.0)
    f0 = np.asarray(f0, np.float64)
    return f0 + (1.0 - f0) * (1.0 - c) ** 5


def specular_brdf(n_dot_l, n_dot_v, n_dot_h, v_dot_h, alpha, f0) -> np.ndarray:
    """GGX's specular BRDF f = F D G2 / (4 cos_l cos_v), per channel of ``f0`` (trailing axis)."""
    n_dot_l, n_dot_v = np.clip(n_dot_l, 0.0, 1.0), np.clip(n_dot_v, 0.0, 1.0)
    scalar = distribution(n_dot_h, alpha) * masking_shadowing(n_dot_l, n_dot_v, alpha)
    scalar = scalar / np.maximum(4.0 * n_dot_l * n_dot_v, 1e-12)
    return schlick(f0, np.asarray(v_dot_h, np.float64)[..., None]) * scalar[..., None]


def sample_visible_normal(view, alpha, u1, u2) -> np.ndarray:
    """Heitz's visible-normal sampling: microfacet normals (N, 3) distributed as G1(v) max(0, v.h) D(h) / cos_v,
    for views ``view`` (N, 3) with view.z > 0 and uniform numbers ``u1``, ``u2`` in [0, 1)."""
    view = np.asarray(view, np.float64)
    alpha = np.broadcast_to(np.asarray(alpha, np.float64), u1.shape)
    stretched = np.stack([alpha * view[:, 0], alpha * view[:, 1], view[:, 2]], axis=1)
    stretched /= np.linalg.norm(stretched, axis=1, keepdims=True)
    length2 = stretched[:, 0] ** 2 + stretched[:, 1] ** 2
    with np.errstate(invalid="ignore", divide="ignore"):
        t1 = np.where(length2[:, None] > 0, np.stack([-stretched[:, 1], stretched[:, 0], np.zeros_like(u1)], 1)
                      / np.sqrt(length2)[:, None], np.array([1.0, 0.0, 0.0]))
    t2 = np.cross(stretched, t1)
    r, phi = np.sqrt(u1), 2.0 * np.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + stretched[:, 2])
    p2 = (1.0 - s) * np.sqrt(np.maximum(1.0 - p1 ** 2, 0.0)) + s * p2
    p3 = np.sqrt(np.maximum(1.0 - p1 ** 2 - p2 ** 2, 0.0))
    normal = p1[:, None] * t1 + p2[:, None] * t2 + p3[:, None] * stretched
    normal = np.stack([alpha * normal[:, 0], alpha * normal[:, 1], np.maximum(normal[:, 2], 1e-9)], axis=1)
    return normal / np.linalg.norm(normal, axis=1, keepdims=True)


def reflect(view, normal) -> np.ndarray:
    """The direction mirrored about ``normal`` of ``view`` (both pointing away from the surface)."""
    return 2.0 * np.sum(view * normal, axis=-1, keepdims=True) * normal - view


def _hammersley(count: int) -> tuple[np.ndarray, np.ndarray]:
    i = np.arange(count, dtype=np.uint32)
    bits = i.copy()
    bits = ((bits << 16) | (bits >> 16)) & 0xFFFFFFFF
    bits = ((bits & 0x55555555) << 1) | ((bits & 0xAAAAAAAA) >> 1)
    bits = ((bits & 0x33333333) << 2) | ((bits & 0xCCCCCCCC) >> 2)
    bits = ((bits & 0x0F0F0F0F) << 4) | ((bits & 0xF0F0F0F0) >> 4)
    bits = ((bits & 0x00FF00FF) << 8) | ((bits & 0xFF00FF00) >> 8)
    return (i + 0.5) / count, bits.astype(np.float64) / 2.0**32


@lru_cache(maxsize=4)
def brdf_table(size: int = BRDF_TABLE_SIZE, samples: int = BRDF_TABLE_SAMPLES) -> np.ndarray:
    """The split-sum table (size, size, 2) float32: texel [j, i] at cos_v = i / (size - 1) (the first at a
    quarter texel, since a view along the surface sees nothing) and roughness j / (size - 1), edges included,
    holds (A, B) with  integral of f_spec cos_l dl = F0 A + B  for Schlick's F (so A + B is the
    single-scattering albedo E(cos_v) of a white metal)."""
    u1, u2 = _hammersley(samples)
    cos_v = np.maximum(np.arange(size) / (size - 1), 0.25 / (size - 1))
    table = np.zeros((size, size, 2), np.float32)
    for j, roughness in enumerate(np.arange(size) / (size - 1)):
        alpha = float(alpha_of(roughness))
        for i, c in enumerate(cos_v):
            view = np.broadcast_to([np.sqrt(1.0 - c * c), 0.0, c], (samples, 3))
            h = sample_visible_normal(view, alpha, u1, u2)
            light = reflect(view, h)
            n_dot_l = np.clip(light[:, 2], 0.0, 1.0)
            v_dot_h = np.clip(np.sum(view * h, axis=1), 0.0, 1.0)
            # With visible normals the estimator of f cos_l / pdf is G2 / G1(v) (times F).
            weight = np.where(n_dot_l > 0, masking_shadowing(n_dot_l, c, alpha) / masking(c, alpha), 0.0)
            fc = (1.0 - v_dot_h) ** 5
            table[j, i] = (np.mean(weight * (1.0 - fc)), np.mean(weight * fc))
    return table


def energy_compensation(f0, albedo) -> np.ndarray:
    """Fdez-Aguera's factor 1 + F0 (1 / E - 1) that scales single-scattering GGX (white-metal albedo ``albedo``
    = A + B) so a rough white metal keeps all the energy it receives."""
    return 1.0 + np.asarray(f0, np.float64) * (1.0 / np.maximum(np.asarray(albedo, np.float64), 1e-6) - 1.0)


def split_sum(cos_v, roughness) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of :func:`brdf_table` at ``cos_v`` and ``roughness`` (arrays of one shape), bilinear between
    its texels, as the shaders' linear lookup reads the table (common/microfacet.glsl's split_sum)."""
    table = brdf_table().astype(np.float64)
    size = table.shape[0]
    x = np.clip(np.asarray(cos_v, np.float64), 0.0, 1.0) * (size - 1)
    y = np.clip(np.asarray(roughness, np.float64), 0.0, 1.0) * (size - 1)
    x0, y0 = np.minimum(np.floor(x).astype(np.int64), size - 2), np.minimum(np.floor(y).astype(np.int64), size - 2)
    fx, fy = (x - x0)[..., None], (y - y0)[..., None]
    value = ((1 - fy) * ((1 - fx) * table[y0, x0] + fx * table[y0, x0 + 1])
             + fy * ((1 - fx) * table[y0 + 1, x0] + fx * table[y0 + 1, x0 + 1]))
    return value[..., 0], value[..., 1]


def layer_weights(f0, f0_dielectric, cos_v, roughness) -> tuple[np.ndarray, np.ndarray]:
    """The weights of the two lobes of an opaque surface at a view (docs/materials.md): the specular lobe's
    energy compensation 1 + F0 (1 / E - 1) and the diffuse base's share 1 - (F0_d A + B), what the
    dielectric's compensated lobe leaves of the light (the base seen under its coat, as Cycles' Principled
    scales it; glTF's spec formula 1 - F(v.h) creates energy at grazing views). (n, 3) each."""
    a, b = split_sum(cos_v, roughness)
    a, b = a[..., None], b[..., None]
    f0_dielectric = np.asarray(f0_dielectric, np.float64)
    compensation = energy_compensation(f0, a + b)
    diffuse_share = 1.0 - (f0_dielectric * a + b) * energy_compensation(f0_dielectric, a + b)
    return compensation, np.clip(diffuse_share, 0.0, 1.0)
