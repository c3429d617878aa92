"""Rasterized techniques: a technique lists its passes; the renderer runs them as a graph (render/graph.py)."""
from __future__ import annotations

from ..gpu.readback import box_downsample, read_rgb, read_rgba, supersampling_factor  # noqa: F401 (re-exported)
from .base import Technique


class RasterTechnique(Technique):
    """A technique made of GPU passes; ``build_passes`` wires them for given parameters."""

    role = "view"

    def build_passes(self, params) -> list:
        raise NotImplementedError
