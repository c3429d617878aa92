"""A reference's own noise floor, from two independent halves of its samples.

A Monte Carlo reference R of N samples per pixel is the mean of two independent
renders A (n_a samples) and B (n_b = N - n_a), weighted by their counts. With
per-sample variance s^2, Var(A) = s^2 / n_a, Var(B) = s^2 / n_b, so
E[(A - B)^2] = s^2 (1/n_a + 1/n_b), while R's own error against the noise-free
image is Var(R) = s^2 / N. The full reference's floor (the error a perfect
technique would still score against it) is therefore

    floor MSE = MSE(A, B) * n_a n_b / N^2      (a quarter of it for equal halves)

in dB: the PSNR between the halves plus 10 log10(N^2 / (n_a n_b)), +6.02 dB for
equal halves: +3 dB from the halves' difference (two noises) to one half's own
error, and +3 dB more for the whole, which has twice a half's samples. The same
factor converts relMSE (an MSE with a per-pixel weight). Noise variance falls as
1/spp, so a floor measured at one count predicts another: +3 dB per doubling
(:func:`spp_for_floor`).

A technique's measured error is its own error plus the reference's noise (they
are independent): a figure within :data:`FLOOR_MARGIN_DB` of the floor is at
least half the reference's noise, so the reference, not the technique, sets it.
"""
from __future__ import annotations

import math

import numpy as np

from .images import psnr_linear, psnr_srgb, relmse

FLOOR_METRICS = ("psnr_linear", "psnr_srgb", "relmse")
FLOOR_MARGIN_DB = 10.0 * math.log10(2.0)  # a measured MSE under twice the floor's is at least half reference noise


def halves_factor(n_a: int, n_b: int) -> float:
    """MSE(A, B) times this is the floor MSE of the reference of n_a + n_b samples (the module docstring)."""
    if n_a < 1 or n_b < 1:
        raise ValueError(f"halves of {n_a} and {n_b} samples: each needs at least one")
    return n_a * n_b / float(n_a + n_b) ** 2


def noise_floor(half_a, half_b, n_a: int, n_b: int, masks: dict | None = None) -> dict[str, dict[str, float]]:
    """{region: {"psnr_linear", "psnr_srgb" (dB), "relmse"}}: the floor of the reference (n_a A + n_b B) / N
    over the whole image ("all") and each of ``masks`` ((H, W) bool), from its halves A and B."""
    factor = halves_factor(n_a, n_b)
    decibels = -10.0 * math.log10(factor)
    regions = {"all": None, **(masks or {})}
    return {name: {"psnr_linear": psnr_linear(half_a, half_b, mask) + decibels,
                   "psnr_srgb": psnr_srgb(half_a, half_b, mask) + decibels,
                   "relmse": relmse(half_a, half_b, mask) * factor}
            for name, mask in regions.items()}


def at_floor(metrics: dict, floor: dict) -> list[str]:
    """The FLOOR_METRICS of one region's figures (compare_images's) that lie within FLOOR_MARGIN_DB of that
    region's floor (a PSNR above floor - 3 dB, a relMSE under twice the floor's): at least half of each such
    measured error is the reference's own noise, so the reference, not the technique, sets it."""
    ratio = 10.0 ** (FLOOR_MARGIN_DB / 10.0)
    near = {"psnr_linear": lambda m, f: m >= f - FLOOR_MARGIN_DB, "psnr_srgb": lambda m, f: m >= f - FLOOR_MARGIN_DB,
            "relmse": lambda m, f: m <= f * ratio}
    return [key for key in FLOOR_METRICS
            if not (math.isnan(metrics[key]) or math.isnan(floor[key])) and near[key](metrics[key], floor[key])]


def spp_for_floor(pilot_spp: int, pilot_floor_db: float, target_db: float, slope: float = 1.0) -> int:
    """Samples a reference needs for a ``target_db`` floor, from a pilot of ``pilot_spp`` that measured
    ``pilot_floor_db``: noise variance ~ 1/spp^slope (1: independent samples, +3 dB per doubling), so spp scales
    by 10^((target - pilot) / (10 slope)); rounded up to an even count (two equal halves) and never below the
    pilot's."""
    if not math.isfinite(pilot_floor_db):
        return pilot_spp  # the pilot has no noise to speak of (a constant image)
    needed = pilot_spp * 10.0 ** ((target_db - pilot_floor_db) / (10.0 * slope))
    return max(pilot_spp, 2 * math.ceil(min(needed, 1e12) / 2.0 - 1e-9))


def measured_slope(spp_a: int, floor_a_db: float, spp_b: int, floor_b_db: float) -> float:
    """How the floor grew between two counts, as the exponent of noise variance ~ 1/spp^slope, kept in
    [0.25, 1]: below 1 where the fewer samples missed rare bright paths and measured too little noise."""
    if spp_b == spp_a or not (math.isfinite(floor_a_db) and math.isfinite(floor_b_db)):
        return 1.0
    return min(1.0, max(0.25, (floor_b_db - floor_a_db) / (10.0 * math.log10(spp_b / spp_a))))


def split_spp(spp: int) -> tuple[int, int]:
    """The two halves' sample counts of a reference of ``spp`` (the first gets the odd one)."""
    return (spp + 1) // 2, spp // 2


def combine_halves(half_a, half_b, n_a: int, n_b: int) -> np.ndarray:
    """The reference of n_a + n_b samples from its halves: their mean weighted by their counts."""
    return ((np.asarray(half_a, np.float64) * n_a + np.asarray(half_b, np.float64) * n_b)
            / (n_a + n_b)).astype(np.float32)
