"""Render targets (textures and framebuffers) pooled by size and format."""
from __future__ import annotations

from dataclasses import dataclass

# format name -> (components, dtype)
FORMATS = {
    "rgba8": (4, "f1"),
    "rgba16f": (4, "f2"),
    "rgba32f": (4, "f4"),
    "rgb32f": (3, "f4"),
    "rg32f": (2, "f4"),
    "r32f": (1, "f4"),
    "depth": (1, "depth"),
}


@dataclass(frozen=True)
class TargetKey:
    size: tuple[int, int]
    format: str


class TargetPool:
    """Hands out textures by (size, format) and takes them back for reuse."""

    def __init__(self, ctx):
        self.ctx = ctx
        self._free: dict[TargetKey, list] = {}
        self._lent: set[int] = set()  # GL names of textures handed out and not yet returned
        self._framebuffers: dict[tuple, object] = {}

    def texture(self, size: tuple[int, int], fmt: str):
        key = TargetKey((int(size[0]), int(size[1])), fmt)
        free = self._free.get(key)
        if free:
            texture = free.pop()
        elif fmt not in FORMATS:
            raise ValueError(f"unknown render target format '{fmt}'; use one of {', '.join(FORMATS)}")
        elif FORMATS[fmt][1] == "depth":
            texture = self.ctx.depth_texture(key.size)
        else:
            components, dtype = FORMATS[fmt]
            texture = self.ctx.texture(key.size, components, dtype=dtype)
        self._lent.add(texture.glo)
        return texture

    def zeroed(self, size: tuple[int, int], fmt: str):
        """A pooled colour texture cleared to zero on the GPU (accumulation targets of atomic splats)."""
        texture = self.texture(size, fmt)
        self.framebuffer([texture]).clear(0.0, 0.0, 0.0, 0.0)
        return texture

    def is_lent(self, texture) -> bool:
        """Whether ``texture`` came from this pool and is still out."""
        return getattr(texture, "glo", None) in self._lent

    def give_back(self, texture) -> None:
        self._lent.discard(texture.glo)
        fmt = "depth" if texture.depth else next(
            name for name, (c, d) in FORMATS.items() if c == texture.components and d == texture.dtype
        )
        self._free.setdefault(TargetKey(tuple(texture.size), fmt), []).append(texture)

    def framebuffer(self, colors: list, depth=None):
        """A framebuffer over the given attachments (cached by their GL names)."""
        key = (tuple(t.glo for t in colors), depth.glo if depth is not None else None)
        fbo = self._framebuffers.get(key)
        if fbo is None:
            fbo = self.ctx.framebuffer(color_attachments=colors, depth_attachment=depth)
            self._framebuffers[key] = fbo
        return fbo

    def release(self) -> None:
        for fbo in self._framebuffers.values():
            fbo.release()
        for textures in self._free.values():
            for t in textures:
                t.release()
        self._framebuffers.clear()
        self._free.clear()
