"""The panel and the overlay as a retained layer over the views.

ImGui (its Python widgets and its PyOpenGL renderer) is a noticeable share of
a frame on llvmpipe (docs/performance.md). So ImGui draws into an offscreen RGBA8
target the size of the window, and every frame only composites that target
over the views. ImGui itself runs for a few frames after any input or change
of the viewer's state, and otherwise every ``REFRESH_S`` seconds, which keeps
the frame-time text live.
"""
from __future__ import annotations

import math
import time

REFRESH_S = 0.25  # ImGui redraws at least this often while nothing happens
SETTLE_FRAMES = 4  # ImGui runs this many frames after an input (hover, popups, key repeat)


class UiLayer:
    """An RGBA8 target ImGui draws into (premultiplied colour), composited over the window each frame."""

    def __init__(self, ctx):
        self.ctx = ctx
        self.texture = None
        self.framebuffer = None
        self._drawn_at = -math.inf
        self._settle = SETTLE_FRAMES

    def touch(self) -> None:
        """An input or a change of state: ImGui runs for the next frames."""
        self._settle = SETTLE_FRAMES

    def due(self, size: tuple[int, int]) -> bool:
        """Whether ImGui must run this frame (input, a resize, or the refresh period)."""
        resized = self.texture is None or tuple(self.texture.size) != tuple(size)
        return resized or self._settle > 0 or time.perf_counter() - self._drawn_at >= REFRESH_S

    def redraw(self, size: tuple[int, int], draw) -> None:
        """Clear the layer and run ``draw()`` (ImGui's render) into it."""
        if self.texture is None or tuple(self.texture.size) != tuple(size):
            self.release()
            self.texture = self.ctx.texture(tuple(size), 4)
            self.framebuffer = self.ctx.framebuffer(color_attachments=[self.texture])
        self.framebuffer.use()
        self.framebuffer.clear(0.0, 0.0, 0.0, 0.0)
        draw()
        self._drawn_at = time.perf_counter()
        self._settle = max(0, self._settle - 1)

    def composite(self, display, size: tuple[int, int], opaque=None, blended=()) -> None:
        """Put the layer over the window (the views already drawn).

        The ``opaque`` rectangle (the panel; x, y, w, h from the lower left) is copied: its colour
        is exact there, whatever alpha ImGui's blending left. The rest is blended: all of it
        while ImGui is settling (popups may lie anywhere), otherwise only the ``blended``
        rectangles (the overlay), a fraction of the window's pixels.
        """
        if self.texture is None:
            return
        if opaque is not None:
            self._copy(opaque)
        if self._settle > 0:
            width = size[0] - (opaque[2] if opaque is not None else 0)
            blended = [(0, 0, width, size[1])] if width > 0 else []
        for rect in blended:
            display.draw(self.texture, rect, "layer")

    def _copy(self, rect) -> None:
        """Blit one rectangle of the layer to the same place in the window."""
        from OpenGL import GL

        x, y, width, height = (int(v) for v in rect)
        GL.glBindFramebuffer(GL.GL_READ_FRAMEBUFFER, self.framebuffer.glo)
        GL.glBindFramebuffer(GL.GL_DRAW_FRAMEBUFFER, self.ctx.screen.glo)
        GL.glBlitFramebuffer(x, y, x + width, y + height, x, y, x + width, y + height, GL.GL_COLOR_BUFFER_BIT,
                             GL.GL_NEAREST)
        self.ctx.screen.use()

    def release(self) -> None:
        for resource in (self.framebuffer, self.texture):
            if resource is not None:
                resource.release()
        self.texture = self.framebuffer = None
