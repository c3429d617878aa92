"""``transport-table-view``: refraction of the viewing ray through the light transport table (Iwasaki et al. 5.3).

The table that ``transport-table`` precomputes for caustics (per vertex and
sampled incident direction: where a ray leaves the glass, along which
direction, with which transmittance) also answers where the *viewing* ray
leaves: every frame, per glass object and vertex, the direction from the eye
to the vertex, in the vertex's tangent frame, picks the four nearest sampled
directions; the exit direction is their slerp, the transmittance their
bilinear blend (:func:`view_exit`, the same :func:`caustica.transport.runtime.lookup`
as the light's). The results travel to the GPU as per-vertex attributes
(``in_exit_dir``, ``in_exit_t``; ``shaders/passes/transport_view.vert``) and
the fragment shades F env(reflect) + (1 - F) T env(exit), F the exact Fresnel
of the front surface per fragment; the exit direction is written to the
``exit_direction`` channel.

Differs from the paper: the exit ray looks up the distant environment; the
paper intersects it with the sample planes and maps the sliced object images
(``caustica.transport.sample_planes``) onto the object. Limits: the exit is
interpolated per vertex, then linearly over each triangle, so it is as coarse
as the mesh (a sphere's exit direction turns fast near the rim); one IOR per
object (no dispersion); Fresnel-reflected view paths inside the glass are not
followed (the table keeps the refracted branch).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..passes.shading.lights import light_passes
from ..passes.shading.surfaces import ShadeBackground, ShadeSurfaces
from ..raytrace.optics import dot, fresnel_dielectric, normalize
from ..scene.transform import normal_matrix
from .raster import RasterTechnique
from .transport_table import TableParams

EXIT_DIRECTION, EXIT_TRANSMITTANCE = "in_exit_dir", "in_exit_t"


@dataclass
class TransportViewParams(TableParams):
    """Parameters of ``transport-table-view``: the table's, shared with ``transport-table``."""


@dataclass
class ViewExit:
    direction: np.ndarray  # (V, 3) world exit direction of the view ray through each vertex
    transmittance: np.ndarray  # (V, 3) after the front interface: later interfaces and Beer-Lambert, per channel
    visible: np.ndarray  # (V,) bool: the vertex faces the eye


def view_exit(obj, eye: np.ndarray, params: TableParams, progress: bool = False) -> ViewExit:
    """The table lookup (5.3) for the viewing rays from ``eye`` to every vertex of glass ``obj``."""
    from ..transport.runtime import lookup, table_for, vertex_frames

    mesh = obj.mesh
    table = table_for(mesh, obj.material.ior, params.directions, params.max_depth, params.quantized, progress)
    m = np.asarray(obj.world_from_object(), dtype=np.float64)
    a, t = m[:3, :3], m[:3, 3]
    world = mesh.vertices.astype(np.float64) @ a.T + t
    towards_eye = normalize(np.asarray(eye, np.float64)[None] - world)
    found = lookup(table, vertex_frames(mesh), towards_eye @ np.linalg.inv(a).T)
    direction = normalize(found.exit_direction @ a.T)
    # The table's transmittance includes the entry's 1 - F; the fragment applies F per pixel.
    normal = normalize(mesh.normals.astype(np.float64) @ normal_matrix(m).T)
    entry = 1.0 - fresnel_dielectric(np.clip(dot(normal, towards_eye), 0.0, 1.0), 1.0, obj.material.ior)
    after = np.clip(found.transmittance / np.maximum(entry, 1e-4), 0.0, 1.0)
    sigma = np.asarray(getattr(obj.material, "absorption_coefficient", np.zeros(3)), np.float64)
    inside = np.linalg.norm(found.exit_position.astype(np.float64) @ a.T + t - world, axis=1)
    return ViewExit(direction, after[:, None] * np.exp(-sigma[None] * inside[:, None]), found.lit)


def _view_attributes(params: TableParams):
    """ShadeSurfaces' per-object hook: the glass object's view exits as vertex attributes, just before it
    is drawn (per object, so two objects sharing one mesh get their own)."""

    def set_uniforms(program, frame, obj) -> None:
        if obj is None or obj.material.kind != "glass":
            return
        found = view_exit(obj, frame.camera.position, params)
        mesh = frame.gpu.meshes.get(obj.mesh)
        mesh.set_attribute(EXIT_DIRECTION, found.direction)
        mesh.set_attribute(EXIT_TRANSMITTANCE, found.transmittance)

    return set_uniforms


class TransportTableView(RasterTechnique):
    name = "transport-table-view"
    summary = "View refraction through the precomputed light transport table, per vertex (Iwasaki et al. 5.3)"
    Params = TransportViewParams

    def build_passes(self, params):
        return [*light_passes(params.shadow_map_size),
                ShadeSurfaces("passes/shading/transport_view.frag", inputs=(), set_uniforms=_view_attributes(params),
                              vertex="passes/shading/transport_view.vert"), ShadeBackground()]
