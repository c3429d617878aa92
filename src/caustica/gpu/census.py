"""GL objects alive in the current context, by kind, for leak checks (tests, bench/soak.py).

moderngl keeps no count of the objects a context holds, so this asks the GL itself:
``glIs<Kind>(name)`` for every name up to the newest one of each kind (Mesa hands out names
above the highest in use, so a probe object made now bounds them). It calls through EGL's
loader, so it counts in whichever context is current (the shared headless one after a render).
"""
from __future__ import annotations

import ctypes
import functools

from .egl import gl_function

KINDS = ("Texture", "Buffer", "Framebuffer", "Renderbuffer", "Program", "VertexArray", "Shader", "Query", "Sampler")


@functools.cache
def _checks() -> dict:
    checks = {}
    for kind in KINDS:
        function = gl_function(f"glIs{kind}", ctypes.c_ubyte, ctypes.c_uint)
        if function is not None:
            checks[kind.lower()] = function
    return checks


def live_gl_names(ctx) -> dict[str, int]:
    """How many objects of each kind the context ``ctx`` (current) has alive, plus ``total``."""
    bounds = _newest_names(ctx)
    counts = {kind: sum(1 for name in range(1, bounds[kind] + 1) if check(name))
              for kind, check in _checks().items()}
    counts["total"] = sum(counts.values())
    return counts


def _newest_names(ctx) -> dict[str, int]:
    """The name a new object of each kind gets now (released again): no live name is above it."""
    texture = ctx.texture((1, 1), 1)
    program = ctx.program(vertex_shader="#version 330\nvoid main() { gl_Position = vec4(0.0); }")
    probes = {"texture": texture, "buffer": ctx.buffer(reserve=4), "renderbuffer": ctx.renderbuffer((1, 1)),
              "framebuffer": ctx.framebuffer(color_attachments=[texture]), "program": program,
              "vertexarray": ctx.vertex_array(program, []), "sampler": ctx.sampler()}
    names = {kind: int(getattr(probe, "glo", None) or probe._glo) for kind, probe in probes.items()}
    for probe in reversed(list(probes.values())):
        probe.release()
    names["shader"] = names["program"]  # one namespace in Mesa
    names["query"] = max(names.values())  # moderngl's queries cannot be released: no probe
    return names
