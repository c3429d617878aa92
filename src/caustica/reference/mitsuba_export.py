"""Export a caustica :class:`~caustica.scene.Scene` to a Mitsuba 3 scene dict with the same meaning.

:func:`scene_to_mitsuba` returns the dict ``mi.load_dict`` takes; it needs
Mitsuba imported with a variant set (transforms are ``mi.ScalarTransform4f``,
the environment an in-memory ``mi.Bitmap``); :func:`caustica.reference.render.mitsuba_module`
does both.

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
- Point light: ``point`` with ``intensity`` (radiant intensity, W/sr, as ours).
  Directional: ``directional`` with ``irradiance`` and ``direction`` (the
  travel direction, as ours). Line light: one ``point`` per point sample.
- Spot light: ``spot`` with ``cutoff_angle`` = our outer angle and
  ``beam_width`` = our inner angle. Approximation: Mitsuba's falloff is
  linear in the angle between the two cones, ours a smoothstep in the
  cosine; both are 1 inside the inner cone and 0 outside the outer one and
  agree at the midpoint, differing by at most about 0.1 between.
- Diffuse: ``twosided`` ``diffuse`` (our receivers are lit from either side).
  Mirror: ``twosided`` ``conductor`` with ``material = 'none'`` (Fresnel 1)
  times ``specular_reflectance`` = colour. Glass: ``dielectric`` with
  ``int_ior`` = ior, ``ext_ior`` = 1. Absorbing glass gets an interior
  ``homogeneous`` medium with ``sigma_t`` = the absorption coefficient and
  ``albedo`` 0 (pure Beer-Lambert absorption), which needs the ``volpath``
  integrator: :func:`scene_to_mitsuba` switches ``path`` to ``volpath`` then.
  ``ptracer`` ignores media, so light-traced caustics through absorbing
  glass are not attenuated (a stated limit of the reference).
- Dispersion (a glass with differing ``ior_rgb``): pass ``channel`` = 0, 1 or 2
  to export every glass with that channel's IOR; the reference renders the
  three and keeps one channel of each (:mod:`caustica.reference.render`).
- Meshes: object-space binary little-endian PLY with vertex normals, named by
  a hash of the vertices, normals and faces (so a mesh reused by several
  objects or renders is written once), and the object's ``world_from_object``
  as ``to_world``. A mesh that tessellates an exact sphere (``analytic_sphere``,
  uniform scale) is exported as Mitsuba's analytic ``sphere`` when
  ``analytic_spheres`` is true (the default), as the exact oracle traces it.
"""
from __future__ import annotations

import hashlib
import math
import tempfile
from pathlib import Path

import numpy as np

from ..cache import atomic_write_bytes
from ..raytrace.embree_scene import world_sphere
from ..scene.mesh import Mesh
from ..scene.transform import look_at_view_from_world, up_hint

INTEGRATORS = ("path", "volpath", "ptracer")


def _rgb(value, scale: float = 1.0) -> dict:
    return {"type": "rgb", "value": [float(x) * scale for x in np.asarray(value, dtype=np.float64).reshape(3)]}


def _matrix(m: np.ndarray):
    """A ``mi.ScalarTransform4f`` of the 4x4 matrix ``m``."""
    import mitsuba as mi

    return mi.ScalarTransform4f(np.asarray(m, dtype=np.float64).tolist())


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
    """Hash of what the PLY holds: vertices, normals and faces."""
    return mesh.geometry_hash()


def ply_bytes(mesh: Mesh) -> bytes:
    """Binary little-endian PLY of ``mesh`` with per-vertex normals."""
    n = len(mesh.vertices)
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment caustica reference export\n"
        f"element vertex {n}\nproperty float x\nproperty float y\nproperty float z\n"
        "property float nx\nproperty float ny\nproperty float nz\n"
        f"element face {len(mesh.faces)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode("ascii")
    vertex = np.concatenate([mesh.vertices, mesh.normals], axis=1).astype("<f4")
    face = np.zeros(len(mesh.faces), dtype=[("n", "u1"), ("idx", "<i4", (3,))])
    face["n"] = 3
    face["idx"] = mesh.faces
    return header + vertex.tobytes() + face.tobytes()


def write_mesh_ply(mesh: Mesh, mesh_dir: Path) -> Path:
    """Write ``mesh`` (object space) to ``mesh_dir/<hash>.ply`` unless it is there; return the path."""
    mesh_dir = Path(mesh_dir)
    mesh_dir.mkdir(parents=True, exist_ok=True)
    path = mesh_dir / f"mesh-{mesh_file_hash(mesh)}.ply"
    if not path.exists():
        atomic_write_bytes(path, ply_bytes(mesh))
    return path


def environment_hash(image: np.ndarray) -> str:
    h = hashlib.sha1(np.ascontiguousarray(image, dtype=np.float32).tobytes())
    h.update(str(image.shape).encode())
    return h.hexdigest()[:16]


def _environment_bitmap(image: np.ndarray) -> dict:
    """The environment as an in-memory ``mi.Bitmap`` (linear float32 RGB, no file)."""
    import mitsuba as mi

    return {"bitmap": mi.Bitmap(np.ascontiguousarray(image, dtype=np.float32))}


def _material(material, channel: int | None) -> tuple[dict, dict | None]:
    """(bsdf dict, interior medium dict or None) for one of our materials."""
    if material.kind == "diffuse":
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": _rgb(material.color)}}, None
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


def scene_to_mitsuba(
    scene,
    size: tuple[int, int] | None = None,
    spp: int = 64,
    integrator: str = "path",
    max_depth: int = 16,
    mesh_dir: str | Path | None = None,
    channel: int | None = None,
    analytic_spheres: bool = True,
    camera=None,
    emitters: str = "all",
) -> dict:
    """The Mitsuba 3 scene dict of ``scene`` (see the module docstring for the mapping).

    ``size`` (width, height) overrides the camera's; ``camera`` replaces the
    scene camera. ``integrator`` is 'path', 'volpath' or 'ptracer'; 'path'
    becomes 'volpath' when a glass absorbs. ``max_depth`` counts path vertices
    as Mitsuba does (-1: unbounded). ``channel`` picks the per-channel IOR of
    dispersive glass. ``emitters`` keeps 'all' emitters, only the
    'environment' or only the 'lights'. Meshes are written to ``mesh_dir`` (default: a
    ``caustica-mitsuba-meshes`` folder in the temp directory).
    """
    if integrator not in INTEGRATORS:
        raise ValueError(f"integrator '{integrator}' must be one of {', '.join(INTEGRATORS)}")
    mesh_dir = Path(mesh_dir) if mesh_dir is not None else Path(tempfile.gettempdir()) / "caustica-mitsuba-meshes"
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

    if emitters not in ("all", "environment", "lights"):
        raise ValueError(f"emitters '{emitters}' must be 'all', 'environment' or 'lights'")
    image = scene.environment.image
    if emitters != "lights" and np.any(image > 0):
        env = {"type": "envmap", "scale": float(scene.intensity_scale)}
        env.update(_environment_bitmap(image))
        result["environment"] = env
    if emitters != "environment":
        result.update(_lights(scene))

    for i, obj in enumerate(scene.objects):
        bsdf, medium = _material(obj.material, channel)
        sphere = world_sphere(obj.mesh, obj.world_from_object()) if analytic_spheres else None
        if sphere is not None:
            center, radius = sphere
            shape = {"type": "sphere", "center": _point(center), "radius": float(radius)}
        else:
            shape = {
                "type": "ply",
                "filename": str(write_mesh_ply(obj.mesh, mesh_dir)),
                "to_world": _matrix(obj.world_from_object()),
                "face_normals": False,
            }
        shape["bsdf"] = bsdf
        if medium is not None:
            shape["interior"] = medium
        result[f"object{i}"] = shape
    return result


def fov_x_of(scene_dict: dict) -> float:
    """Horizontal field of view (degrees) a dict's sensor sees, whichever its ``fov_axis``."""
    sensor = scene_dict["sensor"]
    film = sensor["film"]
    aspect = film["width"] / film["height"]
    fov = math.radians(sensor["fov"])
    if sensor.get("fov_axis", "x") == "x":
        return sensor["fov"]
    return math.degrees(2.0 * math.atan(math.tan(fov / 2.0) * aspect))
