"""Passes declare what they read and write; a technique wires them by channel name.

After Falcor's RenderPassReflection: a reader sees the data flow from the
declarations alone. ``Frame.channels`` is the blackboard the passes share.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar


@dataclass(frozen=True)
class Channel:
    """One named output of a pass: its format and what it means."""

    name: str
    format: str
    meaning: str


@dataclass
class Frame:
    """Everything one render of one image shares: GPU resources, scene, camera, parameters, channels."""

    gpu: Any  # caustica.gpu.device.GpuDevice
    scene: Any
    camera: Any
    params: Any
    channels: dict[str, Any] = field(default_factory=dict)
    pass_ms: dict[str, float] | None = None  # filled with per-pass milliseconds when not None

    def read(self, name: str):
        return self.channels[name]

    def write(self, name: str, value) -> None:
        self.channels[name] = value


class Pass:
    """A render stage. Subclasses set ``reads`` (channel names) and ``writes`` (Channels)."""

    reads: ClassVar[tuple[str, ...]] = ()
    writes: ClassVar[tuple[Channel, ...]] = ()

    @property
    def label(self) -> str:
        """Name in timings: the class, plus its channel for single-output passes (used twice, e.g. front/back)."""
        name = type(self).__name__
        return f"{name}({self.writes[0].name})" if len(self.writes) == 1 else name

    def run(self, frame: Frame) -> None:
        raise NotImplementedError


class PassWiringError(RuntimeError):
    """A pass reads a channel nobody wrote, or fails to write what it declares."""


def run_passes(passes, frame: Frame) -> None:
    """Run passes in order, checking each reads only what an earlier pass wrote."""
    for stage in passes:
        missing = [name for name in stage.reads if name not in frame.channels]
        if missing:
            raise PassWiringError(f"{type(stage).__name__} reads {missing}, which no earlier pass writes")
        if frame.pass_ms is None:
            stage.run(frame)
        else:
            frame.pass_ms[stage.label] = _timed_ms(frame, stage)
        unwritten = [c.name for c in stage.writes if c.name not in frame.channels]
        if unwritten:
            raise PassWiringError(f"{type(stage).__name__} declares {unwritten} but did not write them")


def _timed_ms(frame: Frame, stage: Pass) -> float:
    """Milliseconds of one pass: a GPU timer query on real GPUs, finish() and wall clock on llvmpipe."""
    import time

    ctx = frame.gpu.ctx
    if frame.gpu.info["is_software"]:
        ctx.finish()
        start = time.perf_counter()
        stage.run(frame)
        ctx.finish()
        return (time.perf_counter() - start) * 1000.0
    query = ctx.query(time=True)
    with query:
        stage.run(frame)
    return query.elapsed / 1e6


def describe_passes(passes) -> str:
    """A readable data-flow listing: each pass, what it reads, what it writes."""
    lines = []
    for stage in passes:
        lines.append(f"{type(stage).__name__}: {(stage.__doc__ or '').strip().splitlines()[0]}")
        lines.append(f"  reads:  {', '.join(stage.reads) or '-'}")
        for c in stage.writes:
            lines.append(f"  writes: {c.name} ({c.format}): {c.meaning}")
    return "\n".join(lines)
