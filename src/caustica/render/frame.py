"""Passes declare what they read and write; a technique lists them; the graph runs them.

After Falcor's RenderPassReflection: a reader sees the data flow from the
declarations alone. ``Frame.channels`` is the blackboard the passes share, and
the frame lends every GPU resource a pass allocates (``Frame.texture``): the
graph (render/graph.py) takes each back once no later pass reads it.
"""
from __future__ import annotations

import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, ClassVar

# A channel's format: a texture format (gpu/targets.py), "buffer" (a GL buffer) or "host" (CPU data:
# light samples, views, rectangles); "xN" when each entry is N of them; "[light]" or "[reflector]"
# when the channel holds one entry per light sample (None where a light has none) or per reflector.
CHANNEL_FORMAT = re.compile(r"(rgba8|rgba16f|rgba32f|rgb32f|rg32f|r32f|depth|buffer|host)( x[2-9])?"
                            r"( \+ host)?(\[(light|reflector)\])?")


@dataclass(frozen=True)
class Channel:
    """One named output of a pass: its format (CHANNEL_FORMAT) and what it means."""

    name: str
    format: str
    meaning: str

    def __post_init__(self):
        if not CHANNEL_FORMAT.fullmatch(self.format):
            raise ValueError(f"channel '{self.name}' has format '{self.format}', which is not a channel format "
                             "(e.g. 'rgba32f', 'r32f[light]', 'rgba32f x2[light]', 'buffer[light]', 'host')")


class Pass:
    """A render stage. Subclasses set ``reads`` (channel names), ``writes`` (Channels) and may set:

    ``optional``: channels read when an earlier pass wrote them, each with the define (1 or 0) that
    tells the shaders (:meth:`Frame.optional_defines`; None: no shader needs to know);
    :meth:`cache_key`: what the outputs depend on, so that the graph reuses them across frames
    (:meth:`Frame.version` names an input's content, for a key over what a pass reads).
    """

    reads: ClassVar[tuple[str, ...]] = ()
    optional: ClassVar[dict[str, str]] = {}
    writes: ClassVar[tuple[Channel, ...]] = ()

    @property
    def label(self) -> str:
        """Name in timings: the class, plus its channel for single-output passes (used twice, e.g. front/back)."""
        name = type(self).__name__
        return f"{name}({self.writes[0].name})" if len(self.writes) == 1 else name

    def cache_key(self, frame: "Frame"):
        """A hashable value of everything this pass's outputs depend on, or None (run every frame).

        When not None, the graph keeps the outputs in the device cache and, while the key stays the
        same, writes them instead of running the pass (render/graph.py)."""
        return None

    def run(self, frame: "Frame") -> None:
        raise NotImplementedError


def frame_setting(params, name: str):
    """A setting of a frame's parameters (the view's of a composite's pair, which auto sets), or None."""
    first = params[0] if isinstance(params, tuple) and params else params
    return getattr(first, name, None)


class PassWiringError(RuntimeError):
    """A pass reads a channel nobody wrote, or fails to write what it declares."""


@dataclass
class Frame:
    """Everything one render of one image shares: GPU resources, scene, camera, parameters, channels.

    Every texture a pass takes with :meth:`texture` or :meth:`zeroed`, and every GL object it makes
    itself and hands to :meth:`own`, is lent to the frame; the graph gives them back (pooled textures
    to the pool, the rest released) once no later pass reads them, so no pass frees by hand."""

    gpu: Any  # caustica.gpu.device.GpuDevice
    scene: Any
    camera: Any
    params: Any
    channels: dict[str, Any] = field(default_factory=dict)
    pass_ms: dict[str, float] | None = None  # filled with per-pass milliseconds when not None
    lent: dict[int, Any] = field(default_factory=dict, repr=False)  # id -> texture or GL object on loan
    running: Any = field(default=None, repr=False)  # the pass being run (for optional_defines)
    versions: dict[str, Any] = field(default_factory=dict, repr=False)  # channel -> version (render/graph.py)

    def read(self, name: str):
        return self.channels[name]

    def write(self, name: str, value) -> None:
        self.channels[name] = value

    def texture(self, size: tuple[int, int], fmt: str, samples: int = 1):
        """A pooled render target lent to this frame (``samples`` > 1: multisampled)."""
        return self.own(self.gpu.targets.texture(size, fmt, samples))

    def zeroed(self, size: tuple[int, int], fmt: str):
        """A pooled render target cleared to zero, lent to this frame."""
        return self.own(self.gpu.targets.zeroed(size, fmt))

    def own(self, value):
        """Lend ``value`` (a GL object this pass made, e.g. a buffer or a texture with its own sampling) to
        the frame, which releases it with the rest; returns it."""
        self.lent[id(value)] = value
        return value

    def scratch(self, size: tuple[int, int], fmt: str, zeroed: bool = False, samples: int = 1):
        """A pooled target for a ``with`` block alone (a depth buffer under one draw)."""
        return self.scoped(self.zeroed(size, fmt) if zeroed else self.texture(size, fmt, samples))

    @contextmanager
    def scoped(self, value):
        """Lend ``value`` (a GL object this pass made) for a ``with`` block alone: given back at its end."""
        self.own(value)
        try:
            yield value
        finally:
            self.give_back(value)

    def optional(self, name: str):
        """An optional input's value, None when no earlier pass wrote it."""
        return self.channels.get(name)

    def optional_defines(self, stage: Pass | None = None) -> dict[str, int]:
        """The defines of ``stage``'s (default: the running pass's) optional inputs: 1 where written, else 0."""
        stage = self.running if stage is None else stage
        return {define: int(self.channels.get(name) is not None) for name, define in stage.optional.items()
                if define is not None}

    def version(self, name: str):
        """A hashable name of a channel's content: the cache key of the pass that wrote it when that
        pass is cached (equal across frames while the key holds), else unique to this write; None
        when the channel is absent."""
        return self.versions.get(name) if name in self.channels else None

    def take_out(self, value) -> list:
        """Stop lending the GL objects in ``value`` (someone else keeps them now); returns them."""
        from ..gpu.device import gl_objects

        taken = [obj for obj in gl_objects(value) if self.lent.pop(id(obj), None) is not None]
        return taken

    def give_back(self, value=None) -> None:
        """Give back the lent objects in ``value`` (all of them when None)."""
        from ..gpu.device import release_all

        objects = list(self.lent.values()) if value is None else self.take_out(value)
        if value is None:
            self.lent.clear()
        release_all(objects, self.gpu.targets if self.gpu is not None else None)

    def sub_frame(self, scene, camera, channels: dict, params=None) -> "Frame":
        """A frame over another scene or camera (reflection maps, impostor textures) sharing the GPU."""
        return Frame(self.gpu, scene, camera, self.params if params is None else params, channels=dict(channels))
