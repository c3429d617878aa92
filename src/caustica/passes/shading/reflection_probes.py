"""Local reflection probes of glossy receivers: what a rough metal or glossy plastic reflects of the scene around
it, not only of the distant environment.

For each glossy Principled receiver that is not planar (takes_probe; at most MAX_REFLECTION_PROBES of them, the
largest first; the others share the probe whose centre is nearest theirs) the scene without that object is rendered from the centre of its
world bounds into six 90-degree faces, shaded as the frame's receivers are shaded (ShadeSurfaces with the
env-map baseline's program: lights, shadow maps, the environment's ambient and lobes, glossy receivers by
their split sum; glass by its Fresnel reflection and refraction of the environment), with the environment
itself (less a sun that comes as a light) where no object is. The faces are resampled into one equirect
image and prefiltered per roughness level like the environment (prefiltered.py), so that shade_principled
reads the object's probe in its place (common/reflection_probe.glsl; with PROBE_PARALLAX, its lookup is
corrected against a proxy box around the scene: Lagarde and Zanuttini, SIGGRAPH 2012).

A probe does not depend on the camera: the pass is cached by the scene's geometry, lights, materials and the
light passes' outputs. Caustic maps are not in the probes (the caustic passes run after the light passes)."""
from __future__ import annotations

from dataclasses import dataclass

import moderngl
import numpy as np

from ...cache import material_state_key, scene_state_key
from ...gpu.meshes import set_uniform
from ...lighting.samples import CUBE_FORWARD, CUBE_UP
from ...render.bindings import MAX_REFLECTION_PROBES
from ...render.frame import Channel, Frame, Pass
from ...render.offscreen import OffscreenCamera, render_offscreen, scene_subset
from ...scene.transform import look_at_view_from_world, perspective_clip_from_view
from .prefiltered import prefilter_atlas, reflected_environment
from .surfaces import ShadeSurfaces, principled_defines

PROBE_FACE_SIZE = 64  # texels a side of each of a probe's six faces
PROBE_PARALLAX = True  # look probes up towards the reflected ray's exit from the proxy box (else as distant)
OPEN_SIDE_REACH = 1000.0  # scene extents out to which proxy_box puts a side without a wall
WALL_THINNESS = 0.1  # an object this thin along an axis, for its size, is a wall of the proxy box (proxy_box)
_SHARED = ("environment_shadows", "environment_bake")  # the light passes' outputs a probe's faces are lit by


@dataclass
class ReflectionProbe:
    """One probe: where it was rendered from, its parallax proxy box (2, 3) and its prefiltered atlas
    (prefiltered.py's layout: PREFILTER_LEVELS equirect bands)."""

    centre: np.ndarray
    box: np.ndarray
    atlas: object


@dataclass
class ReflectionProbeSet:
    """The frame's probes, per scene object (by index) the probe its glossy shading reads (-1: none), and
    whether lookups are parallax-corrected (PROBE_PARALLAX)."""

    probes: list
    probe_of_object: tuple
    parallax: bool = PROBE_PARALLAX

    def probe_for(self, scene, obj) -> ReflectionProbe | None:
        """The probe ``obj`` (an object of ``scene``) reads, or None."""
        for index, other in enumerate(scene.objects):
            if other is obj:
                k = self.probe_of_object[index] if index < len(self.probe_of_object) else -1
                return self.probes[k] if k >= 0 else None
        return None


def takes_probe(obj) -> bool:
    """Whether ``obj`` gets a reflection probe: a glossy Principled receiver (a GGX specular lobe of its own)
    that is not planar (WALL_THINNESS along an axis: a floor, a backdrop). A probe at a plane's centre sits
    in the objects standing on it and shows them from there: a planar receiver keeps the distant
    environment's prefiltered atlas."""
    if not dict(principled_defines(obj, obj.material)).get("GLOSSY"):
        return False
    extent = np.ptp(obj.world_mesh().bounds, axis=0)
    return bool(extent.min() > WALL_THINNESS * extent.max())


class ReflectionProbes(Pass):
    """The reflection probes of the scene's glossy receivers (takes_probe; None when it has none: then nothing
    else changes)."""

    reads = ("light_samples", "shadow_maps")
    optional = {name: None for name in _SHARED}
    writes = (Channel("reflection_probes", "host",
                      "the glossy receivers' local reflection probes (ReflectionProbeSet) or None"),)

    def __init__(self, face_size: int = PROBE_FACE_SIZE, parallax: bool = PROBE_PARALLAX):
        self.face_size, self.parallax = int(face_size), bool(parallax)

    def cache_key(self, frame: Frame):
        scene = frame.scene
        if not any(takes_probe(obj) for obj in scene.objects):
            return ("none",)
        return (self.face_size, self.parallax, scene_state_key(scene), material_state_key(scene), float(scene.intensity_scale),
                tuple(frame.version(name) for name in ("light_samples", "shadow_maps", *_SHARED)))

    def run(self, frame: Frame) -> None:
        scene = frame.scene
        glossy = [i for i, obj in enumerate(scene.objects) if takes_probe(obj)]
        if not glossy:
            frame.write("reflection_probes", None)
            return
        boxes = {i: scene.objects[i].world_mesh().bounds for i in glossy}
        # The largest receivers get probes of their own; each other glossy one reads the nearest.
        owners = sorted(glossy, key=lambda i: -float(np.linalg.norm(boxes[i][1] - boxes[i][0])))[:MAX_REFLECTION_PROBES]
        probes = [self._probe(frame, i) for i in owners]
        centres = np.stack([p.centre for p in probes])
        probe_of = [-1] * len(scene.objects)
        for i in glossy:
            centre = boxes[i].mean(axis=0)
            probe_of[i] = owners.index(i) if i in owners else int(np.argmin(np.linalg.norm(centres - centre, axis=1)))
        frame.write("reflection_probes", ReflectionProbeSet(probes, tuple(probe_of), self.parallax))

    def _probe(self, frame: Frame, index: int) -> ReflectionProbe:
        """The probe of object ``index``: six faces of the scene without it, resampled and prefiltered."""
        scene, gpu, size = frame.scene, frame.gpu, self.face_size
        centre = scene.objects[index].world_mesh().bounds.mean(axis=0)
        others = scene_subset(scene, [i for i in range(len(scene.objects)) if i != index])
        corners = scene.bounds()
        far = float(np.linalg.norm(np.maximum(np.abs(corners - centre), 1e-3), axis=1).max()) * 2.0 + 1e-3
        projection = perspective_clip_from_view(90.0, 1.0, 1e-4 * far, far)
        share = tuple(name for name in _SHARED if frame.optional(name) is not None)
        faces, clips = [], []
        for forward, up in zip(CUBE_FORWARD, CUBE_UP):
            view = look_at_view_from_world(centre, centre + forward, up)
            camera = OffscreenCamera(centre, (size, size), np.asarray(up, np.float64), view, projection @ view)
            faces.append(render_offscreen(frame, others, camera, [ShadeSurfaces(inputs=())], share=share)["color"])
            clips.append(projection @ view)
        equirect = self._equirect(frame, faces, np.stack(clips), centre)
        atlas = frame.own(prefilter_atlas(gpu, equirect, 2 * size))
        frame.give_back(faces)
        frame.give_back([equirect])
        return ReflectionProbe(centre, proxy_box(scene, index, centre), atlas)

    def _equirect(self, frame: Frame, faces: list, clips: np.ndarray, centre: np.ndarray):
        """The six ``faces`` as one mipmapped equirect image of 4 x 2 face widths (reflection_probe_equirect.frag)."""
        gpu, scene = frame.gpu, frame.scene
        width, height = 4 * self.face_size, 2 * self.face_size
        image = frame.own(gpu.ctx.texture((width, height), 4, dtype="f4"))
        environment = reflected_environment(scene.environment, frame.read("light_samples"))
        environment_texture = gpu.environment_texture(environment)
        program = gpu.shaders.program("common/fullscreen.vert", "passes/shading/reflection_probe_equirect.frag")
        for unit, face in enumerate(faces):
            face.filter = (moderngl.LINEAR, moderngl.LINEAR)
            face.repeat_x = face.repeat_y = False
            face.use(unit)
            set_uniform(program, f"face{unit}", unit)
        environment_texture.use(len(faces))
        set_uniform(program, "environment", len(faces))
        set_uniform(program, "environment_lod",
                    max(float(np.log2(environment.image.shape[1] / width)), 0.0)
                    if environment.filter == "footprint" else 0.0)
        program["face_clip_from_world"].write(np.ascontiguousarray(clips.transpose(0, 2, 1), "f4").tobytes())
        set_uniform(program, "probe_centre", centre.astype("f4"))
        set_uniform(program, "intensity_scale", float(scene.intensity_scale) or 1.0)
        set_uniform(program, "size", np.array([width, height], "i4"))
        fbo = gpu.ctx.framebuffer(color_attachments=[image])
        try:
            fbo.use()
            gpu.draw_fullscreen(program)
        finally:
            fbo.release()
        image.repeat_x, image.repeat_y = True, False
        image.build_mipmaps()
        image.filter = (moderngl.LINEAR_MIPMAP_LINEAR, moderngl.LINEAR)
        return image


def proxy_box(scene, index: int, centre: np.ndarray) -> np.ndarray:
    """The parallax proxy (2, 3) of object ``index``'s probe: per axis and side, the nearest wall beyond the
    centre (another object thin along that axis, WALL_THINNESS of its size, and at least as large as this
    object: a floor, a backdrop; or a side of an object enclosing the centre, a room), else a side
    OPEN_SIDE_REACH scene extents out, where rays look the probe up as a distant environment: the objects
    standing around are not walls, and a box over their tops would bend the open sky's reflection."""
    own = scene.objects[index].world_mesh().bounds.astype(np.float64)
    reach = OPEN_SIDE_REACH * float(np.max(np.ptp(scene.bounds(), axis=0)))
    box = np.stack([centre - reach, centre + reach])
    size = float(np.max(own[1] - own[0]))
    for i, obj in enumerate(scene.objects):
        if i == index:
            continue
        low, high = obj.world_mesh().bounds.astype(np.float64)
        extent = high - low
        encloses = bool(np.all(low < own[0]) and np.all(high > own[1]))  # a room around the object
        for axis in range(3):
            wall = encloses or (extent[axis] <= WALL_THINNESS * extent.max() and extent.max() >= size)
            if not wall:
                continue
            if high[axis] <= centre[axis] or encloses:  # below (or this room's near side)
                box[0, axis] = max(box[0, axis], high[axis] if not encloses else low[axis])
            if low[axis] >= centre[axis] or encloses:
                box[1, axis] = min(box[1, axis], low[axis] if not encloses else high[axis])
    return box
