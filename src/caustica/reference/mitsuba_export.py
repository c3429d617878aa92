"""Export a caustica :class:`~caustica.scene.Scene` to Mitsuba 3 with the same meaning: a dict or an XML file.

One description, two serializations. :func:`scene_description` builds the
scene as a Mitsuba dict whose leaves are plain data (:class:`Matrix`,
:class:`Bitmap`, :class:`PlyMesh`). :func:`scene_to_mitsuba` turns it into the
dict ``mi.load_dict`` takes (``mi.ScalarTransform4f``, in-memory ``mi.Bitmap``,
PLY files in a mesh folder); it needs Mitsuba imported with a variant set, as
:func:`caustica.reference.render.mitsuba_module` does. :func:`write_mitsuba_xml`
writes the same description as a Mitsuba 3 XML file with the meshes as PLY and
the images as EXR in a folder beside it (``mitsuba out.xml`` or
``mi.load_file`` renders it; Mitsuba is not needed to write it).

What maps to what (every radiometric value times ``scene.intensity_scale``):

- Camera: ``perspective`` sensor, ``fov_axis = 'y'`` with our vertical
  ``fov_y``; ``to_world`` is Mitsuba's look_at from position / look_at / up.
  Mitsuba's local camera looks down +Z with +X to the left of the image, so
  the look_at frame puts image column 0 on the left and row 0 at the top,
  exactly as :meth:`caustica.scene.Camera.primary_rays` (checked by
  ``tests/test_reference.py`` with an off-centre object). Film: ``hdrfilm``,
  RGB float32, box reconstruction filter (each pixel is the mean over its
  square footprint, as our stratified pixel samples).
- Environment: ``envmap`` with identity ``to_world``: Mitsuba's mapping
  u = atan2(d.x, -d.z) / 2pi, v = acos(d.y) / pi (row 0 at +Y) is ours.
  Its rotation and strength are already in the image
  (:meth:`caustica.scene.Environment.rotated`), so they export unchanged.
- Point light: ``point`` with ``intensity`` (radiant intensity, W/sr, as ours).
  Directional: ``directional`` with ``irradiance`` and ``direction`` (the
  travel direction, as ours). Line light: one ``point`` per point sample.
- Spot light: ``spot`` with ``cutoff_angle`` = our outer angle and
  ``beam_width`` = our inner angle. Approximation: Mitsuba's falloff is
  linear in the angle between the two cones, ours a smoothstep in the
  cosine; both are 1 inside the inner cone and 0 outside the outer one and
  agree at the midpoint, differing by at most about 0.1 between.
- Diffuse: ``twosided`` ``diffuse`` (our receivers are lit from either side).
  A texture (``Diffuse.texture`` on a mesh with ``uvs``) becomes a ``bitmap``
  reflectance of colour times texture (linear float, bilinear, repeat); the
  PLY carries the uvs as they are: glTF's (0, 0) = top-left is Mitsuba's too.
  Mirror: ``twosided`` ``conductor`` with ``material = 'none'`` (Fresnel 1)
  times ``specular_reflectance`` = colour. Glass: ``dielectric`` with
  ``int_ior`` = ior, ``ext_ior`` = 1. Absorbing glass gets an interior
  ``homogeneous`` medium with ``sigma_t`` = the absorption coefficient and
  ``albedo`` 0 (pure Beer-Lambert absorption), which needs the ``volpath``
  integrator: :func:`scene_to_mitsuba` switches ``path`` to ``volpath`` then.
  ``ptracer`` ignores media, so light-traced caustics through absorbing
  glass are not attenuated (a stated limit of the reference).
- Principled with a specular lobe (drawn as an opaque receiver): ``twosided`` ``principled`` with
  ``base_color``, ``roughness`` (Mitsuba's alpha is roughness^2, as glTF's), ``metallic`` (bitmaps of the
  base colour and of the metallic-roughness map's green and blue channels) and ``specular`` = the
  dielectric F0 / 0.08; inside a ``normalmap`` where it has a normal map (Mitsuba's frame: +u, and
  cross(n, +u), which is glTF's bitangent for w = +1). Both use GGX and Schlick's Fresnel; Mitsuba's
  diffuse lobe is Disney's, not glTF's Lambertian less Fresnel (measured: a glossy plastic floor about
  3 % brighter). Emission: an ``area`` emitter with the lights.
- Dispersion (a glass with differing ``ior_rgb``): pass ``channel`` = 0, 1 or 2
  to export every glass with that channel's IOR; the reference renders the
  three and keeps one channel of each (:mod:`caustica.reference.render`).
- Meshes: object-space binary little-endian PLY with vertex normals (and uvs
  when the mesh has them), named by a hash of what it holds (so a mesh reused by
  several objects or renders is written once), and the object's ``world_from_object``
  as ``to_world``. A mesh that tessellates an exact sphere (``analytic_sphere``,
  uniform scale) is exported as Mitsuba's analytic ``sphere`` when
  ``analytic_spheres`` is true (the default) and it has no texture, as the exact
  oracle traces it.
"""
from __future__ import annotations

import hashlib
import math
import os
import re
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from xml.sax.saxutils import escape, quoteattr

import numpy as np

from ..cache import atomic_write_bytes
from ..errors import OutputError
from ..raytrace.embree_scene import world_sphere
from ..scene.mesh import Mesh
from ..scene.transform import look_at_view_from_world, up_hint

INTEGRATORS = ("path", "volpath", "ptracer")


# -- the description's leaves: plain data that each serialization writes its own way ----------------


@dataclass(eq=False)
class Matrix:
    """A 4x4 transform (``mi.ScalarTransform4f`` in a dict, ``<transform><matrix/>`` in XML)."""

    matrix: np.ndarray


@dataclass(eq=False)
class Bitmap:
    """A linear float32 RGB image (an in-memory ``mi.Bitmap``, or an EXR file beside the XML)."""

    image: np.ndarray
    stem: str  # the file name's start: 'environment' or 'texture'


@dataclass(eq=False)
class PlyMesh:
    """An object-space mesh, written as a binary PLY (in the mesh folder, or beside the XML)."""

    mesh: Mesh


def _rgb(value, scale: float = 1.0) -> dict:
    return {"type": "rgb", "value": [float(x) * scale for x in np.asarray(value, dtype=np.float64).reshape(3)]}


def _matrix(m: np.ndarray) -> Matrix:
    return Matrix(np.asarray(m, dtype=np.float64).reshape(4, 4))


def _point(p) -> list[float]:
    return [float(x) for x in np.asarray(p, dtype=np.float64).reshape(3)]


def look_at_to_world(origin, target, up) -> np.ndarray:
    """Mitsuba's ``Transform4f.look_at`` as a 4x4 matrix: columns left, up, forward, origin.

    Our OpenGL ``world_from_view`` has columns right, up, -forward: Mitsuba's
    frame is it with X and Z negated.
    """
    world_from_view = np.linalg.inv(look_at_view_from_world(origin, target, up))
    return world_from_view @ np.diag([-1.0, 1.0, -1.0, 1.0])


def mesh_file_hash(mesh: Mesh) -> str:
    """Hash of what the PLY holds: vertices, normals and faces (and uvs, when the mesh has them)."""
    return mesh.geometry_hash()


def ply_bytes(mesh: Mesh) -> bytes:
    """Binary little-endian PLY of ``mesh`` with per-vertex normals (and u, v when the mesh has uvs)."""
    n = len(mesh.vertices)
    columns = [mesh.vertices, mesh.normals] + ([mesh.uvs] if mesh.uvs is not None else [])
    uv_header = "property float u\nproperty float v\n" if mesh.uvs is not None else ""
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment caustica reference export\n"
        f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
        f"property float nx\nproperty float ny\nproperty float nz\n{uv_header}"
        f"element face {len(mesh.faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode("ascii")
    vertex = np.concatenate(columns, axis=1).astype("<f4")
    face = np.zeros(len(mesh.faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    face["n"] = 3
    face["idx"] = mesh.faces
    return header + vertex.tobytes() + face.tobytes()


def mesh_file_name(mesh: Mesh) -> str:
    return f"mesh-{mesh_file_hash(mesh)}.ply"


def write_mesh_ply(mesh: Mesh, mesh_dir: Path) -> Path:
    """Write ``mesh`` (object space) to ``mesh_dir/<hash>.ply`` unless it is there; return the path."""
    mesh_dir = Path(mesh_dir)
    mesh_dir.mkdir(parents=True, exist_ok=True)
    path = mesh_dir / mesh_file_name(mesh)
    if not path.exists():
        atomic_write_bytes(path, ply_bytes(mesh))
    return path


def image_hash(image: np.ndarray) -> str:
    """Hash of an image's float32 values and shape (names the EXR files; keys the reference cache)."""
    h = hashlib.sha1(np.ascontiguousarray(image, dtype=np.float32).tobytes())
    h.update(str(image.shape).encode())
    return h.hexdigest()[:16]


def _diffuse_reflectance(material, mesh: Mesh):
    """The diffuse albedo: an RGB, or a bitmap of colour times texture where the mesh has uvs."""
    if getattr(material, "texture", None) is None or mesh.uvs is None:
        return _rgb(material.color)
    image = np.asarray(material.texture, dtype=np.float32) * np.asarray(material.color, dtype=np.float32)
    return {"type": "bitmap", "bitmap": Bitmap(image, "texture"), "filter_type": "bilinear", "wrap_mode": "repeat"}


PRINCIPLED_F0_PER_SPECULAR = 0.08  # Mitsuba's principled: a dielectric's F0 is 0.08 times its ``specular``


def _texture_or_value(texture, value, mesh: Mesh, raw: bool = False, channel: int | None = None):
    """A Principled factor ``value`` (a number or an RGB) times ``texture`` (one of its channels, repeated in
    all three, where ``channel`` is given) as a Mitsuba value or bitmap; the value alone without a texture
    or uvs. ``raw``: data, not colour (Mitsuba reads it unchanged)."""
    if texture is None or mesh.uvs is None:
        return float(value) if np.ndim(value) == 0 else _rgb(value)
    image = np.asarray(texture, dtype=np.float32)
    if channel is not None:
        image = np.repeat(image[..., channel:channel + 1], 3, axis=2)
    image = image * np.asarray(value, dtype=np.float32)
    bitmap = {"type": "bitmap", "bitmap": Bitmap(np.ascontiguousarray(image), "texture"), "filter_type": "bilinear",
              "wrap_mode": "repeat"}
    return bitmap | ({"raw": True} if raw else {})


def principled_bsdf(material, mesh: Mesh) -> dict:
    """A glossy Principled as Mitsuba's ``principled`` (the module docstring), twosided, in its normal map."""
    f0_dielectric = float(material.dielectric_f0.mean())
    bsdf = {"type": "principled",
            "base_color": _texture_or_value(material.base_color_texture, material.base_color, mesh),
            "roughness": _texture_or_value(material.metallic_roughness_texture, material.roughness, mesh,
                                           raw=True, channel=1),
            "metallic": _texture_or_value(material.metallic_roughness_texture, material.metallic, mesh,
                                          raw=True, channel=2),
            "specular": f0_dielectric / PRINCIPLED_F0_PER_SPECULAR}
    if material.normal_texture is not None and mesh.uvs is not None:
        bsdf = {"type": "normalmap", "bsdf": bsdf,
                "normalmap": _texture_or_value(material.normal_texture, np.ones(3), mesh, raw=True)}
    return {"type": "twosided", "bsdf": bsdf}


def emitter_of(material, mesh: Mesh, scale: float) -> dict | None:
    """The ``area`` emitter of a Principled's emission (times ``scale``), or None where it emits nothing."""
    emission = np.asarray(getattr(material, "emission", np.zeros(3)), np.float64)
    if not np.any(emission > 0):
        return None
    return {"type": "area", "radiance": _texture_or_value(getattr(material, "emission_texture", None),
                                                          emission * scale, mesh)}


def _material(material, channel: int | None, mesh: Mesh) -> tuple[dict, dict | None]:
    """(bsdf dict, interior medium dict or None) for one of our materials on ``mesh``."""
    if material.kind == "diffuse" and getattr(material, "glossy", False):
        return principled_bsdf(material, mesh), None
    if material.kind == "diffuse" and getattr(material, "normal_texture", None) is not None and mesh.uvs is not None:
        return {"type": "twosided", "bsdf": {"type": "normalmap", "normalmap": _texture_or_value(
            material.normal_texture, np.ones(3), mesh, raw=True), "bsdf": {
                "type": "diffuse", "reflectance": _diffuse_reflectance(material, mesh)}}}, None
    if material.kind == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": _diffuse_reflectance(material, mesh)}}, None
    if material.kind == "mirror":
        return {
            "type": "twosided",
            "bsdf": {"type": "conductor", "material": "none", "specular_reflectance": _rgb(material.color)},
        }, None
    if material.kind == "glass":
        ior = float(material.ior if channel is None else material.ior_rgb[channel])
        bsdf = {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0}
        sigma = np.asarray(material.absorption_coefficient, dtype=np.float64)
        medium = None
        if np.any(sigma > 0):
            # Mitsuba's RGB textures must lie in [0, 1]: normalise sigma_t and carry its size in ``scale``;
            # a zero channel makes volpath's distance sampling divide by zero (NaN), so floor it at 1e-4.
            scale = float(sigma.max())
            medium = {"type": "homogeneous", "sigma_t": _rgb(np.maximum(sigma / scale, 1e-4)), "scale": scale,
                      "albedo": _rgb(np.zeros(3))}
        return bsdf, medium
    raise ValueError(f"cannot export material kind '{material.kind}' to Mitsuba")
def _lights(scene) -> dict:
    out = {}
    s = float(scene.intensity_scale)
    for i, light in enumerate(scene.lights):
        if light.kind == "directional":
            out[f"light{i}"] = {
                "type": "directional",
                "direction": _point(light.direction),
                "irradiance": _rgb(light.intensity, s),
            }
        elif light.kind == "spot":
            pos, d = light.position, light.direction
            out[f"light{i}"] = {
                "type": "spot",
                "to_world": _matrix(look_at_to_world(pos, pos + d, up_hint(d))),
                "intensity": _rgb(light.intensity, s),
                "cutoff_angle": float(light.outer_angle),
                "beam_width": float(light.inner_angle),
            }
        elif light.kind in ("point", "line"):
            for k, (position, intensity) in enumerate(light.point_samples()):
                out[f"light{i}_{k}"] = {
                    "type": "point",
                    "position": _point(position),
                    "intensity": _rgb(intensity, s),
                }
        else:
            raise ValueError(f"cannot export light kind '{light.kind}' to Mitsuba")
    return out


def has_absorbing_glass(scene) -> bool:
    return any(o.material.kind == "glass" and np.any(o.material.absorption_coefficient > 0) for o in scene.objects)


def has_dispersion(scene) -> bool:
    return any(o.material.kind == "glass" and np.ptp(o.material.ior_rgb) > 0 for o in scene.objects)


def scene_description(
    scene,
    size: tuple[int, int] | None = None,
    spp: int = 64,
    integrator: str = "path",
    max_depth: int = 16,
    channel: int | None = None,
    analytic_spheres: bool = True,
    camera=None,
    emitters: str = "all",
) -> dict:
    """The Mitsuba 3 scene of ``scene`` as a dict whose leaves are plain data (:class:`Matrix`,
    :class:`Bitmap`, :class:`PlyMesh`); :func:`scene_to_mitsuba` and :func:`write_mitsuba_xml` serialize it.

    ``size`` (width, height) overrides the camera's; ``camera`` replaces the
    scene camera. ``integrator`` is 'path', 'volpath' or 'ptracer'; 'path'
    becomes 'volpath' when a glass absorbs. ``max_depth`` counts path vertices
    as Mitsuba does (-1: unbounded). ``channel`` picks the per-channel IOR of
    dispersive glass. ``emitters`` keeps 'all' emitters, only the
    'environment' or only the 'lights'.
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator '{integrator}' must be one of {', '.join(INTEGRATORS)}")
    if emitters not in ("all", "environment", "lights"):
        raise ValueError(f"emitters '{emitters}' must be 'all', 'environment' or 'lights'")
    camera = camera if camera is not None else scene.camera
    if size is not None:
        camera = camera.with_size(*size)
    width, height = camera.size
    if integrator == "path" and has_absorbing_glass(scene):
        integrator = "volpath"

    result: dict = {"type": "scene"}
    integrator_dict = {"type": integrator, "max_depth": int(max_depth)}
    if integrator != "ptracer":
        integrator_dict["hide_emitters"] = False
    result["integrator"] = integrator_dict
    result["sensor"] = {
        "type": "perspective",
        "fov_axis": "y",
        "fov": float(camera.fov_y),
        "near_clip": float(camera.near),
        "far_clip": float(camera.far),
        "to_world": _matrix(look_at_to_world(camera.position, camera.look_at, camera.up)),
        "sampler": {"type": "independent", "sample_count": int(spp)},
        "film": {
            "type": "hdrfilm",
            "width": int(width),
            "height": int(height),
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": {"type": "box"},
        },
    }

    image = scene.environment.image
    if emitters != "lights" and np.any(image > 0):
        result["environment"] = {"type": "envmap", "scale": float(scene.intensity_scale),
                                 "bitmap": Bitmap(image, "environment")}
    if emitters != "environment":
        result.update(_lights(scene))

    for i, obj in enumerate(scene.objects):
        bsdf, medium = _material(obj.material, channel, obj.mesh)
        textured = bsdf.get("bsdf", {}).get("reflectance", {}).get("type") == "bitmap"
        sphere = world_sphere(obj.mesh, obj.world_from_object()) if analytic_spheres and not textured else None
        if sphere is not None:
            center, radius = sphere
            shape = {"type": "sphere", "center": _point(center), "radius": float(radius)}
        else:
            shape = {
                "type": "ply",
                "filename": PlyMesh(obj.mesh),
                "to_world": _matrix(obj.world_from_object()),
                "face_normals": False,
            }
        shape["bsdf"] = bsdf
        emitter = emitter_of(obj.material, obj.mesh, scene.intensity_scale) if emitters != "environment" else None
        if emitter is not None:
            shape["emitter"] = emitter
        if medium is not None:
            shape["interior"] = medium
        result[f"object{i}"] = shape
    return result


def _leaves(node, convert):
    """``node`` (a description) with every leaf of ours replaced by ``convert(leaf)``."""
    if isinstance(node, dict):
        return {key: _leaves(value, convert) for key, value in node.items()}
    if isinstance(node, (Matrix, Bitmap, PlyMesh)):
        return convert(node)
    return node


def scene_to_mitsuba(scene, mesh_dir: str | Path | None = None, **options) -> dict:
    """The Mitsuba 3 scene dict of ``scene`` for ``mi.load_dict`` (see the module docstring for the mapping).

    ``options`` are :func:`scene_description`'s. Meshes are written to ``mesh_dir`` (default: a
    ``caustica-mitsuba-meshes`` folder in the temp directory); images stay in memory.
    """
    import mitsuba as mi

    description = scene_description(scene, **options)
    mesh_dir = Path(mesh_dir) if mesh_dir is not None else Path(tempfile.gettempdir()) / "caustica-mitsuba-meshes"

    def convert(leaf):
        if isinstance(leaf, Matrix):
            return mi.ScalarTransform4f(leaf.matrix.tolist())
        if isinstance(leaf, Bitmap):
            return mi.Bitmap(np.ascontiguousarray(leaf.image, dtype=np.float32))
        return str(write_mesh_ply(leaf.mesh, mesh_dir))

    return _leaves(description, convert)


# -- XML -------------------------------------------------------------------------------------------

# The XML tag of each plugin type the description uses.
_TAGS = {
    "path": "integrator", "volpath": "integrator", "ptracer": "integrator", "perspective": "sensor",
    "independent": "sampler", "hdrfilm": "film", "box": "rfilter", "envmap": "emitter", "point": "emitter",
    "directional": "emitter", "spot": "emitter", "ply": "shape", "sphere": "shape", "twosided": "bsdf",
    "diffuse": "bsdf", "conductor": "bsdf", "dielectric": "bsdf", "homogeneous": "medium", "bitmap": "texture",
    "principled": "bsdf", "normalmap": "bsdf", "area": "emitter",
}
_VECTORS = ("direction",)  # three numbers that are a direction (<vector>); the others are points
_FILES = re.compile(r"(mesh|environment|texture)-[0-9a-f]{16}\.(ply|exr)")
XML_VERSION = "3.0.0"


def _number(x) -> str:
    return repr(float(x))


def _xml_value(name: str, value, files, indent: str) -> list[str]:
    """The XML lines of one parameter ``name`` = ``value``."""
    attr = f"name={quoteattr(name)}"
    if isinstance(value, dict) and value.get("type") == "rgb":
        return [f'{indent}<rgb {attr} value="{", ".join(_number(x) for x in value["value"])}"/>']
    if isinstance(value, dict):
        return _xml_plugin(value, files, indent, attr)
    if isinstance(value, Matrix):
        numbers = " ".join(_number(x) for x in value.matrix.reshape(-1))
        return [f"{indent}<transform {attr}>", f'{indent}    <matrix value="{numbers}"/>', f"{indent}</transform>"]
    if isinstance(value, (Bitmap, PlyMesh)):
        return [f"{indent}<string name=\"filename\" value={quoteattr(files(value))}/>"]
    if isinstance(value, bool):
        return [f'{indent}<boolean {attr} value="{str(value).lower()}"/>']
    if isinstance(value, int):
        return [f'{indent}<integer {attr} value="{value}"/>']
    if isinstance(value, float):
        return [f'{indent}<float {attr} value="{_number(value)}"/>']
    if isinstance(value, str):
        return [f"{indent}<string {attr} value={quoteattr(value)}/>"]
    if isinstance(value, list) and len(value) == 3:
        tag = "vector" if name in _VECTORS else "point"
        return [f'{indent}<{tag} {attr} value="{", ".join(_number(x) for x in value)}"/>']
    raise ValueError(f"cannot write parameter {name} = {value!r} as Mitsuba XML")


def _xml_plugin(node: dict, files, indent: str, attr: str) -> list[str]:
    kind = node["type"]
    tag = _TAGS.get(kind)
    if tag is None:
        raise ValueError(f"no Mitsuba XML tag known for plugin type '{kind}'")
    opening = f"{indent}<{tag} type={quoteattr(kind)} {attr}"
    lines = [line for key, value in node.items() if key != "type"
             for line in _xml_value(key, value, files, indent + "    ")]
    return [opening + ">", *lines, f"{indent}</{tag}>"] if lines else [opening + "/>"]


def description_to_xml(description: dict, files, comment: str = "") -> str:
    """The Mitsuba 3 XML text of a :func:`scene_description`; ``files(leaf)`` writes a Bitmap or PlyMesh
    and returns the path the XML names (relative paths resolve against the XML's folder)."""
    lines = ['<?xml version="1.0" encoding="utf-8"?>']
    if comment:
        lines.append(f"<!-- {escape(comment).replace('--', '- -')} -->")
    lines.append(f'<scene version="{XML_VERSION}">')
    for key, value in description.items():
        if key != "type":
            lines += _xml_plugin(value, files, "    ", f"id={quoteattr(key)}")
    return "\n".join(lines + ["</scene>", ""])


def files_folder(path: Path) -> Path:
    """The folder of an XML export's meshes and images: ``out.xml`` -> ``out_files``."""
    return path.with_name(path.stem + "_files")


def write_mitsuba_xml(
    scene,
    path: str | Path,
    size: tuple[int, int] | None = None,
    spp: int = 256,
    integrator: str = "path",
    max_depth: int = 16,
    analytic_spheres: bool = True,
) -> Path:
    """Write ``scene`` as a Mitsuba 3 XML file at ``path`` (.xml), its meshes (PLY) and images (EXR) in
    ``<stem>_files/`` beside it; return ``path``. Atomic: on any error neither is left half-written (a
    ``<stem>_files`` folder from an earlier export is replaced; one holding other files is refused).

    The description is :func:`scene_description`'s, as ``compare`` renders it, with one integrator
    (``path`` by default, ``volpath`` when a glass absorbs) and each dispersive glass at its mean IOR;
    docs/reference.md says what the reference composites beyond that.
    """
    from ..atomic import check_writable, temp_path, write_atomic
    from ..images import write_image

    path = Path(path)
    if path.suffix.lower() != ".xml":
        raise OutputError(f"Mitsuba export '{path}' must end in .xml")
    check_writable(path)
    folder = files_folder(path)
    _check_folder(folder)
    description = scene_description(scene, size=size, spp=spp, integrator=integrator, max_depth=max_depth,
                                    analytic_spheres=analytic_spheres)
    staging, previous = temp_path(folder), temp_path(folder)
    written: dict[str, str] = {}

    def files(leaf) -> str:
        if isinstance(leaf, PlyMesh):
            name = mesh_file_name(leaf.mesh)
            if name not in written:
                (staging / name).write_bytes(ply_bytes(leaf.mesh))
        else:
            name = f"{leaf.stem}-{image_hash(leaf.image)}.exr"
            if name not in written:
                write_image(staging / name, leaf.image)
        written[name] = f"{folder.name}/{name}"
        return written[name]

    try:
        os.mkdir(staging)  # mode 0o777 less the umask, like any new folder
        text = description_to_xml(description, files, comment=_comment(scene, description))
        if os.path.lexists(folder):
            os.replace(folder, previous)
        os.replace(staging, folder)
        try:
            write_atomic(path, lambda tmp: Path(tmp).write_text(text, encoding="utf-8"))
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            if os.path.lexists(previous):
                os.replace(previous, folder)
            raise
    except OutputError:
        raise
    except OSError as exc:
        raise OutputError(f"cannot write the Mitsuba export {path}: {exc.strerror or exc}; "
                          "check permissions and free space") from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)
        shutil.rmtree(previous, ignore_errors=True)
    return path


def _check_folder(folder: Path) -> None:
    """An existing ``folder`` may be replaced only when it holds nothing but an earlier export's files."""
    if not os.path.lexists(folder):
        return
    try:
        ours = folder.is_dir() and not folder.is_symlink() and all(_FILES.fullmatch(p.name) for p in folder.iterdir())
    except OSError as exc:
        raise OutputError(f"cannot read '{folder}' ({exc.strerror}); move it or choose another output name") from None
    if not ours:
        raise OutputError(f"'{folder}' is in the way of the export's mesh and image folder and is not an earlier "
                          "export's; move it or choose another output name")


def _comment(scene, description: dict) -> str:
    return (f"caustica export of scene {scene.name!r}: integrator {description['integrator']['type']}, environment "
            f"{scene.environment.describe()} (its rotation and strength are baked into the EXR), intensity scale "
            f"{float(scene.intensity_scale):g}")


def fov_x_of(scene_dict: dict) -> float:
    """Horizontal field of view (degrees) a dict's sensor sees, whichever its ``fov_axis``."""
    sensor = scene_dict["sensor"]
    film = sensor["film"]
    aspect = film["width"] / film["height"]
    fov = math.radians(sensor["fov"])
    if sensor.get("fov_axis", "x") == "x":
        return sensor["fov"]
    return math.degrees(2.0 * math.atan(math.tan(fov / 2.0) * aspect))
