"""LabelSurfaces: the per-pixel label buffers a render returns on request (caustica.labels, docs/labels.md).

One draw of every object at the output size, so each pixel holds its centre sample: the first surface's
world normal (facing the eye) and view-space depth, its object and material index and glass flag, and,
where a caustic technique wrote ``caustic_maps`` or ``caustic_tiles``, the caustic irradiance on a diffuse
receiver (the term ShadeSurfaces adds, common/caustics.glsl). With supersampling, a second draw at the
frame's size gives the coverage each pixel's samples see (alpha). The technique's own passes are untouched:
this pass comes last and reads only what they leave.
"""
from __future__ import annotations

from contextlib import contextmanager

import moderngl

from ..gpu.meshes import set_uniform
from .base import Channel, Frame, Pass
from .caustics import MAX_CAUSTIC_TILES, bind_caustic_maps, bind_caustic_tiles, bind_receiver_tiles
from .lights import MAX_LIGHTS, bind_lights, draw_objects

SURFACE = Channel("label_surface", "rgba32f", "first surface at pixel centres (output size): world normal "
                  "facing the eye xyz, view-space depth w (0: background)")
IDS = Channel("label_ids", "rgba32f", "object index + 1, material index + 1, glass 1, covered 1 (0: background)")
CAUSTIC = Channel("label_caustic", "rgba32f", "caustic irradiance times intensity_scale on diffuse receivers "
                  "(None: no caustic technique ran)")
COVERAGE = Channel("label_coverage", "r32f", "1 where an object covers a sample (frame size; None at 1 spp)")
FIRST_LIGHT_UNIT = 1  # shadow maps (bound by bind_lights, unread), then the caustic maps


class LabelSurfaces(Pass):
    """Label buffers of the first surface at each pixel centre, plus coverage and caustics on request."""

    reads = ()
    optional = {"caustic_maps": "CAUSTICS", "caustic_tiles": "CAUSTIC_TILES", "light_samples": None,
                "shadow_maps": None}

    def __init__(self, supersampling: int, materials: list, caustic: bool = False, coverage: bool = False):
        """``supersampling``: the frame's k (its camera is k times the output size); ``materials``: the
        material index of each object (caustica.labels.material_indices); ``caustic``, ``coverage``:
        write those buffers too."""
        self.k, self.materials, self.caustic, self.coverage = int(supersampling), list(materials), caustic, coverage
        self.writes = (SURFACE, IDS) + ((CAUSTIC,) if caustic else ()) + ((COVERAGE,) if coverage else ())

    def run(self, frame: Frame) -> None:
        width, height = frame.camera.size
        camera = frame.camera.with_size(width // self.k, height // self.k)
        caustic_maps, tiles = frame.optional("caustic_maps"), frame.optional("caustic_tiles")
        with_caustics = self.caustic and (caustic_maps is not None or tiles is not None)
        surface, ids = (frame.texture(camera.size, "rgba32f") for _ in range(2))
        targets = [surface, ids]
        if with_caustics:
            targets.append(frame.texture(camera.size, "rgba32f"))
        defines = {"LABEL_CAUSTIC": int(with_caustics), **frame.optional_defines(self), "MAX_LIGHTS": MAX_LIGHTS,
                   "MAX_CAUSTIC_TILES": MAX_CAUSTIC_TILES}
        program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/labels.frag", defines)
        set_uniform(program, "camera_position", camera.position.astype("f4"))
        set_uniform(program, "camera_forward", -camera.view_from_world()[2, :3].astype("f4"))
        if with_caustics:
            set_uniform(program, "intensity_scale", float(frame.scene.intensity_scale))
            bind_lights(program, frame.optional("light_samples") or [], frame.optional("shadow_maps") or [],
                        first_unit=FIRST_LIGHT_UNIT)
            if caustic_maps is not None:
                bind_caustic_maps(program, caustic_maps, first_unit=FIRST_LIGHT_UNIT + MAX_LIGHTS)
            else:
                bind_caustic_tiles(program, tiles, unit=FIRST_LIGHT_UNIT + MAX_LIGHTS)
        with _drawing(frame, camera.size, targets):
            clip_from_world = camera.clip_from_world()
            for index, obj in enumerate(frame.scene.objects):
                set_uniform(program, "object_id", float(index + 1))
                set_uniform(program, "material_id", float(self.materials[index] + 1))
                set_uniform(program, "glass", float(obj.material.kind == "glass"))
                if with_caustics:
                    set_uniform(program, "receives_caustics", int(obj.material.kind == "diffuse"))
                    if tiles is not None and caustic_maps is None:
                        bind_receiver_tiles(program, tiles, obj)
                draw_objects(frame, program, [obj], clip_from_world)
        frame.write(SURFACE.name, surface)
        frame.write(IDS.name, ids)
        if self.caustic:
            frame.write(CAUSTIC.name, targets[2] if with_caustics else None)
        if self.coverage:
            frame.write(COVERAGE.name, self._coverage(frame))

    def _coverage(self, frame: Frame):
        """1 at every sample of the supersampled frame that an object covers, 0 elsewhere."""
        target = frame.texture(frame.camera.size, "r32f")
        program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/labels.frag", {"COVERAGE_ONLY": 1})
        with _drawing(frame, frame.camera.size, [target]):
            draw_objects(frame, program, frame.scene.objects, frame.camera.clip_from_world())
        return target


@contextmanager
def _drawing(frame: Frame, size, targets):
    """A framebuffer over ``targets`` with a scratch depth buffer: cleared to 0, depth tested, no culling."""
    with frame.scratch(size, "depth") as depth:
        fbo = frame.gpu.targets.framebuffer(targets, depth)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx = frame.gpu.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        ctx.depth_func = "<"
        yield fbo


def read_label_buffers(frame: Frame) -> dict:
    """The label channels of ``frame`` read back as float32 arrays, row 0 at the top (None where absent)."""
    from ..gpu.readback import read_rgba

    out = {}
    for channel in (SURFACE, IDS, CAUSTIC, COVERAGE):
        texture = frame.channels.get(channel.name)
        out[channel.name] = None if texture is None else read_rgba(texture)
    return out



def label_pass(scene, names, supersampling: int) -> LabelSurfaces:
    """The LabelSurfaces run that gives the labels ``names`` (caustica.labels.check_labels) of ``scene``
    rendered with ``supersampling`` k: the caustic buffer when asked for, the coverage when alpha is and k > 1."""
    from ..labels import material_indices

    return LabelSurfaces(supersampling, material_indices(scene), caustic="caustic" in names,
                         coverage="alpha" in names and supersampling > 1)
