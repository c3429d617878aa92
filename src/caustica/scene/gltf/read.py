"""glTF 2.0 document to caustica objects, lights and cameras (the mapping is in docs/gltf.md).

One :class:`SceneObject` per triangle primitive (TANGENT kept as ``Mesh.tangents``), placed by the node
hierarchy; materials become :class:`Principled` (glTF 2.0's metallic-roughness with its textures,
KHR_materials_specular, _emissive_strength, _transmission, _ior, _volume and _dispersion), or the Diffuse,
Mirror or Glass a material is exactly; KHR_lights_punctual lights and perspective cameras keep their node's
place. What caustica does not render is collected and reported once, as one warning naming the nodes.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import MeshError, SceneError, closest_name, first_line, short
from .. import budget, rules
from ..camera import Camera
from ..lights import DirectionalLight, PointLight, SpotLight
from ..materials import Diffuse, Principled
from ..mesh import Mesh
from ..scene import SceneObject
from ..transform import Transform
from .container import GltfFile, open_gltf
from .matrices import transform_of, trs_matrix
from .origin import CameraOrigin, GltfOrigin, LightOrigin, MaterialOrigin, NodeOrigin
from .units import radiometric

GLASS_EXTENSIONS = ("KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                    "KHR_materials_dispersion")  # what caustica's Glass models (export writes them from it)
MATERIAL_EXTENSIONS = GLASS_EXTENSIONS + ("KHR_materials_specular", "KHR_materials_emissive_strength")  # Principled's
SUPPORTED_EXTENSIONS = MATERIAL_EXTENSIONS + ("KHR_lights_punctual", "KHR_mesh_quantization")
GLASS_ROUGHNESS = 0.05  # rougher glass is rendered smooth, with a warning
DIELECTRIC_IOR = 1.5  # the IOR whose F0 (0.04) glTF's dielectric base has without KHR_materials_ior
DEFAULT_HEIGHT = 512  # pixels of an imported camera's image height (width from its aspect ratio)
MIN_SPOT_INNER = 0.01  # degrees: caustica's spot needs a positive inner cone; glTF's default is 0
MAX_SPOT_OUTER = 89.9  # degrees: caustica's outer cone stays below 90
FLOAT, BYTE, UBYTE, SHORT, USHORT, UINT = 5126, 5120, 5121, 5122, 5123, 5125
TRIANGLES = 4
DEGENERATE_DETERMINANT = 1e-24  # a node world matrix scaling volumes by less draws nothing (scale 0 hides a node)
TRANSFORM_KEYS = ("matrix", "translation", "rotation", "scale")
_MODES = {0: "points", 1: "lines", 2: "line loops", 3: "line strips", 5: "triangle strips", 6: "triangle fans"}
_NAMES_SHOWN = 3


@dataclass
class GltfCamera:
    """A perspective camera of the file: its names, node world matrix and glTF fields."""

    name: str
    node_name: str
    world: np.ndarray
    fields: dict
    extras: dict


@dataclass
class GltfScene:
    """What a glTF file holds, in caustica's terms (the camera is made once the scene bounds are known);
    ``origin``: what export writes back; ``environment``: caustica's ``extras.caustica.environment`` (a
    TOML [environment] table), or None."""

    name: str
    objects: list[SceneObject] = field(default_factory=list)
    lights: list = field(default_factory=list)
    cameras: list[GltfCamera] = field(default_factory=list)
    source: str = ""
    origin: GltfOrigin = field(default_factory=GltfOrigin)
    environment: dict | None = None


def read_gltf(path: str | Path, placement: np.ndarray | None = None) -> GltfScene:
    """Objects, lights and cameras of a ``.glb``/``.gltf`` file; ``placement`` (4x4) moves the whole
    file (a TOML entry's position, rotation and scale). Warns once about what is not supported."""
    path = Path(path)
    reader = _Reader(open_gltf(path))
    result = reader.read(np.eye(4) if placement is None else np.asarray(placement, dtype=np.float64))
    reader.warn_unsupported()
    return result


class _Reader:
    def __init__(self, file: GltfFile):
        self.file = file
        self.legacy = _legacy_caustica(file.doc)
        self.unsupported: dict[str, list[str]] = {}
        self.meshes: dict[tuple[int, int], Mesh] = {}
        self.materials: dict[int, tuple[object, list[str]]] = {}
        self.textures: dict[int, np.ndarray | None] = {}
        self.names: set[str] = set()

    def note(self, feature: str, node: str) -> None:
        names = self.unsupported.setdefault(feature, [])
        if node not in names:
            names.append(node)

    def warn_unsupported(self) -> None:
        if not self.unsupported:
            return
        parts = []
        for feature, names in self.unsupported.items():
            shown = ", ".join(repr(n) for n in names[:_NAMES_SHOWN])
            more = f" and {len(names) - _NAMES_SHOWN} more" if len(names) > _NAMES_SHOWN else ""
            parts.append(f"{feature} ({shown}{more})")
        warnings.warn(f"{self.file.path.name}: not supported, ignored: {'; '.join(parts)} (see docs/gltf.md)",
                      stacklevel=4)

    # Document ---------------------------------------------------------------------

    def read(self, placement: np.ndarray) -> GltfScene:
        f = self.file
        required = f.doc.get("extensionsRequired", [])
        missing = [e for e in required if e not in SUPPORTED_EXTENSIONS] if isinstance(required, list) else []
        if missing:
            raise f.error(f"requires {', '.join(map(str, missing))}, which caustica does not read; re-export it "
                          "without them (e.g. without Draco or meshopt compression)")
        for name in f.table(f.doc, "extensions", "the document"):
            if name not in SUPPORTED_EXTENSIONS:
                self.note(name, "the document")
        budget.check_nodes(len(f.items("nodes")), f"{f.path.name} has")
        scene_name, roots = self._roots()
        result = GltfScene(name=scene_name, source=str(f.path), environment=self._environment())
        result.origin.extensions_required = [e for e in required if isinstance(e, str)] \
            if isinstance(required, list) else []
        self._lights_table = f.table(f.table(f.doc, "extensions", "the document"), "KHR_lights_punctual",
                                     "extensions").get("lights", [])
        placed = self._hierarchy(roots, placement, result)
        self.budget = self._check_budget(placed)
        for index, node, label, world in placed:
            named = isinstance(node.get("name"), str) and node["name"].strip()
            self._mesh_objects(node["mesh"], f"nodes[{index}].mesh", label, None if named else f"node{index}",
                               world, result)
        return result

    def _hierarchy(self, roots: list, placement: np.ndarray, result: GltfScene) -> list[tuple]:
        """Walk the node tree once (iteratively, each node once): lights and cameras go into ``result``;
        returns (index, node, label, world) of the nodes with a mesh, in document order of the walk."""
        f = self.file
        nodes = f.items("nodes")
        stack = [(index, placement) for index in reversed(roots)]
        seen: set[int] = set()
        placed = []
        while stack:
            index, parent = stack.pop()
            node = f.item("nodes", index, "a node reference")
            if index in seen:
                raise f.error(f"nodes[{index}] is reached twice in the hierarchy (a cycle, or a node with two "
                              "parents); re-export the file")
            seen.add(index)
            world = self._world(parent, node, f"nodes[{index}]")
            label = f.name(node, f"nodes[{index}]")
            self._node(node, index, label, world, result)
            if "mesh" in node:
                placed.append((index, node, label, world))
            children = node.get("children", [])
            if not isinstance(children, list):
                raise f.error(f"nodes[{index}].children must be an array of node indices; re-export the file")
            for child in reversed(children):
                if not _index_in(child, nodes):
                    f.item("nodes", child, f"nodes[{index}].children")  # raises, naming the reference
                stack.append((child, world))
        return placed

    def _check_budget(self, placed: list[tuple]) -> budget.SceneBudget:
        """Refuse, before any mesh is built, a file whose mesh nodes would make more objects than
        scene/budget.py allows; the budget returned then counts triangles and bytes as meshes are built."""
        meshes = self.file.items("meshes")
        objects = 0
        for _, node, _, _ in placed:
            mesh = node["mesh"]
            primitives = meshes[mesh].get("primitives") if _index_in(mesh, meshes) else None
            objects += sum(isinstance(p, dict) and p.get("mode", TRIANGLES) == TRIANGLES
                           for p in (primitives if isinstance(primitives, list) else []))
        scene_budget = budget.SceneBudget(self.file.path.name)
        scene_budget.objects(objects)
        return scene_budget

    def _environment(self) -> dict | None:
        """The document's ``extras.caustica.environment`` table (caustica's export writes it), or None."""
        table = _caustica_extras(self.file.doc).get("environment")
        if table is not None and not isinstance(table, dict):
            raise self.file.error(f"extras.caustica.environment {short(table)} must be a JSON object; re-export "
                                  "the file")
        return table

    def _roots(self) -> tuple[str, list[int]]:
        """The scene's name and root nodes: ``scene`` (default 0) of ``scenes``, or every parentless node."""
        f = self.file
        scenes = f.items("scenes")
        if scenes:
            index = f.doc.get("scene", 0)
            scene = f.item("scenes", index, "scene")
            roots = scene.get("nodes", [])
            if not isinstance(roots, list):
                raise f.error(f"scenes[{index}].nodes must be an array of node indices; re-export the file")
            return f.name(scene, f.path.stem), roots
        children = {c for node in f.items("nodes") if isinstance(node.get("children"), list)
                    for c in node["children"] if isinstance(c, int)}
        return f.path.stem, [i for i in range(len(f.items("nodes"))) if i not in children]

    def _world(self, parent: np.ndarray, node: dict, where: str) -> np.ndarray:
        """The node's world matrix: ``parent`` itself for a node without a transform (most of a big file)."""
        if not any(key in node for key in TRANSFORM_KEYS):
            return parent
        return parent @ self._local_matrix(node, where)

    def _local_matrix(self, node: dict, where: str) -> np.ndarray:
        f = self.file
        if "matrix" in node:
            return f.numbers(node, "matrix", 16, None, where).reshape(4, 4).T  # column-major
        translation = f.numbers(node, "translation", 3, [0.0, 0.0, 0.0], where)
        if "rotation" not in node and "scale" not in node:  # the common case of a big file: a shift
            local = np.eye(4)
            local[:3, 3] = translation
            return local
        rotation = f.numbers(node, "rotation", 4, [0.0, 0.0, 0.0, 1.0], where)
        if math.hypot(*rotation) < 1e-12:
            raise f.error(f"{where}.rotation {short(rotation)} is not a unit quaternion; re-export the file")
        return trs_matrix(translation, rotation, f.numbers(node, "scale", 3, [1.0, 1.0, 1.0], where))

    def _node(self, node: dict, index: int, label: str, world: np.ndarray, result: GltfScene) -> None:
        f = self.file
        where = f"nodes[{index}]"
        if "skin" in node:
            self.note("skins", label)
        if "weights" in node:
            self.note("morph targets", label)
        extensions = f.table(node, "extensions", where)
        for name in extensions:
            if name != "KHR_lights_punctual":
                self.note(name, label)
        if "KHR_lights_punctual" in extensions:
            light = f.table(extensions, "KHR_lights_punctual", f"{where}.extensions").get("light")
            made = self._light(light, f"{where}.extensions.KHR_lights_punctual.light", label, world)
            result.lights.append(made)
            result.origin.add("lights", made, LightOrigin(_name_or_none(self._lights_table[light]),
                                                          _name_or_none(node)))
        if "camera" in node:
            camera = f.item("cameras", node["camera"], f"{where}.camera")
            if camera.get("type") == "perspective":
                fields = f.table(camera, "perspective", f"cameras[{node['camera']}]")
                extras = _caustica_extras(camera)
                result.cameras.append(GltfCamera(f.name(camera, label), label, world, fields, extras))
            else:
                self.note(f"{camera.get('type')} cameras" if isinstance(camera.get("type"), str) else
                          "cameras without a type", label)

    # Meshes -----------------------------------------------------------------------

    def _mesh_objects(self, mesh_index, where: str, label: str, unnamed: str | None, world: np.ndarray,
                      result: GltfScene) -> None:
        """One object per triangle primitive, named after the node (``unnamed``: the node has no name; the
        mesh's name, else ``unnamed``, is used), ``.k`` appended when the mesh has several."""
        f = self.file
        mesh = f.item("meshes", mesh_index, where)
        primitives = mesh.get("primitives")
        if not isinstance(primitives, list) or not primitives or not all(isinstance(p, dict) for p in primitives):
            raise f.error(f"meshes[{mesh_index}].primitives must be a non-empty array of objects; re-export the file")
        if "weights" in mesh:
            self.note("morph targets", label)
        if abs(np.linalg.det(world[:3, :3])) < DEGENERATE_DETERMINANT:
            self.note("zero-scale nodes (not drawn)", label)
            return
        triangles = [k for k, p in enumerate(primitives) if p.get("mode", TRIANGLES) == TRIANGLES]
        base = label if unnamed is None else f.name(mesh, unnamed)
        node = NodeOrigin(base) if len(triangles) > 1 else None
        for k, primitive in enumerate(primitives):
            mode = primitive.get("mode", TRIANGLES)
            if mode != TRIANGLES:
                kind = _MODES.get(mode) if isinstance(mode, int) else None
                self.note(f"{kind or f'mode {short(mode)}'} primitives", label)
                continue
            if "targets" in primitive:
                self.note("morph targets", label)
            for name in f.table(primitive, "extensions", f"meshes[{mesh_index}].primitives[{k}]"):
                self.note(name, label)
            geometry = self._primitive(mesh_index, k, primitive, f.name(mesh, f"mesh{mesh_index}"))
            self.budget.mesh(geometry, f"{where}.primitives[{k}]")
            material = self._material_for(primitive, label, geometry, result.origin)
            name = self._unique(f"{base}.{k}" if node is not None else base)
            transform = transform_of(world)
            if transform is None:  # shear or mirroring: baked into the vertices
                geometry, transform = geometry.transformed(world), Transform()
            result.objects.append(SceneObject(name, geometry, material, transform))
            if node is not None:
                result.origin.add("objects", result.objects[-1], node)

    def _unique(self, name: str) -> str:
        candidate, n = name, 2
        while candidate in self.names:
            candidate, n = f"{name}-{n}", n + 1
        self.names.add(candidate)
        return candidate

    def _primitive(self, mesh_index: int, k: int, primitive: dict, mesh_name: str) -> Mesh:
        key = (mesh_index, k)
        if key in self.meshes:
            return self.meshes[key]
        f = self.file
        where = f"meshes[{mesh_index}].primitives[{k}]"
        attributes = f.table(primitive, "attributes", where)
        if "POSITION" not in attributes:
            raise f.error(f"{where} has no POSITION attribute; re-export the mesh", MeshError)
        quantized = (BYTE, UBYTE, SHORT, USHORT, FLOAT)  # KHR_mesh_quantization widens the float-only fields
        vertices = f.accessor(attributes["POSITION"], f"{where}.POSITION", ("VEC3",), quantized)
        normals = None
        if "NORMAL" in attributes:
            normals = f.accessor(attributes["NORMAL"], f"{where}.NORMAL", ("VEC3",), (BYTE, SHORT, FLOAT))
            if len(normals) != len(vertices):
                raise f.error(f"{where}: NORMAL has {len(normals):,} entries for {len(vertices):,} positions; "
                              "re-export the mesh", MeshError)
            normals = _unit_or_none(normals)
        uvs = None
        if "TEXCOORD_0" in attributes:
            uvs = f.accessor(attributes["TEXCOORD_0"], f"{where}.TEXCOORD_0", ("VEC2",), (UBYTE, USHORT, FLOAT) +
                             (BYTE, SHORT))
            if len(uvs) != len(vertices):
                raise f.error(f"{where}: TEXCOORD_0 has {len(uvs):,} entries for {len(vertices):,} positions; "
                              "re-export the mesh", MeshError)
        tangents = None
        if "TANGENT" in attributes and normals is not None:  # the spec ignores tangents without normals
            tangents = f.accessor(attributes["TANGENT"], f"{where}.TANGENT", ("VEC4",), (BYTE, SHORT, FLOAT))
            if len(tangents) != len(vertices):
                raise f.error(f"{where}: TANGENT has {len(tangents):,} entries for {len(vertices):,} positions; "
                              "re-export the mesh", MeshError)
            tangents = _unit_tangents_or_none(tangents)
        if "indices" in primitive:
            indices = f.accessor(primitive["indices"], f"{where}.indices", ("SCALAR",), (UBYTE, USHORT, UINT))
            indices = indices.reshape(-1)
        else:
            indices = np.arange(len(vertices), dtype=np.uint32)
        if len(indices) % 3 or not len(indices):
            raise f.error(f"{where} has {len(indices):,} triangle indices, not a multiple of 3; re-export the mesh",
                          MeshError)
        if int(indices.max()) >= len(vertices):
            raise f.error(f"{where}: indices out of range (up to {int(indices.max()):,} for {len(vertices):,} "
                          "vertices); repair or re-export the mesh", MeshError)
        rules.triangles(len(indices) // 3, f"{f.path.name}: {where} has", "use a coarser (decimated) mesh",
                        error=MeshError)
        faces = indices.astype(np.int32).reshape(-1, 3)
        try:
            mesh = Mesh(vertices, normals, faces, name=mesh_name, uvs=uvs, tangents=tangents)
        except MeshError as exc:
            raise f.error(f"{where}: {first_line(exc)}", MeshError) from None
        mesh.analytic_sphere = self._analytic_sphere(primitive, mesh)
        self.meshes[key] = mesh
        return mesh

    def _analytic_sphere(self, primitive: dict, mesh: Mesh):
        """caustica's own hint (``extras.caustica.analytic_sphere`` = [cx, cy, cz, r]) that a primitive
        tessellates a sphere, kept only when every vertex lies on that sphere."""
        sphere = _caustica_extras(primitive).get("analytic_sphere")
        if not (isinstance(sphere, list) and len(sphere) == 4 and all(rules.finite(v) for v in sphere)):
            return None
        center, radius = np.array(sphere[:3], dtype=np.float64), float(sphere[3])
        distance = np.linalg.norm(mesh.vertices.astype(np.float64) - center, axis=1)
        return (center, float(radius)) if radius > 0 and np.abs(distance - radius).max() <= 1e-4 * radius else None

    # Materials --------------------------------------------------------------------

    def _material_for(self, primitive: dict, label: str, mesh: Mesh, origin: GltfOrigin):
        if "material" not in primitive:
            return Diffuse()
        index = primitive["material"]
        entry = self.file.item("materials", index, "a primitive's material")
        if index not in self.materials:
            self.materials[index] = self._material(entry, f"materials[{index}]")
            origin.add("materials", self.materials[index][0], _material_origin(entry, self.materials[index][0]))
        material, features = self.materials[index]
        for feature in features:
            self.note(feature, label)
        if mesh.uvs is None and _has_textures(material):
            self.note("textures on a mesh without TEXCOORD_0", label)
        return material

    def _material(self, entry: dict, where: str):
        """(material, the features it uses that are not drawn) of one glTF material: a Principled with every
        field the file gives, or the Diffuse, Mirror or Glass it is exactly (Principled.shorthand)."""
        f = self.file
        features: list[str] = []
        pbr = f.table(entry, "pbrMetallicRoughness", where)
        here = f"{where}.pbrMetallicRoughness"
        base = f.numbers(pbr, "baseColorFactor", 4, [1.0, 1.0, 1.0, 1.0], here)
        if base.min() < 0 or base.max() > 1:
            raise f.error(f"{here}.baseColorFactor {short(base)} must lie in [0, 1]; re-export the file")
        emission = f.numbers(entry, "emissiveFactor", 3, [0.0, 0.0, 0.0], where)
        if emission.min() < 0:  # the spec's [0, 1]; brighter is KHR_materials_emissive_strength's, taken as well
            raise f.error(f"{where}.emissiveFactor {short(emission)} must lie in [0, 1]; re-export the file")
        extensions = f.table(entry, "extensions", where)

        def extension(name: str) -> tuple[dict, str]:
            return f.table(extensions, name, f"{where}.extensions"), f"{where}.extensions.{name}"

        for name in extensions:
            if name not in SUPPORTED_EXTENSIONS:
                features.append(name)
        if entry.get("alphaMode", "OPAQUE") != "OPAQUE":
            features.append(f"alphaMode {short(entry.get('alphaMode'))}")
        transmission, transmission_here = extension("KHR_materials_transmission")
        specular, specular_here = extension("KHR_materials_specular")
        strength, strength_here = extension("KHR_materials_emissive_strength")
        if "specularTexture" in specular or "specularColorTexture" in specular:
            features.append("KHR_materials_specular textures")
        if "transmissionTexture" in transmission:
            features.append("transmission textures")
        values = dict(
            base_color=base[:3],
            base_color_texture=self._texture(pbr, "baseColorTexture", here, features),
            metallic=f.number(pbr, "metallicFactor", 1.0, here, 0.0, 1.0),
            roughness=f.number(pbr, "roughnessFactor", 1.0, here, 0.0, 1.0),
            metallic_roughness_texture=self._texture(pbr, "metallicRoughnessTexture", here, features, srgb=False),
            normal_texture=self._texture(entry, "normalTexture", where, features, srgb=False),
            occlusion_texture=self._texture(entry, "occlusionTexture", where, features, srgb=False),
            emission_texture=self._texture(entry, "emissiveTexture", where, features),
            normal_scale=f.number(entry.get("normalTexture", {}), "scale", 1.0, f"{where}.normalTexture", -1e3, 1e3),
            occlusion_strength=f.number(entry.get("occlusionTexture", {}), "strength", 1.0,
                                        f"{where}.occlusionTexture", 0.0, 1.0),
            emission=emission * f.number(strength, "emissiveStrength", 1.0, strength_here, 0.0, rules.MAX_INTENSITY),
            # caustica's files before the metallic-roughness model wrote a Diffuse as metallic 0 alone
            specular=f.number(specular, "specularFactor", 0.0 if self.legacy else 1.0, specular_here, 0.0, 1.0),
            specular_color=f.numbers(specular, "specularColorFactor", 3, [1.0, 1.0, 1.0], specular_here),
            transmission=f.number(transmission, "transmissionFactor", 0.0, transmission_here, 0.0, 1.0),
            **self._volume(extension))
        material = self._made(Principled, where, **values)
        features += _undrawn(material)
        return material.shorthand() or material, features

    def _made(self, kind, where: str, **values):
        """``kind(**values)``, a SceneError naming the file and ``where``."""
        with rules.context(f"{self.file.path.name}: {where}"):
            return kind(**values)

    def _volume(self, extension) -> dict:
        """KHR_materials_ior's, _volume's and _dispersion's fields of a Principled (an infinite or absent
        attenuationDistance is None: no absorption; no volume extension, no thickness: thin-walled)."""
        f = self.file
        ior, ior_here = extension("KHR_materials_ior")
        volume, here = extension("KHR_materials_volume")
        distance = volume.get("attenuationDistance", math.inf)
        if distance != math.inf:
            distance = f.number(volume, "attenuationDistance", 1.0, here, rules.MIN_LENGTH, 1e12)
        dispersion, dispersion_here = extension("KHR_materials_dispersion")
        return dict(ior=f.number(ior, "ior", 1.5, ior_here),
                    attenuation_color=f.numbers(volume, "attenuationColor", 3, [1.0, 1.0, 1.0], here),
                    attenuation_distance=None if distance == math.inf else distance,
                    thickness=f.number(volume, "thicknessFactor", 0.0, here, 0.0, 1e12) if volume else None,
                    dispersion=f.number(dispersion, "dispersion", 0.0, dispersion_here, 0.0, 1e6))

    def _texture(self, owner: dict, key: str, where: str, features: list[str], srgb: bool = True):
        """The image of texture info ``owner[key]`` (None when absent, on another uv set or without an image):
        sRGB-decoded colour (``srgb``: base colour, emission), else linear data."""
        f = self.file
        if key not in owner:
            return None
        info = owner[key]
        if not isinstance(info, dict):
            raise f.error(f"{where}.{key} must be a JSON object; re-export the file")
        if "KHR_texture_transform" in f.table(info, "extensions", f"{where}.{key}"):
            features.append("KHR_texture_transform")
        if info.get("texCoord", 0) != 0:
            features.append(f"{key} on TEXCOORD_{short(info.get('texCoord'))}")
            return None
        index = info.get("index")
        texture = f.item("textures", index, f"{where}.{key}.index")
        if (index, srgb) not in self.textures:
            self.textures[index, srgb] = (f.image(texture["source"], f"textures[{index}].source", srgb)
                                          if "source" in texture else None)
        if self.textures[index, srgb] is None:
            features.append("textures without a PNG or JPEG source")
        return self.textures[index, srgb]

    # Lights -----------------------------------------------------------------------

    def _light(self, index, where: str, label: str, world: np.ndarray):
        f = self.file
        lights = self._lights_table
        if not isinstance(lights, list) or not _index_in(index, lights) or not isinstance(lights[index], dict):
            raise f.error(f"{where} {short(index)} does not index the KHR_lights_punctual lights; re-export the file")
        light, here = lights[index], f"extensions.KHR_lights_punctual.lights[{index}]"
        color = f.numbers(light, "color", 3, [1.0, 1.0, 1.0], here)
        intensity = radiometric(color, f.number(light, "intensity", 1.0, here, 0.0, rules.MAX_INTENSITY))
        if "range" in light:
            self.note("light range", label)
        position = world[:3, 3]
        direction = world[:3, :3] @ np.array([0.0, 0.0, -1.0])
        kind = light.get("type")
        with rules.context(f"{f.path.name}: {here}"):
            if kind == "point":
                return PointLight(position, intensity)
            if kind == "directional":
                return DirectionalLight(direction, intensity)
            if kind == "spot":
                spot = f.table(light, "spot", here)
                outer = f.number(spot, "outerConeAngle", math.pi / 4, f"{here}.spot", 0.0, math.pi / 2)
                inner = f.number(spot, "innerConeAngle", 0.0, f"{here}.spot", 0.0, outer)
                outer_deg = min(math.degrees(outer), MAX_SPOT_OUTER)
                inner_deg = min(max(math.degrees(inner), MIN_SPOT_INNER), outer_deg)
                return SpotLight(position, direction, intensity, inner_deg, max(outer_deg, inner_deg))
        raise f.error(f"{here}.type {short(kind)} must be point, spot or directional; re-export the file")


def _name_or_none(obj: dict) -> str | None:
    name = obj.get("name")
    return name if isinstance(name, str) else None


def _material_origin(entry: dict, material) -> MaterialOrigin:
    """What export keeps of a glTF material: name, doubleSided and the extensions caustica does not write
    from ``material`` (all but MATERIAL_EXTENSIONS, which the material holds)."""
    extensions = entry.get("extensions", {})
    carried = {name: data for name, data in extensions.items() if name not in MATERIAL_EXTENSIONS}
    return MaterialOrigin(_name_or_none(entry), entry.get("doubleSided") is True, carried,
                          thin_walled=material.kind == "glass" and "KHR_materials_volume" not in extensions)


def _has_textures(material) -> bool:
    return material.textured if isinstance(material, Principled) else getattr(material, "texture", None) is not None


def _undrawn(material: Principled) -> list[str]:
    """What of a Principled its drawing role does not draw (docs/materials.md): glass is smooth and clear,
    a mirror perfect and untextured, an opaque surface opaque with the dielectric F0 of IOR 1.5."""
    features = []
    emits = bool(np.any(material.emission > 0))
    if material.kind == "glass":
        if material.roughness > GLASS_ROUGHNESS:
            features.append("roughness on glass")
        if np.any(material.base_color < 1.0):
            features.append("baseColorFactor tint on glass")
        if material.textured:
            features.append("textures on glass")
        if emits:
            features.append("emission on glass")
    elif material.kind == "mirror":
        if material.textured:
            features.append("textures on mirrors")
        if emits:
            features.append("emission on mirrors")
    else:
        if material.transmission > 0:
            features.append("transmission below 0.5 (drawn opaque)")
        if material.ior != DIELECTRIC_IOR and material.metallic < 1.0:
            features.append("KHR_materials_ior on opaque surfaces (their F0 is IOR 1.5's)")
    return features


MATERIAL_MODEL = "metallic-roughness"  # caustica's writer marks its files' asset.extras.caustica.materials so


def _legacy_caustica(doc: dict) -> bool:
    """Whether caustica wrote ``doc`` before its materials were glTF's metallic-roughness model (then a
    Diffuse was metallic 0 with no KHR_materials_specular, which glTF draws with a 0.04 specular layer)."""
    asset = doc.get("asset")
    generator = asset.get("generator") if isinstance(asset, dict) else None
    return isinstance(generator, str) and generator.startswith("caustica ") \
        and _caustica_extras(asset).get("materials") != MATERIAL_MODEL


def _caustica_extras(obj: dict) -> dict:
    """``obj.extras.caustica`` (what caustica's exporter keeps), or {}: extras may hold anything."""
    extras = obj.get("extras")
    hint = extras.get("caustica") if isinstance(extras, dict) else None
    return hint if isinstance(hint, dict) else {}


def _unit_or_none(normals: np.ndarray) -> np.ndarray | None:
    """Unit normals, or None (recompute them) when some are zero or not finite."""
    length = np.sqrt(np.einsum("ij,ij->i", normals, normals))
    if not np.all(np.isfinite(length)) or float(length.min()) < 1e-6:
        return None
    return normals / length[:, None]


def _unit_tangents_or_none(tangents: np.ndarray) -> np.ndarray | None:
    """Tangents with unit xyz and w snapped to +-1, or None (generate them from the uvs) when some xyz are
    zero or not finite or some w is not +-1."""
    xyz = _unit_or_none(tangents[:, :3])
    w = tangents[:, 3]
    if xyz is None or not np.all(np.abs(np.abs(w) - 1.0) <= 1e-3):
        return None
    return np.c_[xyz, np.where(w < 0, -1.0, 1.0)].astype(np.float32)


def _index_in(index, items: list) -> bool:
    return isinstance(index, int) and not isinstance(index, bool) and 0 <= index < len(items)


# Cameras ------------------------------------------------------------------------


def camera_names(imports: list[GltfScene]) -> list[str]:
    return [c.name for g in imports for c in g.cameras]


def choose_camera(imports: list[GltfScene], name: str | None, bounds: np.ndarray) -> Camera:
    """The glTF camera called ``name`` (a camera's or its node's name), else the first one; without any,
    a camera framing ``bounds`` (said in a warning)."""
    cameras = [(g, c) for g in imports for c in g.cameras]
    if name is not None:
        chosen = [(g, c) for g, c in cameras if name in (c.name, c.node_name)]
        if not chosen:
            names = camera_names(imports) or ["none"]
            raise SceneError(f"camera {short(name)} not found{closest_name(name, names)}; the glTF cameras are: "
                             f"{', '.join(map(repr, names[:10]))}")
        return _recorded_camera(*chosen[0], bounds)
    if cameras:
        return _recorded_camera(*cameras[0], bounds)
    source = ", ".join(Path(g.source).name for g in imports)
    warnings.warn(f"{source} has no camera: a camera frames the scene from +Z and above "
                  "(add one in the file, or a [camera] table in a TOML scene)", stacklevel=3)
    return framing_camera(bounds)


def _recorded_camera(imported: GltfScene, camera: GltfCamera, bounds: np.ndarray) -> Camera:
    """:func:`gltf_camera`, its names and extras keys recorded in the file's origin for export."""
    made = gltf_camera(camera, bounds)
    focus = float(np.linalg.norm(np.asarray(made.look_at) - np.asarray(made.position)))
    imported.origin.add("cameras", made, CameraOrigin(camera.name, camera.node_name, frozenset(camera.extras),
                                                      tuple(made.size), focus, dict(camera.fields)))
    return made


def gltf_camera(camera: GltfCamera, bounds: np.ndarray) -> Camera:
    """caustica's Camera for a glTF perspective camera: the node looks down its -Z with +Y up."""
    where = f"camera {short(camera.name)}"
    fields, extras = camera.fields, camera.extras
    yfov = fields.get("yfov")
    near = fields.get("znear")
    if not (rules.finite(yfov) and 0 < yfov < math.pi) or not (rules.finite(near) and near > 0):
        raise SceneError(f"{where} needs yfov in (0, pi) radians and a positive znear; re-export the file")
    aspect = fields.get("aspectRatio")
    widest = rules.MAX_IMAGE_SIZE
    if aspect is not None and not (rules.finite(aspect) and 1.0 / widest <= aspect <= widest):
        raise SceneError(f"{where}.aspectRatio {short(aspect)} must be a positive number in [1/{rules.MAX_IMAGE_SIZE}, "
                         f"{rules.MAX_IMAGE_SIZE}]; re-export the file")
    size = _camera_size(aspect, extras.get("size"))
    position = camera.world[:3, 3]
    forward = camera.world[:3, :3] @ np.array([0.0, 0.0, -1.0])
    up = camera.world[:3, :3] @ np.array([0.0, 1.0, 0.0])
    if np.linalg.norm(forward) < 1e-12 or np.linalg.norm(up) < 1e-12:
        raise SceneError(f"{where}: its node's transform collapses the view direction; re-export the file")
    forward = forward / np.linalg.norm(forward)
    center = bounds.mean(axis=0)
    focus = extras.get("focus_distance")
    if not (rules.finite(focus) and focus > 0):
        focus = float((center - position) @ forward)
        if focus <= 2 * near:
            focus = max(1.0, 10 * near)
    far = fields.get("zfar")
    if far is None:  # infinite: beyond the farthest corner of the scene
        corners = np.array(np.meshgrid(*bounds.T)).reshape(3, -1).T
        far = max(2.0 * float(np.linalg.norm(corners - position, axis=1).max()), 100.0 * near)
    elif not (rules.finite(far) and far > near):
        raise SceneError(f"{where}.zfar {short(far)} must be a number above znear {near:g}; re-export the file")
    far = min(float(far), rules.MAX_DEPTH_RATIO * near)
    with rules.context(where):
        return Camera(position=position, look_at=position + float(focus) * forward, up=up,
                      fov_y=math.degrees(yfov), near=near, far=far, size=size)


def _camera_size(aspect, size) -> tuple[int, int]:
    """caustica's pixel size (``extras.caustica.size`` when it agrees with the aspect ratio), else
    DEFAULT_HEIGHT pixels high (wide when the aspect is above 1)."""
    if isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) and 1 <= v <= rules.MAX_IMAGE_SIZE
                                                         for v in size):
        if aspect is None or abs(size[0] / size[1] - aspect) <= 1e-3 * aspect:
            return size[0], size[1]
    if aspect is None:
        return DEFAULT_HEIGHT, DEFAULT_HEIGHT
    if aspect >= 1:
        return min(rules.MAX_IMAGE_SIZE, round(DEFAULT_HEIGHT * aspect)), DEFAULT_HEIGHT
    return DEFAULT_HEIGHT, min(rules.MAX_IMAGE_SIZE, round(DEFAULT_HEIGHT / aspect))


FRAMING_DIRECTION = np.array([0.0, 0.45, 1.0]) / np.linalg.norm([0.0, 0.45, 1.0])  # from +Z, a little above
FRAMING_FOV = 40.0


def framing_camera(bounds: np.ndarray, size=(DEFAULT_HEIGHT, DEFAULT_HEIGHT)) -> Camera:
    """A camera at +Z and slightly above ``bounds`` (2, 3) whose view holds its bounding sphere."""
    lo, hi = np.asarray(bounds, dtype=np.float64)
    center = (lo + hi) / 2.0
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-3)
    distance = 1.1 * radius / math.sin(math.radians(FRAMING_FOV) / 2.0)
    near = max(distance - 1.5 * radius, distance * 1e-3)
    return Camera(position=center + distance * FRAMING_DIRECTION, look_at=center, up=[0.0, 1.0, 0.0],
                  fov_y=FRAMING_FOV, near=near, far=distance + 2.0 * radius, size=size)

