"""Render targets (textures and framebuffers) pooled by size and format.

The pool keeps what recent frames used: a free texture not handed out again within
``IDLE_FRAMES`` frames (``end_frame`` counts them) is released, so resizing or switching
techniques does not pile up textures of sizes and formats no longer drawn. Framebuffers are
cached by their attachments, at most ``FRAMEBUFFERS`` of them (least recently used first out).
"""
from __future__ import annotations

from collections import OrderedDict
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
BYTES_PER_COMPONENT = {"f1": 1, "f2": 2, "f4": 4, "depth": 4}
IDLE_FRAMES = 8  # frames a free texture waits to be handed out again before it is released
FRAMEBUFFERS = 256  # framebuffers cached (each costs little; the bound keeps stale ones from piling up)


@dataclass(frozen=True)
class TargetKey:
    size: tuple[int, int]
    format: str
    samples: int = 1  # above 1: a multisampled texture (texelFetch by sample; not filtered)


class TargetPool:
    """Hands out textures by (size, format) and takes them back for reuse."""

    def __init__(self, ctx, idle_frames: int = IDLE_FRAMES, max_framebuffers: int = FRAMEBUFFERS):
        self.ctx = ctx
        self.idle_frames, self.max_framebuffers = int(idle_frames), int(max_framebuffers)
        self.frame = 0  # frames ended (end_frame)
        self._free: dict[TargetKey, list] = {}  # key -> [(texture, frame it came back)], oldest first
        self._lent: dict[int, object] = {}  # GL name -> texture handed out and not yet returned
        self._framebuffers: OrderedDict[tuple, object] = OrderedDict()

    def texture(self, size: tuple[int, int], fmt: str, samples: int = 1):
        key = TargetKey((int(size[0]), int(size[1])), fmt, int(samples))
        free = self._free.get(key)
        if free:
            texture, _ = free.pop()
        elif fmt not in FORMATS:
            raise ValueError(f"unknown render target format '{fmt}'; use one of {', '.join(FORMATS)}")
        elif FORMATS[fmt][1] == "depth":
            texture = self.ctx.depth_texture(key.size, samples=key.samples if key.samples > 1 else 0)
        else:
            components, dtype = FORMATS[fmt]
            texture = self.ctx.texture(key.size, components, dtype=dtype, samples=key.samples if key.samples > 1 else 0)
        self._lent[texture.glo] = texture
        return texture

    def zeroed(self, size: tuple[int, int], fmt: str):
        """A pooled colour texture cleared to zero on the GPU (accumulation targets of atomic splats)."""
        texture = self.texture(size, fmt)
        self.framebuffer([texture]).clear(0.0, 0.0, 0.0, 0.0)
        return texture

    def is_lent(self, texture) -> bool:
        """Whether ``texture`` came from this pool and is still out (by identity: a buffer or a
        renderbuffer may share a texture's GL name)."""
        return self._lent.get(getattr(texture, "glo", None)) is texture

    def give_back(self, texture) -> None:
        self._lent.pop(texture.glo, None)
        fmt = "depth" if texture.depth else next(
            name for name, (c, d) in FORMATS.items() if c == texture.components and d == texture.dtype
        )
        key = TargetKey(tuple(texture.size), fmt, max(1, texture.samples))
        self._free.setdefault(key, []).append((texture, self.frame))

    def end_frame(self) -> None:
        """Count a frame; release free textures that waited more than ``idle_frames`` frames."""
        self.frame += 1
        for key in list(self._free):
            free = self._free[key]
            while free and self.frame - free[0][1] > self.idle_frames:
                self._release_texture(free.pop(0)[0])
            if not free:
                del self._free[key]

    def _release_texture(self, texture) -> None:
        """Release a pooled texture and the cached framebuffers drawing into it."""
        for key in [k for k, fbo in self._framebuffers.items() if _attached(fbo, texture)]:
            self._framebuffers.pop(key).release()
        texture.release()

    def counts(self) -> dict[str, int]:
        """Free and lent textures, free bytes, cached framebuffers (for leak checks)."""
        free = [t for entries in self._free.values() for t, _ in entries]
        return {"free_textures": len(free), "lent_textures": len(self._lent), "framebuffers": len(self._framebuffers),
                "free_bytes": sum(texture_bytes(t) for t in free)}

    def framebuffer(self, colors: list, depth=None):
        """A framebuffer over the given attachments (cached by their GL names)."""
        key = (tuple(t.glo for t in colors), depth.glo if depth is not None else None)
        fbo = self._framebuffers.get(key)
        if fbo is not None and not _same_attachments(fbo, colors, depth):  # GL names are reused after a release
            self._framebuffers.pop(key).release()
            fbo = None
        if fbo is None:
            fbo = self.ctx.framebuffer(color_attachments=colors, depth_attachment=depth)
            self._framebuffers[key] = fbo
            while len(self._framebuffers) > self.max_framebuffers:
                self._framebuffers.popitem(last=False)[1].release()
        self._framebuffers.move_to_end(key)
        return fbo

    def release(self) -> None:
        for fbo in self._framebuffers.values():
            fbo.release()
        for entries in self._free.values():
            for t, _ in entries:
                t.release()
        self._framebuffers.clear()
        self._free.clear()


def format_bytes(fmt: str, samples: int = 1) -> int:
    """Bytes a pixel of a target of format ``fmt`` (FORMATS) with ``samples`` samples holds."""
    components, dtype = FORMATS[fmt]
    return components * BYTES_PER_COMPONENT[dtype] * max(1, samples)


def texture_bytes(texture) -> int:
    """Bytes of a pooled texture's storage."""
    return (texture.width * texture.height * texture.components * max(1, texture.samples)
            * BYTES_PER_COMPONENT.get(texture.dtype, 4))


def _same_attachments(fbo, colors: list, depth) -> bool:
    """Whether ``fbo`` draws into exactly these texture objects."""
    attached = list(fbo.color_attachments)
    return len(attached) == len(colors) and all(a is c for a, c in zip(attached, colors)) \
        and fbo.depth_attachment is depth


def _attached(fbo, texture) -> bool:
    return fbo.depth_attachment is texture or any(a is texture for a in fbo.color_attachments)
