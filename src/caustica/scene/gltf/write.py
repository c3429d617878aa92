"""A caustica Scene as glTF 2.0: the inverse of :mod:`.read`, so a round trip renders the same image.

One node per object (TRS from its Transform) with one mesh primitive (POSITION, NORMAL, TEXCOORD_0,
TANGENT where the mesh has its own, uint32 or uint16 indices), materials in glTF's metallic-roughness model
with KHR_materials_specular (a Diffuse has factor 0), _emissive_strength, _transmission, _ior, _volume and
_dispersion, KHR_lights_punctual lights in photometric units, the camera, and textures as embedded PNG
(colour ones sRGB-encoded, data ones linear). ``asset.extras.caustica.materials`` marks the material model
(files without it that caustica wrote are read as its earlier model). ``.glb``
holds one binary chunk; ``.gltf`` embeds the same buffer as a base64 data URI, so either is one
self-contained file. A scene read from glTF keeps what its file said (scene/gltf/origin.py): names,
doubleSided, the extensions caustica does not render, extensionsRequired. The environment goes into
``extras.caustica.environment``, which only caustica reads; that, and what glTF cannot say (line lights,
colours above 1), is said in one warning.
"""
from __future__ import annotations

import base64
import io
import json
import math
import struct
import warnings
from pathlib import Path

import numpy as np

from ...atomic import write_atomic
from ...errors import OutputError
from ..environment import PROCEDURAL_ENVIRONMENTS
from ..lights import DirectionalLight, LineLight, PointLight, SpotLight
from ..materials import Diffuse, Glass, Mirror, Principled
from ..transform import rotation_from_euler_degrees, up_hint
from .container import GLB_BIN, GLB_JSON, GLB_MAGIC
from .matrices import quaternion_from_matrix
from .origin import aspect_ratio, camera_extras, origin_of
from .read import DIELECTRIC_IOR, MATERIAL_MODEL
from .units import photometric

FLOAT, USHORT, UINT = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
PROCEDURAL = "procedural:"


def write_gltf(scene, path: str | Path) -> Path:
    """Write ``scene`` to ``path`` (``.glb`` or ``.gltf``) atomically; warns once about what glTF cannot hold."""
    path = Path(path)
    binary = path.suffix.lower() == ".glb"
    if path.suffix.lower() not in (".glb", ".gltf"):
        raise OutputError(f"glTF output '{path.name}' must end in .glb or .gltf")
    writer = _Writer(scene, path.parent)
    doc, blob = writer.document()
    if writer.notes:
        warnings.warn(f"{path.name}: {'; '.join(writer.notes)}", stacklevel=3)
    if binary:
        data = glb_bytes(doc, blob)
    else:
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode("ascii")
        data = json.dumps(doc, indent=1).encode("utf-8")
    return write_atomic(path, lambda tmp: Path(tmp).write_bytes(data))


def glb_bytes(doc: dict, blob: bytes) -> bytes:
    """A GLB container: header, JSON chunk (space padded), BIN chunk (zero padded)."""
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    blob = bytes(blob) + b"\0" * (-len(blob) % 4)
    total = 12 + 8 + len(text) + 8 + len(blob)
    return b"".join([GLB_MAGIC, struct.pack("<II", 2, total), struct.pack("<II", len(text), GLB_JSON), text,
                     struct.pack("<II", len(blob), GLB_BIN), blob])


def _clamped(color, what: str, notes: list[str]) -> list[float]:
    color = np.asarray(color, dtype=np.float64)
    if color.max() > 1.0:
        notes.append(f"{what} colour {np.round(color, 3).tolist()} clamped to 1 (glTF's limit)")
    return [float(c) for c in np.clip(color, 0.0, 1.0)]


def frame_quaternion(forward, up=None) -> list[float]:
    """The rotation (x, y, z, w) that turns -Z to ``forward`` and +Y towards ``up`` (a glTF camera or light)."""
    forward = np.asarray(forward, dtype=np.float64)
    forward = forward / np.linalg.norm(forward)
    up = up_hint(forward) if up is None else np.asarray(up, dtype=np.float64)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    return [float(q) for q in quaternion_from_matrix(np.stack([right, true_up, -forward], axis=1))]


class _Writer:
    def __init__(self, scene, folder: Path):
        self.scene, self.folder = scene, folder
        self.origin = origin_of(scene)
        self.blob = bytearray()
        asset = {"version": "2.0", "generator": _generator(), "extras": {"caustica": {"materials": MATERIAL_MODEL}}}
        self.doc: dict = {"asset": asset, "scene": 0,
                          "scenes": [{"name": scene.name, "nodes": []}], "nodes": [], "meshes": [],
                          "materials": [], "accessors": [], "bufferViews": [], "buffers": []}
        self.used: set[str] = set()
        self.notes: list[str] = []
        self.geometry: dict[int, dict] = {}
        self.meshes: dict[tuple[int, int], int] = {}
        self.materials: dict[int, int] = {}
        self.textures: dict[tuple[int, bool], int] = {}

    def document(self) -> tuple[dict, bytes]:
        scene, doc = self.scene, self.doc
        for first, group in self._node_groups():
            t = scene.objects[first].transform
            record = self.origin.of("objects", scene.objects[first])
            node = {"name": record.name if len(group) > 1 else scene.objects[first].name,
                    "mesh": self._mesh(group, first),
                    "translation": [float(x) for x in t.position],
                    "rotation": [float(q) for q in quaternion_from_matrix(rotation_from_euler_degrees(t.rotation))],
                    "scale": [float(s) for s in t.scale]}
            self._add_node(node)
        self._camera()
        for i, light in enumerate(scene.lights):
            self._light(light, i)
        self._environment()
        doc["buffers"].append({"byteLength": len(self.blob)})
        if self.used:
            doc["extensionsUsed"] = sorted(self.used)
        required = [e for e in self.origin.extensions_required if e in self.used]
        if required:
            doc["extensionsRequired"] = required
        for key in ("materials", "meshes", "accessors", "bufferViews"):
            if not doc[key]:
                del doc[key]
        return doc, bytes(self.blob)

    def _environment(self) -> None:
        """The environment as a TOML [environment] table in ``extras.caustica.environment`` (intensity_scale
        baked into its strength, as the lights carry it), said in the warning; nothing for the default one."""
        env, scale = self.scene.environment, float(self.scene.intensity_scale)
        table = environment_table(env, scale, self.folder)
        if table is None:
            self.notes.insert(0, f"the environment ({env.describe()}) is not kept: it has no file or procedural "
                              "source glTF can name; give it again with --environment or a TOML [environment]")
        elif table:
            self.doc.setdefault("extras", {}).setdefault("caustica", {})["environment"] = table
            self.notes.insert(0, f"the environment ({env.describe()}{f', times {scale:g}' if scale != 1 else ''}) "
                              "is kept in extras.caustica, which caustica reads back and other glTF readers ignore")

    def _add_node(self, node: dict) -> None:
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]))
        self.doc["nodes"].append(node)

    # Buffers ----------------------------------------------------------------------

    def _view(self, data: bytes, target: int | None = None) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        view = {"buffer": 0, "byteOffset": len(self.blob), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        self.blob += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, array: np.ndarray, kind: str, component: int, target: int, bounds: bool = False) -> int:
        dtype = {FLOAT: "<f4", USHORT: "<u2", UINT: "<u4"}[component]
        data = np.ascontiguousarray(array, dtype=dtype)
        accessor = {"bufferView": self._view(data.tobytes(), target), "componentType": component,
                    "count": int(len(data)), "type": kind}
        if bounds:
            accessor["min"] = [float(x) for x in data.min(axis=0)]
            accessor["max"] = [float(x) for x in data.max(axis=0)]
        self.doc["accessors"].append(accessor)
        return len(self.doc["accessors"]) - 1

    # Meshes and materials ---------------------------------------------------------

    def _node_groups(self) -> list[tuple[int, list]]:
        """(index of the first, objects) of each node to write: one object, or the consecutive objects that
        one glTF node's primitives became (the same NodeOrigin, transform and mesh name)."""
        groups: list[tuple[int, list]] = []
        previous = None
        for i, obj in enumerate(self.scene.objects):
            record = self.origin.of("objects", obj)
            if record is not None and record is previous and _same_place(groups[-1][1][0], obj):
                groups[-1][1].append(obj)
            else:
                groups.append((i, [obj]))
            previous = record
        return groups

    def _mesh(self, group: list, first: int) -> int:
        """The glTF mesh of a node's objects (one primitive each), shared by nodes drawing the same ones."""
        key = tuple((id(o.mesh), id(o.material)) for o in group)
        if key not in self.meshes:
            primitives = [self._primitive(obj, f"objects[{first + k}]") for k, obj in enumerate(group)]
            self.doc["meshes"].append({"name": group[0].mesh.name, "primitives": primitives})
            self.meshes[key] = len(self.doc["meshes"]) - 1
        return self.meshes[key]

    def _primitive(self, obj, where: str) -> dict:
        """The object's primitive: its mesh's accessors (written once per mesh) and its material."""
        mesh, material = obj.mesh, obj.material
        if id(mesh) not in self.geometry:
            attributes = {"POSITION": self._accessor(mesh.vertices, "VEC3", FLOAT, ARRAY_BUFFER, bounds=True),
                          "NORMAL": self._accessor(mesh.normals, "VEC3", FLOAT, ARRAY_BUFFER)}
            if mesh.uvs is not None:
                attributes["TEXCOORD_0"] = self._accessor(mesh.uvs, "VEC2", FLOAT, ARRAY_BUFFER)
            if mesh.tangents is not None:
                attributes["TANGENT"] = self._accessor(mesh.tangents, "VEC4", FLOAT, ARRAY_BUFFER)
            small = len(mesh.vertices) < 65536
            indices = self._accessor(mesh.faces.reshape(-1), "SCALAR", USHORT if small else UINT,
                                     ELEMENT_ARRAY_BUFFER)
            primitive = {"attributes": attributes, "indices": indices, "mode": 4}
            if mesh.analytic_sphere is not None:
                center, radius = mesh.analytic_sphere
                sphere = [float(c) for c in center] + [float(radius)]
                primitive["extras"] = {"caustica": {"analytic_sphere": sphere}}
            self.geometry[id(mesh)] = primitive
        return dict(self.geometry[id(mesh)], material=self._material(material, obj, where))

    def _material(self, material, obj, where: str) -> int:
        if id(material) in self.materials:
            return self.materials[id(material)]
        origin = self.origin.of("materials", material)
        entry: dict = {"name": origin.name if origin and origin.name is not None else f"{obj.name}-{material.kind}"}
        if origin and origin.double_sided:
            entry["doubleSided"] = True
        if isinstance(material, Glass):
            entry["pbrMetallicRoughness"] = {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
                                             "roughnessFactor": 0.0}
            entry["extensions"] = self._glass(material, obj, where, thin_walled=bool(origin and origin.thin_walled))
        elif isinstance(material, Mirror):
            entry["pbrMetallicRoughness"] = {"baseColorFactor": _clamped(material.color, where, self.notes) + [1.0],
                                             "metallicFactor": 1.0, "roughnessFactor": 0.0}
        elif isinstance(material, Diffuse):  # no specular layer: KHR_materials_specular's factor 0 says so
            pbr = {"baseColorFactor": _clamped(material.color, where, self.notes) + [1.0], "metallicFactor": 0.0,
                   "roughnessFactor": 1.0}
            if material.texture is not None:
                pbr["baseColorTexture"] = {"index": self._texture(material.texture)}
            entry["pbrMetallicRoughness"] = pbr
            entry["extensions"] = {"KHR_materials_specular": {"specularFactor": 0.0}}
            self.used.add("KHR_materials_specular")
        else:
            self._principled(entry, material, obj, where, thin_walled=bool(origin and origin.thin_walled))
        if origin:
            self._carry(entry, origin.extensions, where)
        self.doc["materials"].append(entry)
        self.materials[id(material)] = len(self.doc["materials"]) - 1
        return self.materials[id(material)]

    def _carry(self, entry: dict, extensions: dict, where: str) -> None:
        """Add a glTF material's extensions that caustica does not write itself, unchanged but for their
        texture references (indices into the source file's textures), which are left out and said."""
        for name, data in extensions.items():
            if not isinstance(data, dict) or name in entry.get("extensions", {}):
                continue
            textures = [key for key, value in data.items() if isinstance(value, dict) and "index" in value]
            if textures:
                self.notes.append(f"{where}: {name}'s {', '.join(textures)} not kept (caustica does not carry "
                                  "textures it does not render)")
            entry.setdefault("extensions", {})[name] = {k: v for k, v in data.items() if k not in textures}
            self.used.add(name)

    def _glass(self, glass: Glass, obj, where: str, thin_walled: bool = False) -> dict:
        return self._transmission(glass.as_principled(), obj, where, thin_walled)

    def _transmission(self, m: Principled, obj, where: str, thin_walled: bool) -> dict:
        """KHR_materials_transmission, _ior, _volume (its thickness, else the object's smallest extent, unless
        the file's material was thin-walled and still is) and _dispersion of a transmissive surface."""
        ior, dispersion, thickness = m.ior, m.dispersion, m.thickness
        attenuation_color = m.attenuation_color if np.any(m.attenuation_color < 1.0) else None
        attenuation_distance = m.attenuation_distance
        extensions = {"KHR_materials_transmission": {"transmissionFactor": float(m.transmission)},
                      "KHR_materials_ior": {"ior": float(ior)}}
        absorbs = attenuation_color is not None or attenuation_distance is not None
        if not thin_walled or absorbs or thickness is not None:  # a file's thin-walled glass stays so
            lo, hi = obj.mesh.bounds.astype(np.float64)
            volume = {"thicknessFactor": float(thickness if thickness is not None else (hi - lo).min())}
            if attenuation_color is not None:
                volume["attenuationColor"] = [float(c) for c in attenuation_color]
            if attenuation_distance is not None:
                volume["attenuationDistance"] = float(attenuation_distance)
            extensions["KHR_materials_volume"] = volume
        if ior < 1.0:
            self.notes.append(f"{where}: ior {ior:g} is below KHR_materials_ior's minimum of 1 (caustica reads "
                              "it back; other viewers may not)")
        if dispersion > 0:
            extensions["KHR_materials_dispersion"] = {"dispersion": float(dispersion)}
        self.used.update(extensions)
        return extensions

    def _principled(self, entry: dict, material: Principled, obj, where: str, thin_walled: bool) -> None:
        """Every field of a Principled: the metallic-roughness factors and textures (colour ones as sRGB PNG,
        data ones as linear PNG), normal and occlusion maps, emission (above 1 by
        KHR_materials_emissive_strength), KHR_materials_specular where it differs from glTF's default, and
        transmission, ior, volume and dispersion."""
        m = material
        pbr = {"baseColorFactor": [float(c) for c in m.base_color] + [1.0], "metallicFactor": float(m.metallic),
               "roughnessFactor": float(m.roughness)}
        if m.base_color_texture is not None:
            pbr["baseColorTexture"] = {"index": self._texture(m.base_color_texture)}
        if m.metallic_roughness_texture is not None:
            pbr["metallicRoughnessTexture"] = {"index": self._texture(m.metallic_roughness_texture, srgb=False)}
        entry["pbrMetallicRoughness"] = pbr
        for key, texture, scalar, value in (("normalTexture", m.normal_texture, "scale", m.normal_scale),
                                            ("occlusionTexture", m.occlusion_texture, "strength",
                                             m.occlusion_strength)):
            if texture is not None:
                entry[key] = {"index": self._texture(texture, srgb=False)}
                if value != 1.0:
                    entry[key][scalar] = float(value)
        extensions: dict = {}
        brightest = float(m.emission.max())
        if brightest > 0:
            entry["emissiveFactor"] = [float(c) for c in (m.emission / brightest if brightest > 1 else m.emission)]
            if brightest > 1:
                extensions["KHR_materials_emissive_strength"] = {"emissiveStrength": brightest}
        if m.emission_texture is not None:
            entry["emissiveTexture"] = {"index": self._texture(m.emission_texture)}
        specular = {}
        if m.specular != 1.0:
            specular["specularFactor"] = float(m.specular)
        if np.any(m.specular_color != 1.0):
            specular["specularColorFactor"] = [float(c) for c in m.specular_color]
        if specular:
            extensions["KHR_materials_specular"] = specular
        if m.transmission > 0:
            extensions.update(self._transmission(m, obj, where, thin_walled))
        elif m.ior != DIELECTRIC_IOR:
            extensions["KHR_materials_ior"] = {"ior": float(m.ior)}
        self.used.update(extensions)
        if extensions:
            entry["extensions"] = extensions

    def _texture(self, texture: np.ndarray, srgb: bool = True) -> int:
        """The glTF texture of ``texture``: an embedded 8-bit PNG, sRGB-encoded (colour: base colour,
        emission) or its linear values (``srgb`` False: data such as normal or roughness maps)."""
        key = (id(texture), srgb)
        if key not in self.textures:
            from PIL import Image

            from ...images import linear_to_srgb

            encoded = linear_to_srgb(texture) if srgb else texture
            codes = np.rint(np.clip(encoded, 0.0, 1.0) * 255.0).astype(np.uint8)
            encoded = io.BytesIO()
            Image.fromarray(codes, "RGB").save(encoded, format="PNG")
            doc = self.doc
            doc.setdefault("images", []).append({"bufferView": self._view(encoded.getvalue()), "mimeType": "image/png"})
            doc.setdefault("samplers", [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}])
            doc.setdefault("textures", []).append({"source": len(doc["images"]) - 1, "sampler": 0})
            self.textures[key] = len(doc["textures"]) - 1
        return self.textures[key]

    # Camera and lights ------------------------------------------------------------

    def _camera(self) -> None:
        camera = self.scene.camera
        origin = self.origin.camera(camera)
        forward = camera.look_at - camera.position
        entry = {"name": origin.name if origin and origin.name else "camera", "type": "perspective",
                 "perspective": {"yfov": math.radians(camera.fov_y), "aspectRatio": aspect_ratio(origin, camera.size),
                                 "znear": float(camera.near), "zfar": float(camera.far)}}
        extras = camera_extras(origin, camera.size, float(np.linalg.norm(forward)))
        if extras:
            entry["extras"] = {"caustica": extras}
        self.doc["cameras"] = [entry]
        self._add_node({"name": origin.node_name if origin and origin.node_name else entry["name"], "camera": 0,
                        "translation": [float(x) for x in camera.position],
                        "rotation": frame_quaternion(forward, camera.up)})

    def _light(self, light, index: int) -> None:
        scale = float(self.scene.intensity_scale)
        if isinstance(light, LineLight):
            self.notes.append(f"lights[{index}] (a line light) is written as its {light.samples} point lights")
            for k, (position, intensity) in enumerate(light.point_samples()):
                self._punctual({"type": "point"}, intensity * scale, f"lights[{index}].{k}",
                               {"translation": [float(x) for x in position]})
            return
        entry, node = {"type": light.kind}, {}
        if isinstance(light, (PointLight, SpotLight)):
            node["translation"] = [float(x) for x in light.position]
        if isinstance(light, (SpotLight, DirectionalLight)):
            node["rotation"] = frame_quaternion(light.direction)
        if isinstance(light, SpotLight):
            entry["spot"] = {"innerConeAngle": math.radians(light.inner_angle),
                             "outerConeAngle": math.radians(light.outer_angle)}
        origin = self.origin.of("lights", light)
        name = origin.name if origin and origin.name is not None else f"lights[{index}]"
        node_name = origin.node_name if origin and origin.node_name is not None else name
        self._punctual(entry, light.intensity * scale, name, node, node_name)

    def _punctual(self, entry: dict, intensity, name: str, node: dict, node_name: str | None = None) -> None:
        color, value = photometric(intensity)
        lights = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})["lights"]
        lights.append(dict(entry, name=name, color=color, intensity=value))
        self.used.add("KHR_lights_punctual")
        self._add_node(dict(node, name=node_name or name,
                            extensions={"KHR_lights_punctual": {"light": len(lights) - 1}}))


def _generator() -> str:
    from ... import __version__

    return f"caustica {__version__}"


def environment_table(env, scale: float, folder: Path) -> dict | None:
    """``env`` (radiance times ``scale``) as a TOML [environment] table for ``extras.caustica``: {} for
    caustica's default environment, None for one without a procedural or file source (an image made in
    Python) or a file outside ``folder`` (the reader takes only files beside the glTF)."""
    strength = float(env.strength) * scale
    if env.source.startswith(PROCEDURAL):
        name, _, factor = env.source[len(PROCEDURAL):].partition("*")  # presets dim the sky: 'sky-checker*0.2'
        try:
            strength *= float(factor) if factor else 1.0
        except ValueError:
            return None
        if name not in PROCEDURAL_ENVIRONMENTS:
            return None
        table = {"procedural": name}
    else:
        try:
            table = {"file": Path(env.source).resolve().relative_to(folder.resolve()).as_posix()}
        except (ValueError, OSError, RuntimeError):
            return None
    if env.rotation:
        table["rotation"] = float(env.rotation)
    if strength != 1.0:
        table["strength"] = strength
    if env.filter != "footprint":
        table["filter"] = env.filter
    return {} if table == {"procedural": "sky-checker"} else table


def _same_place(a, b) -> bool:
    """Whether objects ``a`` and ``b`` have one transform and one mesh name (parts of one glTF node)."""
    ta, tb = a.transform, b.transform
    return a.mesh.name == b.mesh.name and all(np.array_equal(getattr(ta, k), getattr(tb, k))
                                              for k in ("position", "rotation", "scale"))
