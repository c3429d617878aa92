"""Specular optics on arrays of directions: mirror reflection, Snell refraction, Fresnel.

Conventions (shared by every function here):

- Directions ``d`` point along the travel of light (from the eye into the scene
  for camera rays), unit length, shape (..., 3), float64.
- The normal ``n`` passed in faces *against* ``d`` (dot(d, n) <= 0): flip it to
  the side the ray comes from before calling. ``cos_i = -dot(d, n) >= 0``.
- ``eta = n_i / n_t``: index of refraction on the incident side over the one on
  the transmitted side (1/1.5 from air into glass, 1.5 from glass into air).
"""
from __future__ import annotations

import numpy as np


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product, (..., 3) x (..., 3) -> (...)."""
    return np.einsum("...k,...k->...", a, b)


def normalize(v: np.ndarray) -> np.ndarray:
    """Unit vectors along (..., 3) ``v`` (zero vectors stay zero)."""
    v = np.asarray(v, dtype=np.float64)
    length = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(length, 1e-300)


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror reflection r = d - 2 (d . n) n (either orientation of ``n`` works)."""
    d = np.asarray(d, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    return d - 2.0 * dot(d, n)[..., None] * n


def refract(d: np.ndarray, n: np.ndarray, eta) -> tuple[np.ndarray, np.ndarray]:
    """Snell refraction of unit ``d`` at a surface with unit normal ``n`` facing against ``d``.

    With cos_i = -d . n and sin^2 t = eta^2 (1 - cos_i^2) (Snell: n_i sin i = n_t sin t),
    the transmitted direction is t = eta d + (eta cos_i - cos_t) n, cos_t = sqrt(1 - sin^2 t)
    (pbrt 4th ed., section 9.3). Returns ``(t, tir)``: unit directions (..., 3) and a
    boolean mask of total internal reflection (sin^2 t > 1), where ``t`` is the mirror
    reflection instead so that the output is always a valid direction.
    """
    d = np.asarray(d, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    eta = np.asarray(eta, dtype=np.float64)
    cos_i = np.clip(-dot(d, n), 0.0, 1.0)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    tir = sin2_t > 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    t = eta[..., None] * d + (eta * cos_i - cos_t)[..., None] * n
    t = np.where(tir[..., None], reflect(d, n), t)
    return normalize(t), tir


def fresnel_dielectric(cos_i, eta_i, eta_t) -> np.ndarray:
    """Exact unpolarised Fresnel reflectance of a smooth dielectric interface.

    ``cos_i`` is the cosine of the incidence angle (its sign is ignored), ``eta_i``
    and ``eta_t`` the indices on the incident and transmitted side. With
    cos_t = sqrt(1 - (eta_i / eta_t)^2 sin^2 i) (Born and Wolf, section 1.5.2):

        r_s = (eta_i cos_i - eta_t cos_t) / (eta_i cos_i + eta_t cos_t)
        r_p = (eta_t cos_i - eta_i cos_t) / (eta_t cos_i + eta_i cos_t)
        R   = (r_s^2 + r_p^2) / 2

    R = 1 under total internal reflection (sin t > 1); R = 0 when the indices match.
    """
    cos_i = np.clip(np.abs(np.asarray(cos_i, dtype=np.float64)), 0.0, 1.0)
    eta_i = np.asarray(eta_i, dtype=np.float64)
    eta_t = np.asarray(eta_t, dtype=np.float64)
    sin2_t = (eta_i / eta_t) ** 2 * (1.0 - cos_i * cos_i)
    tir = sin2_t >= 1.0
    cos_t = np.sqrt(np.maximum(1.0 - sin2_t, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        r_s = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t)
        r_p = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t)
    reflectance = 0.5 * (r_s * r_s + r_p * r_p)
    reflectance = np.where(tir, 1.0, np.nan_to_num(reflectance, nan=1.0))  # grazing: 0/0 -> 1
    return np.where(eta_i == eta_t, 0.0, reflectance)
