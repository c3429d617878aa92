"""Resolve: the supersampled colour to the output pixels (box filter), and post-process edge anti-aliasing."""
from __future__ import annotations

from typing import TYPE_CHECKING

from ...errors import RenderOptionError, short
from ...render.draw import fullscreen_pass

if TYPE_CHECKING:  # the CLI imports ANTIALIAS_MODES without the GL layers
    from ...render.frame import Frame

ANTIALIAS_MODES = ("none", "edge", "msaa", "adaptive")
"""``none``: pixels as rendered (k x k supersampling with spp > 1); ``edge``: the post-process edge blend
(docs/antialiasing.md) after the box filter; ``msaa``: the outlines resolved with multisampled geometry
coverage (passes/post/subpixel.py) before the box filter; ``adaptive``: 1 spp, and 4 spp at the pixels whose
neighbours differ (passes/post/adaptive.py; the renderer runs both frames)."""


def check_antialias(antialias) -> str:
    """``antialias`` when it is one of ANTIALIAS_MODES; RenderOptionError otherwise."""
    if antialias not in ANTIALIAS_MODES:
        raise RenderOptionError(f"antialias {short(antialias)} is unknown; choose one of {', '.join(ANTIALIAS_MODES)}")
    return antialias


EDGE_SEARCH_STEPS = 12  # 29 pixels each way (steps of 1, 2, 4 and 8 pixels)


def resolved(frame: Frame, texture, k: int, antialias: str = "none"):
    """``texture`` (rgba32f, k times the output size) as the output's pixels: its outlines resolved with
    multisampled coverage when ``antialias`` is ``msaa``, averaged over k x k blocks, then edge
    anti-aliased when ``antialias`` is ``edge``. New textures are lent to ``frame``."""
    if antialias == "msaa":
        from .subpixel import reconstructed

        texture = reconstructed(frame, texture, frame.texture(texture.size, "rgba32f"))
    if k > 1:
        texture = fullscreen_pass(frame, texture, "passes/post/box_downsample.frag", {"K": int(k)}, k)
    if antialias == "edge":
        texture = fullscreen_pass(frame, texture, "passes/post/edge_antialias.frag", {"MAX_STEPS": EDGE_SEARCH_STEPS}, 1)
    return texture


