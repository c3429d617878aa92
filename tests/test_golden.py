"""Golden images of the presets (llvmpipe), with a stated tolerance.

Regenerate after an intended change: ``pytest --regen-golden -k golden``
(or CAUSTICA_REGEN_GOLDEN=1). Tolerance: PSNR >= 40 dB on linear values
clipped to [0, 1], and no more than 0.5% of pixels off by more than 0.05;
other GL drivers rasterize edges slightly differently, llvmpipe reproduces
the images to within float rounding.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import caustica
from caustica.renderer import Renderer

GOLDEN = Path(__file__).parent / "golden"
SIZE = (128, 128)


def psnr(a, b):
    mse = np.mean((np.clip(a, 0, 1) - np.clip(b, 0, 1)) ** 2)
    return float("inf") if mse == 0 else 10 * np.log10(1.0 / mse)


@pytest.mark.parametrize("technique", ["env-map", "exact"])
@pytest.mark.parametrize("preset", ["glass-sphere", "caustic-sphere"])
def test_golden_preset(preset, technique, regen_golden):
    image = Renderer(SIZE).render(caustica.load_scene(preset), technique)
    path = GOLDEN / f"{preset}_{technique}.npz"
    if regen_golden:
        GOLDEN.mkdir(exist_ok=True)
        np.savez_compressed(path, image=image.astype(np.float16))
        pytest.skip(f"regenerated {path.name}")
    if not path.exists():
        pytest.fail(f"golden image {path} is missing; run pytest --regen-golden -k golden")
    golden = np.load(path)["image"].astype(np.float32)
    assert image.shape == golden.shape
    assert psnr(image, golden) >= 40.0
    off = np.abs(np.clip(image, 0, 1) - np.clip(golden, 0, 1)).max(axis=2) > 0.05
    assert off.mean() <= 0.005
