"""Caustic maps kept across frames: a chain of light-space passes rerun only when what it reads changes.

Shah et al. (III-F) and Wyman ("Putting it Together") build the caustic map
from the light alone: it does not depend on the camera, so while lights,
objects and materials stay as they are the map of the last frame is the map of
this one. :class:`CachedPasses` runs a chain of passes as one pass whose
:meth:`~caustica.render.frame.Pass.cache_key` is those (plus the technique's
parameters); the render graph (``render/graph.py``) keeps its outputs.
"""
from __future__ import annotations

from ..cache import material_state_key, scene_state_key
from .frame import Frame, Pass
from .graph import run_passes


class CachedPasses(Pass):
    """Run ``passes`` only when lights, objects, materials or ``key`` change; reuse their outputs otherwise.

    The graph caches the ``keep`` channels (render/graph.py, :meth:`Pass.cache_key`); whatever else
    the inner passes wrote is given back when they finish.
    """

    def __init__(self, tag: str, key, passes: list, keep: tuple[str, ...] = ("caustic_maps",)):
        self.tag, self.key, self.passes, self.keep = tag, key, list(passes), tuple(keep)
        inner = {c.name for p in self.passes for c in p.writes}
        self.reads = tuple(dict.fromkeys(("light_samples", *(n for p in self.passes for n in p.reads if n not in inner))))
        self.writes = tuple(c for p in self.passes for c in p.writes if c.name in self.keep)
        self.rebuilt = 0  # how many times the inner passes ran (tests)

    @property
    def label(self) -> str:
        return f"{type(self).__name__}({self.tag})"

    def cache_key(self, frame: Frame):
        return self.key, scene_state_key(frame.scene), material_state_key(frame.scene)

    def run(self, frame: Frame) -> None:
        before = set(frame.channels)
        run_passes(self.passes, frame, keep=before | set(self.keep))
        for name in set(frame.channels) - before - set(self.keep):
            del frame.channels[name]  # given back by the inner graph
        self.rebuilt += 1
