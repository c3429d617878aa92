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

from ...gpu.meshes import set_uniform
from ...gpu.readback import read_rgba
from ...lighting.samples import MAX_LIGHTS
from ...render.bindings import (MAX_CAUSTIC_TILES, bind_caustic_maps, bind_caustic_tiles, bind_lights,
                                bind_receiver_tiles)
from ...render.draw import culled_back_faces  # ShadeSurfaces' back-face culling of solids
from ...render.draw import draw_objects
from ...render.frame import Channel, Frame, Pass

SURFACE = Channel("label_surface", "rgba32f", "first surface at pixel centres (output size): world normal "
                  "facing the eye xyz, view-space depth w (0: background)")
IDS = Channel("label_ids", "rgba32f", "object index + 1, material index + 1, glass 1, covered 1 (0: background)")
CAUSTIC = Channel("label_caustic", "rgba32f", "caustic irradiance times intensity_scale on diffuse receivers "
                  "(None: no caustic technique ran)")
COVERAGE = Channel("label_coverage", "r32f", "1 where an object covers a sample (frame size; None at 1 spp)")


class LabelSurfaces(Pass):
    """Label buffers of the first surface at each pixel centre, plus coverage and caustics on request."""

    reads = ()
    optional = {"caustic_maps": "CAUSTICS", "caustic_tiles": "CAUSTIC_TILES", "light_samples": None,
                "shadow_maps": None}

    def __init__(self, supersampling: int, materials: list, caustic: bool = False, coverage: bool = False,
                 objects: list | None = None):
        """``supersampling``: the frame's k (its camera is k times the output size); ``materials``: the
        material index of each object (caustica.labels.material_indices); ``caustic``, ``coverage``:
        write those buffers too; ``objects``: the scene's, which the labels describe (None: the frame's; a
        frame that leaves out invisible glass still labels it)."""
        self.k, self.materials, self.caustic, self.coverage = int(supersampling), list(materials), caustic, coverage
        self.objects = objects
        self.writes = (SURFACE, IDS) + ((CAUSTIC,) if caustic else ()) + ((COVERAGE,) if coverage else ())

    def run(self, frame: Frame) -> None:
        width, height = frame.camera.size
        camera = frame.camera.with_size(width // self.k, height // self.k)
        caustic_maps, tiles = frame.optional("caustic_maps"), frame.optional("caustic_tiles")
        with_caustics = self.caustic and (caustic_maps is not None or tiles is not None)
        targets = [frame.texture(camera.size, "rgba32f") for _ in range(3 if with_caustics else 2)]
        # One variant for the diffuse receivers, which look the caustics up, one for the rest.
        programs = {receiver: self._program(frame, camera, with_caustics, receiver)
                    for receiver in ((False, True) if with_caustics else (False,))}
        draw_first_surfaces(frame, camera, targets, programs, self.materials, None if caustic_maps is not None else tiles,
                            objects=self.objects)
        frame.write(SURFACE.name, targets[0])
        frame.write(IDS.name, targets[1])
        if self.caustic:
            frame.write(CAUSTIC.name, targets[2] if with_caustics else None)
        if self.coverage:
            frame.write(COVERAGE.name, self._coverage(frame))

    def _program(self, frame: Frame, camera, with_caustics: bool, receiver: bool):
        """labels.frag with its per-frame uniforms: ``with_caustics`` a caustic target, ``receiver`` the
        variant that looks the caustics up (lights and caustic maps or tiles bound)."""
        defines = {"LABEL_CAUSTIC": int(with_caustics), "CAUSTIC_RECEIVER": int(receiver)}
        if receiver:
            defines.update({**frame.optional_defines(self), "MAX_LIGHTS": MAX_LIGHTS,
                            "MAX_CAUSTIC_TILES": MAX_CAUSTIC_TILES})
        program = label_program(frame, camera, defines)
        if receiver:
            caustic_maps = frame.optional("caustic_maps")
            set_uniform(program, "intensity_scale", float(frame.scene.intensity_scale))
            bind_lights(program, frame.optional("light_samples") or [], frame.optional("shadow_maps") or [])
            if caustic_maps is not None:
                bind_caustic_maps(program, caustic_maps)
            else:
                bind_caustic_tiles(program, frame.optional("caustic_tiles"))
        return program

    def _coverage(self, frame: Frame):
        """1 at every sample of the supersampled frame that an object covers, 0 elsewhere."""
        target = frame.texture(frame.camera.size, "r32f")
        program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/post/labels.frag", {"COVERAGE_ONLY": 1})
        with _drawing(frame, frame.camera.size, [target]):
            clip_from_world = frame.camera.clip_from_world()
            for obj in frame.scene.objects if self.objects is None else self.objects:
                with culled_back_faces(frame.gpu.ctx, obj, clip_from_world):
                    draw_objects(frame, program, [obj], clip_from_world)
        return target


def label_program(frame: Frame, camera, defines: dict | None = None):
    """labels.frag (``defines``) with ``camera``'s uniforms set."""
    program = frame.gpu.shaders.program("common/mesh_vertex.glsl", "passes/post/labels.frag", defines or {})
    set_uniform(program, "camera_position", camera.position.astype("f4"))
    set_uniform(program, "camera_forward", -camera.view_from_world()[2, :3].astype("f4"))
    return program


def draw_first_surfaces(frame: Frame, camera, targets, programs: dict, materials: list, tiles=None,
                        samples: int = 1, objects: list | None = None) -> None:
    """Every object's first surface seen by ``camera`` into ``targets`` (labels.frag's surface, ids and
    caustic; ``samples`` per pixel): ``programs`` maps receiver (a diffuse object looking the caustics up,
    key True when given) to its program; ``materials`` the objects' material indices; ``tiles`` the caustic
    tiles bound per receiver (None: caustic maps or none); ``objects`` (None: the frame scene's)."""
    clip_from_world = camera.clip_from_world()
    with _drawing(frame, camera.size, targets, samples):
        for index, obj in enumerate(frame.scene.objects if objects is None else objects):
            receiver = True in programs and obj.material.kind == "diffuse"
            program = programs[receiver]
            set_uniform(program, "object_id", float(index + 1))
            set_uniform(program, "material_id", float(materials[index] + 1))
            set_uniform(program, "glass", float(obj.material.kind == "glass"))
            if receiver and tiles is not None:
                bind_receiver_tiles(program, tiles, obj)
            with culled_back_faces(frame.gpu.ctx, obj, clip_from_world):  # the same nearest surface
                draw_objects(frame, program, [obj], clip_from_world)


@contextmanager
def _drawing(frame: Frame, size, targets, samples: int = 1):
    """A framebuffer over ``targets`` with a scratch depth buffer (``samples`` per pixel): cleared to 0,
    depth tested, no culling."""
    with frame.scratch(size, "depth", samples=samples) as depth:
        fbo = frame.gpu.targets.framebuffer(targets, depth)
        fbo.use()
        fbo.clear(0.0, 0.0, 0.0, 0.0, depth=1.0)
        ctx = frame.gpu.ctx
        ctx.enable(moderngl.DEPTH_TEST)
        ctx.disable(moderngl.CULL_FACE)
        ctx.depth_func = "<"
        yield fbo


def read_label_buffers(frame: Frame, names) -> dict:
    """The label channels that the labels ``names`` need, read back as float32 arrays (row 0 at the top:
    flipped views, not copies; None where absent)."""
    wanted = {IDS.name: True, SURFACE.name: bool({"depth", "normal"} & set(names)),
              CAUSTIC.name: "caustic" in names, COVERAGE.name: "alpha" in names}
    out = {}
    for name, needed in wanted.items():
        texture = frame.channels.get(name) if needed else None
        out[name] = None if texture is None else read_rgba(texture, copy=False)
    return out


def label_pass(scene, names, supersampling: int) -> LabelSurfaces:
    """The LabelSurfaces run that gives the labels ``names`` (caustica.labels.check_labels) of ``scene``
    rendered with ``supersampling`` k: the caustic buffer when asked for, the coverage when alpha is and k > 1."""
    from ...labels import material_indices

    return LabelSurfaces(supersampling, material_indices(scene), caustic="caustic" in names,
                         coverage="alpha" in names and supersampling > 1, objects=list(scene.objects))
