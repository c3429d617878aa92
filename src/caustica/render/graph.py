"""The render graph: a technique's passes checked, run, timed, cached and given back.

After Falcor's RenderGraph. :class:`RenderGraph` checks the wiring once (each
pass reads only what an earlier pass or the caller wrote) and knows, for each
channel, the last pass that reads it. :func:`run_graph` runs the passes in
order and, after each, gives back every texture the frame lent that no later
pass reads and the caller does not keep: a pass allocates with
``frame.texture`` and never frees. A pass with a :meth:`Pass.cache_key` is run
only when its key changes; its outputs then live in the device cache (one
entry per pass label, the older one given back on a miss).
"""
from __future__ import annotations

import itertools
import time

from ..text import summary
from .frame import Frame, Pass, PassWiringError


class RenderGraph:
    """``passes`` in order, wired by channel name; ``provided``: channels the frame starts with."""

    def __init__(self, passes, provided=()):
        self.passes: list[Pass] = list(passes)
        self.provided = tuple(provided)

    def check(self, frame_channels=None) -> None:
        """PassWiringError where a pass reads a channel that neither the caller nor an earlier pass writes."""
        written = set(self.provided if frame_channels is None else frame_channels)
        for stage in self.passes:
            missing = [name for name in stage.reads if name not in written]
            if missing:
                raise PassWiringError(f"{type(stage).__name__} reads {missing}, which no earlier pass writes")
            written.update(c.name for c in stage.writes)

    def last_reads(self) -> dict[str, int]:
        """Channel -> index of the last pass reading it (declared or optional)."""
        last = {}
        for index, stage in enumerate(self.passes):
            for name in (*stage.reads, *stage.optional):
                last[name] = index
        return last

    def channels(self) -> dict:
        """Every channel written, by name: (Channel, label of the pass writing it first)."""
        out = {}
        for stage in self.passes:
            for channel in stage.writes:
                out.setdefault(channel.name, (channel, stage.label))
        return out

    def lifetime(self, name: str, keep=("color",)) -> str:
        """How long a channel's textures stay lent: kept for the caller, held by the cache (a cached
        pass's outputs), or until the pass that reads them last."""
        writer = next((i for i, p in enumerate(self.passes) if any(c.name == name for c in p.writes)), None)
        if name in keep:
            return "kept for the caller"
        if writer is not None and is_cached(self.passes[writer]):
            return "held by the cache"
        last = max(self.last_reads().get(name, -1), -1 if writer is None else writer)
        return f"lent until pass {last + 1}"

    def describe(self, keep=("color",), indent: str = "") -> str:
        """The wired graph as text: passes in order, what each reads and writes (format, meaning,
        how long it stays lent), what is cached across frames; a group's inner passes indented."""
        lines = []
        for index, stage in enumerate(self.passes, start=1):
            cached = "  [cached across frames]" if is_cached(stage) else ""
            lines.append(f"{indent}{index}. {stage.label}: {summary(stage.__doc__)}{cached}")
            lines.append(f"{indent}     reads:    {', '.join(stage.reads) or '-'}")
            if stage.optional:
                lines.append(f"{indent}     optional: "
                             + ", ".join(f"{n} (define {d})" if d else n for n, d in stage.optional.items()))
            for c in stage.writes:
                lines.append(f"{indent}     writes:   {c.name} ({c.format}): {c.meaning}; {self.lifetime(c.name, keep)}")
            inner = getattr(stage, "passes", None)  # a group of passes run as one (CachedPasses)
            if inner:
                lines.append(f"{indent}     runs:")
                lines.append(RenderGraph(inner).describe(keep=[c.name for c in stage.writes], indent=indent + "       "))
        return "\n".join(lines)

    def dot(self, title: str = "graph") -> str:
        """Graphviz: a box per pass, an edge from each channel's writer to each of its readers."""
        def quote(text: str) -> str:
            return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'

        lines = [f"digraph {quote(title)} {{", "  rankdir=TB;", "  node [shape=box, fontname=Helvetica];"]
        writer: dict[str, str] = {}
        formats = {}
        for index, stage in enumerate(self.passes):
            node = f"p{index}"
            cached = is_cached(stage)
            lines.append(f"  {node} [label={quote(stage.label)}{', style=bold' if cached else ''}];")
            for name, optional in [(n, False) for n in stage.reads] + [(n, True) for n in stage.optional]:
                if name in writer:
                    style = ", style=dashed" if optional else ""
                    lines.append(f"  {writer[name]} -> {node} [label={quote(name + ' ' + formats[name])}{style}];")
            for c in stage.writes:
                writer[c.name], formats[c.name] = node, c.format
        lines.append("}")
        return "\n".join(lines) + "\n"


def is_cached(stage: Pass) -> bool:
    """Whether a pass declares a cache key (its outputs may be reused across frames)."""
    return type(stage).cache_key is not Pass.cache_key


def run_graph(passes, frame: Frame, keep=None) -> None:
    """Run ``passes`` on ``frame``, then give back what no later pass reads.

    ``keep``: the channels the caller reads afterwards (their textures stay lent to the frame until
    it gives them back); None keeps every channel written. Checks that each pass writes what it
    declares; fills ``frame.pass_ms`` when it is not None."""
    graph = RenderGraph(passes)
    graph.check(frame.channels)
    last = graph.last_reads()
    keep = None if keep is None else set(keep)
    for index, stage in enumerate(graph.passes):
        frame.running = stage
        try:
            elapsed, version = _run_stage(stage, frame)
        finally:
            frame.running = None
        if frame.pass_ms is not None:
            frame.pass_ms[stage.label] = elapsed
        unwritten = [c.name for c in stage.writes if c.name not in frame.channels]
        if unwritten:
            raise PassWiringError(f"{type(stage).__name__} declares {unwritten} but did not write them")
        for channel in stage.writes:
            frame.versions[channel.name] = version
        if frame.lent:
            live = [value for name, value in frame.channels.items()
                    if keep is None or name in keep or last.get(name, -1) > index]
            _give_back_all_but(frame, live)


def _give_back_all_but(frame: Frame, live: list) -> None:
    """Give back every object the frame lent that no value in ``live`` holds."""
    from ..gpu.device import gl_objects

    held = {id(obj) for obj in gl_objects(live)}
    idle = [obj for key, obj in frame.lent.items() if key not in held]
    if idle:
        frame.give_back(idle)


def _run_stage(stage: Pass, frame: Frame) -> tuple[float, object]:
    """Run (or find in the cache) one pass: its milliseconds when timing (else 0) and the version of
    what it wrote (its cache key, or a new number)."""
    key = stage.cache_key(frame) if frame.gpu is not None else None
    if key is None:
        return _timed(stage, frame), next(_WRITES)
    cache = frame.gpu.cache
    version = (stage.label, key)
    entry = cache.get(version)
    if entry is not None:
        for name, value in entry.items():
            frame.write(name, value)
        return 0.0, version
    evict(cache, stage.label)
    elapsed = _timed(stage, frame)
    entry = {c.name: frame.read(c.name) for c in stage.writes if c.name in frame.channels}
    frame.take_out(entry)  # the cache owns them now
    cache[version] = entry
    return elapsed, version


_WRITES = itertools.count(1)  # versions of outputs no cache key names


def evict(cache, label: str) -> None:
    """Give back the cached outputs of the pass labelled ``label`` (the next frame reruns it)."""
    for old in [k for k in cache if isinstance(k, tuple) and len(k) == 2 and k[0] == label]:
        cache.pop_release(old)


def _timed(stage: Pass, frame: Frame) -> float:
    """Run a pass; when timing, its milliseconds: a GPU timer query on real GPUs, finish() and wall clock on llvmpipe."""
    if frame.pass_ms is None:
        stage.run(frame)
        return 0.0
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


def run_passes(passes, frame: Frame, keep=None) -> None:
    """Run ``passes`` on ``frame`` as one graph; ``keep`` as in run_graph."""
    run_graph(passes, frame, keep)


def describe_passes(passes) -> str:
    """A readable data-flow listing: each pass, what it reads, what it writes."""
    return RenderGraph(passes).describe()
