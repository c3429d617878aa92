"""glTF 2.0 import and export (scene/gltf, docs/gltf.md): files are built here with pygltflib, the way
exporters write them, independently of caustica's own writer."""
from __future__ import annotations

import base64
import io
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pygltflib as g
import pytest
from PIL import Image

import caustica
from caustica.cli import main
from caustica.errors import MeshError, OutputError, SceneError
from caustica.images import srgb_to_linear
from caustica.metrics import psnr_linear
from caustica.scene import DirectionalLight, Diffuse, Glass, Mirror, PointLight, SpotLight
from caustica.scene.materials import Principled
from caustica.scene.gltf.matrices import euler_degrees_from_rotation, matrix_from_quaternion, quaternion_from_matrix
from caustica.scene.io import export_scene, load_scene
from caustica.scene.shapes import box, plane, sphere
from caustica.scene.transform import rotation_from_euler_degrees

SIZE = (64, 48)


class Doc:
    """A glTF document made with pygltflib; every array goes into one binary blob (the GLB chunk, or a
    .bin file / data URI for .gltf)."""

    def __init__(self):
        self.gltf = g.GLTF2(asset=g.Asset(version="2.0"), scene=0, scenes=[g.Scene(nodes=[])])
        self.blob = bytearray()

    def view(self, data: bytes) -> int:
        self.blob += b"\0" * (-len(self.blob) % 4)
        self.gltf.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(data)))
        self.blob += data
        return len(self.gltf.bufferViews) - 1

    def accessor(self, array, component=g.FLOAT, kind=g.VEC3, count=None) -> int:
        array = np.ascontiguousarray(array)
        self.gltf.accessors.append(g.Accessor(bufferView=self.view(array.tobytes()), componentType=component,
                                              count=len(array) if count is None else count, type=kind))
        return len(self.gltf.accessors) - 1

    def mesh(self, mesh, material=None, uvs=None, name=None) -> int:
        attributes = g.Attributes(POSITION=self.accessor(mesh.vertices.astype(np.float32)),
                                  NORMAL=self.accessor(mesh.normals.astype(np.float32)))
        if uvs is not None:
            attributes.TEXCOORD_0 = self.accessor(np.asarray(uvs, np.float32), kind=g.VEC2)
        indices = self.accessor(mesh.faces.astype(np.uint32).reshape(-1), g.UNSIGNED_INT, g.SCALAR)
        self.gltf.meshes.append(g.Mesh(name=name, primitives=[g.Primitive(attributes=attributes, indices=indices,
                                                                           material=material)]))
        return len(self.gltf.meshes) - 1

    def material(self, base=(1, 1, 1, 1), metallic=0.0, roughness=1.0, extensions=None, **fields) -> int:
        """A material; ``lambertian=True`` adds KHR_materials_specular's specularFactor 0, without which
        glTF's dielectric has a specular layer (F0 0.04): the glTF twin of a TOML diffuse."""
        if fields.pop("lambertian", False):
            extensions = {**(extensions or {}), "KHR_materials_specular": {"specularFactor": 0.0}}
        pbr = g.PbrMetallicRoughness(baseColorFactor=list(base), metallicFactor=metallic, roughnessFactor=roughness)
        for key, value in fields.pop("pbr", {}).items():
            setattr(pbr, key, value)
        self.gltf.materials.append(g.Material(pbrMetallicRoughness=pbr, extensions=extensions or {}, **fields))
        for name in extensions or {}:
            if name not in self.gltf.extensionsUsed:
                self.gltf.extensionsUsed.append(name)
        return len(self.gltf.materials) - 1

    def image(self, pixels: np.ndarray) -> int:
        """A PNG texture (8-bit sRGB codes) embedded in the buffer; returns the texture index."""
        encoded = io.BytesIO()
        Image.fromarray(pixels, "RGB").save(encoded, format="PNG")
        self.gltf.images.append(g.Image(bufferView=self.view(encoded.getvalue()), mimeType="image/png"))
        self.gltf.textures.append(g.Texture(source=len(self.gltf.images) - 1))
        return len(self.gltf.textures) - 1

    def node(self, root=True, **fields) -> int:
        self.gltf.nodes.append(g.Node(**fields))
        index = len(self.gltf.nodes) - 1
        if root:
            self.gltf.scenes[0].nodes.append(index)
        return index

    def light(self, light: dict, root=True, **node) -> int:
        ext = self.gltf.extensions.setdefault("KHR_lights_punctual", {"lights": []})
        ext["lights"].append(light)
        if "KHR_lights_punctual" not in self.gltf.extensionsUsed:
            self.gltf.extensionsUsed.append("KHR_lights_punctual")
        return self.node(root, extensions={"KHR_lights_punctual": {"light": len(ext["lights"]) - 1}}, **node)

    def camera(self, yfov=math.radians(40), znear=0.1, zfar=50.0, aspect=SIZE[0] / SIZE[1], name="cam", **node):
        self.gltf.cameras.append(g.Camera(type="perspective", name=name, perspective=g.Perspective(
            yfov=yfov, znear=znear, zfar=zfar, aspectRatio=aspect)))
        return self.node(camera=len(self.gltf.cameras) - 1, **node)

    def save(self, path: Path, external: str | None = None) -> Path:
        """``.glb`` (the blob as its BIN chunk) or ``.gltf`` (the blob in file ``external``, else a data URI)."""
        path = Path(path)
        blob = bytes(self.blob) + b"\0" * (-len(self.blob) % 4)
        self.gltf.buffers = [g.Buffer(byteLength=len(blob))]
        if path.suffix == ".glb":
            self.gltf.set_binary_blob(blob)
            self.gltf.save_binary(str(path))
        else:
            if external:
                (path.parent / external).parent.mkdir(parents=True, exist_ok=True)
                (path.parent / external).write_bytes(blob)
                self.gltf.buffers[0].uri = external
            else:
                self.gltf.buffers[0].uri = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
            path.write_text(self.gltf.gltf_to_json())
        return path


def render(renderer, scene, technique: str):
    """``renderer.render``; exact without photon-map caustics where it has them (these tests compare what
    scenes hold, and the photon pass would take most of the file's time)."""
    from caustica.techniques.exact import ExactParams

    fields = getattr(ExactParams, "__dataclass_fields__", {})
    params = {"caustic_photons": 0} if technique == "exact" and "caustic_photons" in fields else {}
    return renderer.render(scene, technique, **params)


def quaternion_x(degrees: float) -> list[float]:
    half = math.radians(degrees) / 2
    return [math.sin(half), 0.0, 0.0, math.cos(half)]


def quiet_load(path, camera=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path, camera)


def one_line(error) -> str:
    message = str(error.value)
    assert message and "\n" not in message
    return message


# The scene the TOML twin also describes: a floor, a glass box, a mirror ball, a point light, a camera.
CAMERA_PITCH = -math.degrees(math.atan2(0.5, 4.0))  # from (0, 1, 4) towards (0, 0.5, 0)
TWIN_TOML = """
[camera]
position = [0, 1, 4]
look_at = [0, 0.5, 0]
fov_y = 40
near = 0.1
far = 50
size = [64, 48]
[[lights]]
type = "point"
position = [1, 3, 2]
intensity = [10, 8, 6]
[[objects]]
shape = "plane"
size = [4, 4]
material = { type = "diffuse", color = [0.7, 0.6, 0.5] }
[[objects]]
shape = "box"
position = [-0.6, 0.5, 0]
rotation = [0, 30, 0]
material = { type = "glass", ior = 1.5 }
[[objects]]
shape = "box"
size = [0.5, 0.5, 0.5]
position = [0.7, 0.25, 0.3]
material = { type = "mirror", color = [0.9, 0.9, 0.8] }
"""


def twin_gltf(path: Path) -> Path:
    doc = Doc()
    floor = doc.material(base=(0.7, 0.6, 0.5, 1.0), lambertian=True)
    glass = doc.material(metallic=0.0, roughness=0.0, extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                                                  "KHR_materials_ior": {"ior": 1.5}})
    mirror = doc.material(base=(0.9, 0.9, 0.8, 1.0), metallic=1.0, roughness=0.0)
    doc.node(mesh=doc.mesh(plane((4.0, 4.0)), floor), name="floor")
    half = math.radians(30) / 2
    doc.node(mesh=doc.mesh(box(), glass), name="glass", translation=[-0.6, 0.5, 0],
             rotation=[0, math.sin(half), 0, math.cos(half)])
    doc.node(mesh=doc.mesh(box((0.5, 0.5, 0.5)), mirror), name="mirror", translation=[0.7, 0.25, 0.3])
    doc.light({"type": "point", "color": [1.0, 0.8, 0.6], "intensity": 10 * 683.0}, translation=[1, 3, 2])
    doc.camera(translation=[0, 1, 4], rotation=quaternion_x(CAMERA_PITCH))
    return doc.save(path)


# Import --------------------------------------------------------------------------


@pytest.mark.parametrize("technique", ["plain", "exact"])
def test_camera_and_scene_match_their_toml_twin(tmp_path, technique):
    """The same scene as a TOML file and as a glTF (camera from a node rotation, photometric light units)
    renders the same: PSNR above 50 dB with a raster and the ray-traced technique."""
    (tmp_path / "twin.toml").write_text(TWIN_TOML)
    toml_scene = load_scene(tmp_path / "twin.toml")
    gltf_scene = load_scene(twin_gltf(tmp_path / "twin.glb"))
    assert gltf_scene.camera.aspect == pytest.approx(toml_scene.camera.aspect, rel=1e-3)  # 683x512 against 64x48
    np.testing.assert_allclose(gltf_scene.camera.position, toml_scene.camera.position, atol=1e-9)
    direction = lambda c: (c.look_at - c.position) / np.linalg.norm(c.look_at - c.position)  # noqa: E731
    np.testing.assert_allclose(direction(gltf_scene.camera), direction(toml_scene.camera), atol=1e-9)
    assert gltf_scene.camera.fov_y == pytest.approx(40.0) and gltf_scene.camera.far == 50.0
    renderer = caustica.Renderer(SIZE)
    reference = render(renderer, toml_scene, technique)
    image = render(renderer, gltf_scene, technique)
    assert reference.mean() > 0.05  # something is lit
    assert psnr_linear(image, reference) > 50.0
    # The twin test can fail: a camera pitched 2 degrees more does not match.
    doc = json.loads(Path(twin_gltf(tmp_path / "off.gltf")).read_text())
    doc["nodes"][-1]["rotation"] = quaternion_x(CAMERA_PITCH - 2.0)
    (tmp_path / "off.gltf").write_text(json.dumps(doc))
    assert psnr_linear(render(renderer, load_scene(tmp_path / "off.gltf"), technique), reference) < 30.0


@pytest.mark.parametrize("technique", ["plain", "exact"])
def test_textured_floor_matches_its_toml_twin(tmp_path, technique):
    """A floor with a baseColorTexture (an asymmetric 4x4 PNG) and TEXCOORD_0 renders as the TOML twin with
    texture = 'floor.png' on the same plane: the texture and its uvs arrive as the renderers expect."""
    codes = np.random.default_rng(5).integers(0, 256, (4, 4, 3), dtype=np.uint8)
    Image.fromarray(codes, "RGB").save(tmp_path / "floor.png")
    floor = plane((4.0, 4.0))
    doc = Doc()
    texture = doc.image(codes)
    material = doc.material(base=(0.9, 0.8, 0.7, 1), pbr={"baseColorTexture": g.TextureInfo(index=texture)},
                            lambertian=True)
    doc.node(mesh=doc.mesh(floor, material, uvs=floor.uvs), name="floor")
    doc.light({"type": "point", "intensity": 10 * 683.0}, translation=[1, 3, 2])
    doc.camera(translation=[0, 1, 4], rotation=quaternion_x(CAMERA_PITCH))
    gltf_scene = load_scene(doc.save(tmp_path / "floor.glb"))
    toml = TWIN_TOML.split("[[objects]]")[0].replace("[10, 8, 6]", "10") + """[[objects]]
shape = "plane"
size = [4, 4]
material = { type = "diffuse", color = [0.9, 0.8, 0.7], texture = "floor.png" }
"""
    (tmp_path / "floor.toml").write_text(toml)
    renderer = caustica.Renderer(SIZE)
    reference = render(renderer, load_scene(tmp_path / "floor.toml"), technique)
    image = render(renderer, gltf_scene, technique)
    assert reference.std() > 0.02  # the texture shows
    assert psnr_linear(image, reference) > 50.0
    flipped = gltf_scene.objects[0].material
    flipped.texture = np.ascontiguousarray(flipped.texture[::-1])  # v upside down: the test can tell
    assert psnr_linear(render(renderer, gltf_scene, technique), reference) < 30.0


def test_node_transforms_compose_through_three_levels(tmp_path):
    """root: translate (1, 0, 0) and turn 90 degrees about +Y; child: translate (0, 1, 0), scale 2;
    grandchild: a matrix translating (0, 0, 1). Object point (0, 0, 0) lands at (3, 1, 0) and (1, 0, 0)
    at (3, 1, -2); a sheared grandchild is baked into its vertices."""
    doc = Doc()
    triangle = caustica.scene.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), None,
                                   np.array([[0, 1, 2]]))
    grandchild = doc.node(False, mesh=doc.mesh(triangle), name="leaf",
                          matrix=[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 1, 1])
    sheared = doc.node(False, mesh=doc.mesh(triangle), name="sheared",
                       matrix=[1, 0, 0, 0, 0.5, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1])  # x += 0.5 y
    child = doc.node(False, translation=[0, 1, 0], scale=[2, 2, 2], children=[grandchild, sheared])
    s = math.sqrt(0.5)
    doc.node(translation=[1, 0, 0], rotation=[0, s, 0, s], children=[child], name="root")
    scene = quiet_load(doc.save(tmp_path / "tree.glb"))
    leaf = {o.name: o for o in scene.objects}["leaf"]
    world = leaf.world_mesh().vertices
    np.testing.assert_allclose(world[0], [3, 1, 0], atol=1e-5)
    np.testing.assert_allclose(world[1], [3, 1, -2], atol=1e-5)
    np.testing.assert_allclose(leaf.transform.scale, [2, 2, 2], atol=1e-9)
    shear = {o.name: o for o in scene.objects}["sheared"]
    np.testing.assert_allclose(shear.transform.world_from_object(), np.eye(4))  # baked
    # Object (0, 1, 0): sheared to (0.5, 1, 0), scaled (1, 2, 0), moved (1, 3, 0), turned (0, 3, -1), (1, 3, -1).
    np.testing.assert_allclose(shear.world_mesh().vertices[2], [1, 3, -1], atol=1e-5)


def test_mirroring_node_keeps_faces_outward(tmp_path):
    """A negative scale (det < 0) is baked, with the triangle order reversed so the solid stays solid."""
    doc = Doc()
    doc.node(mesh=doc.mesh(box()), scale=[-1, 1, 1], name="flipped")
    obj = quiet_load(doc.save(tmp_path / "flip.glb")).objects[0]
    assert obj.mesh.is_solid()


def test_rotations_convert_both_ways():
    rng = np.random.default_rng(3)
    for angles in list(rng.uniform(-180, 180, (50, 3))) + [np.array([20.0, 90.0, 0.0]), np.array([20.0, -90.0, 0.0])]:
        r = rotation_from_euler_degrees(angles)
        np.testing.assert_allclose(rotation_from_euler_degrees(euler_degrees_from_rotation(r)), r, atol=1e-9)
        np.testing.assert_allclose(matrix_from_quaternion(quaternion_from_matrix(r)), r, atol=1e-9)


def test_light_units_at_683_lumens_per_watt(tmp_path):
    """683 cd of colour (1, 0.5, 0.25) is (1, 0.5, 0.25) W/sr; 1366 lux is 2 W/m^2; cones in degrees;
    directions are each node's -Z."""
    doc = Doc()
    doc.light({"type": "point", "color": [1, 0.5, 0.25], "intensity": 683.0}, translation=[1, 2, 3])
    doc.light({"type": "directional", "intensity": 1366.0}, rotation=quaternion_x(-90))  # -Z turned to -Y
    doc.light({"type": "spot", "intensity": 6830.0, "spot": {"innerConeAngle": math.pi / 8,
                                                            "outerConeAngle": math.pi / 4}},
              translation=[0, 4, 0], rotation=quaternion_x(-90))
    doc.node(mesh=doc.mesh(plane()))
    point, sun, spot = quiet_load(doc.save(tmp_path / "lights.glb")).lights
    assert isinstance(point, PointLight) and isinstance(sun, DirectionalLight) and isinstance(spot, SpotLight)
    np.testing.assert_allclose(point.intensity, [1, 0.5, 0.25])
    np.testing.assert_allclose(point.position, [1, 2, 3])
    np.testing.assert_allclose(sun.intensity, [2, 2, 2])
    np.testing.assert_allclose(sun.direction, [0, -1, 0], atol=1e-12)
    np.testing.assert_allclose(spot.intensity, [10, 10, 10])
    assert (spot.inner_angle, spot.outer_angle) == (pytest.approx(22.5), pytest.approx(45.0))
    np.testing.assert_allclose(spot.direction, [0, -1, 0], atol=1e-12)


def test_blender_style_glass_renders_as_glass(tmp_path):
    """Blender's Principled BSDF with Transmission 1 exports KHR_materials_transmission = 1, KHR_materials_ior,
    metallic 0 and its roughness (0.3 here, warned: caustica's glass is smooth); the ball renders as a glass
    ball of that IOR does, not as a diffuse one."""
    doc = Doc()
    glass = doc.material(base=(1, 1, 1, 1), metallic=0.0, roughness=0.3, name="Glass", doubleSided=False,
                         extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                     "KHR_materials_ior": {"ior": 1.45}})
    # A Lambertian floor (no specular layer): exact's glossy floor would be sampled, and its noise hide the ball.
    floor = doc.material(base=(0.8, 0.8, 0.8, 1), metallic=0.0, roughness=0.5, name="Floor", lambertian=True)
    ball = sphere(0.5, 3)
    ball.analytic_sphere = None  # the file holds triangles only; so does the scene built to compare
    doc.node(mesh=doc.mesh(ball, glass, name="Sphere"), name="Sphere", translation=[0, 0.5, 0])
    doc.node(mesh=doc.mesh(plane((4, 4)), floor, name="Plane"), name="Plane")
    doc.light({"type": "point", "intensity": 5000.0}, name="Light", translation=[0, 3, 1])
    doc.camera(translation=[0, 1, 4], rotation=quaternion_x(CAMERA_PITCH), name="Camera")
    with pytest.warns(UserWarning, match=r"roughness on glass.*'Sphere'"):
        scene = load_scene(doc.save(tmp_path / "blender.glb"))
    materials = {o.name: o.material for o in scene.objects}
    material = materials["Sphere"]
    assert material.kind == "glass" and material.roughness == pytest.approx(0.3)
    assert material.ior == pytest.approx(1.45)
    renderer = caustica.Renderer(SIZE)
    image = render(renderer, scene, "exact")
    built = caustica.scene.Scene(camera=scene.camera, lights=scene.lights, objects=[
        caustica.scene.SceneObject("ball", ball, Glass(ior=1.45), caustica.scene.Transform(position=[0, 0.5, 0])),
        caustica.scene.SceneObject("floor", plane((4, 4)), Diffuse([0.8] * 3))])
    assert isinstance(materials["Plane"], Diffuse)
    assert psnr_linear(image, render(renderer, built, "exact")) > 50.0
    built.objects[0].material = Diffuse()
    assert psnr_linear(image, render(renderer, built, "exact")) < 25.0


def test_materials_map_to_principled_and_its_shorthands(tmp_path):
    """Base colour and texture (sRGB PNG to linear, TEXCOORD_0 kept) on glTF's dielectric, which has a
    specular layer (a glossy Principled, not a Diffuse); a smooth metal drawn as a mirror; rough metal drawn
    as itself (no warning); glass with KHR_materials_ior, _volume and _dispersion (V_d = 20 / dispersion);
    exactly clear smooth glass is the Glass shorthand."""
    doc = Doc()
    codes = np.array([[[188, 0, 255], [0, 0, 0]], [[255, 255, 255], [64, 128, 32]]], np.uint8)
    textured = doc.material(base=(0.5, 1, 1, 1), pbr={"baseColorTexture": g.TextureInfo(index=doc.image(codes))})
    mirror = doc.material(base=(0.9, 0.8, 0.7, 1), metallic=0.95, roughness=0.02)
    rough_metal = doc.material(base=(0.9, 0.8, 0.7, 1), metallic=1.0, roughness=0.5)
    amber = doc.material(metallic=0.0, roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 0.9}, "KHR_materials_ior": {"ior": 1.6},
        "KHR_materials_volume": {"thicknessFactor": 0.4, "attenuationColor": [0.9, 0.6, 0.2],
                                 "attenuationDistance": 0.5},
        "KHR_materials_dispersion": {"dispersion": 0.5}})
    clear = doc.material(metallic=0.0, roughness=0.0, extensions={"KHR_materials_transmission": {"transmissionFactor": 1}})
    quad = plane()
    uvs = np.array([[0, 0], [1, 0], [0, 1], [1, 1]], np.float32)[: len(quad.vertices)]
    doc.camera(translation=[0, 0, 5])
    for name, material in (("floor", textured), ("mirror", mirror), ("metal", rough_metal), ("amber", amber),
                           ("clear", clear)):
        doc.node(mesh=doc.mesh(quad, material, uvs=uvs if name == "floor" else None), name=name)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing here is left undrawn
        objects = {o.name: o for o in load_scene(doc.save(tmp_path / "materials.glb")).objects}
    floor = objects["floor"].material
    assert isinstance(floor, Principled) and floor.kind == "diffuse" and floor.glossy
    assert (floor.metallic, floor.roughness, floor.specular) == (0.0, 1.0, 1.0)
    np.testing.assert_allclose(floor.base_color, [0.5, 1, 1])
    np.testing.assert_allclose(floor.base_color_texture, srgb_to_linear(codes / 255.0), atol=1e-6)
    np.testing.assert_allclose(objects["floor"].mesh.uvs, uvs)
    mirror = objects["mirror"].material
    assert mirror.kind == "mirror" and (mirror.metallic, mirror.roughness) == (0.95, 0.02)
    np.testing.assert_allclose(mirror.color, [0.9, 0.8, 0.7])
    metal = objects["metal"].material
    assert isinstance(metal, Principled) and metal.kind == "diffuse" and (metal.metallic, metal.roughness) == (1, 0.5)
    np.testing.assert_allclose(metal.f0, [0.9, 0.8, 0.7])
    amber = objects["amber"].material
    assert amber.kind == "glass" and amber.transmission == 0.9
    assert amber.ior == pytest.approx(1.6) and amber.abbe == pytest.approx(40.0)
    np.testing.assert_allclose(amber.absorption_color, [0.9, 0.6, 0.2])
    assert amber.absorption_distance == pytest.approx(0.5) and amber.thickness == pytest.approx(0.4)
    clear = objects["clear"].material
    assert isinstance(clear, Glass) and clear.ior == 1.5 and clear.abbe is None and clear.thickness is None
    np.testing.assert_allclose(clear.absorption_color, 1.0)


def test_every_mapped_field_round_trips(tmp_path):
    """glTF -> scene -> glTF -> scene keeps every field caustica maps, and the second glTF says the same
    (in glTF units) as the first."""
    doc = Doc()
    codes = np.array([[[188, 20, 255], [3, 0, 9]]], np.uint8)
    floor = doc.material(base=(0.5, 0.6, 0.7, 1), pbr={"baseColorTexture": g.TextureInfo(index=doc.image(codes))})
    mirror = doc.material(base=(0.9, 0.8, 0.7, 1), metallic=1.0, roughness=0.0)
    glass = doc.material(roughness=0.0, extensions={
        "KHR_materials_transmission": {"transmissionFactor": 1.0}, "KHR_materials_ior": {"ior": 1.7},
        "KHR_materials_volume": {"thicknessFactor": 0.3, "attenuationColor": [0.5, 0.7, 0.9],
                                 "attenuationDistance": 2.0},
        "KHR_materials_dispersion": {"dispersion": 0.4}})
    quad = plane((2, 2), 2)
    doc.node(mesh=doc.mesh(quad, floor, uvs=quad.vertices[:, [0, 2]] / 2 + 0.5), name="floor", scale=[2, 1, 3])
    doc.node(mesh=doc.mesh(box(), mirror), name="mirror", translation=[1, 0.5, 0], rotation=quaternion_x(25))
    doc.node(mesh=doc.mesh(sphere(0.5, 2), glass), name="ball", translation=[-1, 0.5, 0])
    doc.light({"type": "point", "color": [1, 0.5, 0.25], "intensity": 2000.0}, translation=[0, 3, 0])
    doc.light({"type": "spot", "intensity": 900.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}},
              translation=[1, 4, 1], rotation=quaternion_x(-80))
    doc.light({"type": "directional", "color": [0.9, 1, 0.8], "intensity": 1500.0}, rotation=quaternion_x(-60))
    doc.camera(translation=[0, 2, 6], rotation=quaternion_x(-15), yfov=0.6, znear=0.2, zfar=80.0, aspect=1.5)
    first = quiet_load(doc.save(tmp_path / "first.glb"))
    export_scene(first, tmp_path / "second.gltf")
    second = quiet_load(tmp_path / "second.gltf")
    assert [o.name for o in second.objects] == [o.name for o in first.objects] == ["floor", "mirror", "ball"]
    for a, b in zip(first.objects, second.objects):
        assert type(a.material) is type(b.material)
        for field in ("color", "texture", "ior", "absorption_color", "absorption_distance", "abbe", "thickness"):
            x, y = getattr(a.material, field, None), getattr(b.material, field, None)
            assert (x is None) == (y is None), field
            if x is not None:
                np.testing.assert_allclose(y, x, atol=1e-6, err_msg=field)
        np.testing.assert_allclose(b.world_from_object(), a.world_from_object(), atol=1e-9)
        np.testing.assert_allclose(b.mesh.vertices, a.mesh.vertices)
        np.testing.assert_allclose(b.mesh.normals, a.mesh.normals, atol=1e-6)
        assert (a.mesh.uvs is None) == (b.mesh.uvs is None)
    for a, b in zip(first.lights, second.lights, strict=True):
        assert type(a) is type(b)
        for field in ("position", "direction", "intensity", "inner_angle", "outer_angle"):
            if hasattr(a, field):
                np.testing.assert_allclose(getattr(b, field), getattr(a, field), atol=1e-9, err_msg=field)
    for field in ("position", "look_at", "up", "fov_y", "near", "far", "size"):
        np.testing.assert_allclose(getattr(second.camera, field), getattr(first.camera, field), atol=1e-9)
    # The written glTF in glTF's own units.
    written = json.loads((tmp_path / "second.gltf").read_text())
    lights = written["extensions"]["KHR_lights_punctual"]["lights"]
    assert [light["intensity"] for light in lights] == [pytest.approx(2000.0), pytest.approx(900.0),
                                                        pytest.approx(1500.0)]
    assert lights[0]["color"] == pytest.approx([1, 0.5, 0.25])
    assert lights[1]["spot"] == {"innerConeAngle": pytest.approx(0.2), "outerConeAngle": pytest.approx(0.5)}
    glass_entry = written["materials"][2]["extensions"]
    assert glass_entry["KHR_materials_ior"] == {"ior": pytest.approx(1.7)}
    assert glass_entry["KHR_materials_dispersion"] == {"dispersion": pytest.approx(0.4)}
    assert glass_entry["KHR_materials_volume"]["attenuationDistance"] == pytest.approx(2.0)
    perspective = written["cameras"][0]["perspective"]
    assert (perspective["yfov"], perspective["znear"], perspective["zfar"], perspective["aspectRatio"]) == \
        (pytest.approx(0.6), pytest.approx(0.2), pytest.approx(80.0), pytest.approx(1.5))


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_exported_presets_render_the_same(tmp_path, suffix):
    """A preset exported and loaded back renders the same image: its environment (here a dimmed sky) is kept
    in extras.caustica, said in one warning line since other glTF readers do not see it."""
    renderer = caustica.Renderer(SIZE)
    for preset in ("tvcg-fig24", "caustics-prism"):
        scene = load_scene(preset)
        with pytest.warns(UserWarning, match="environment .* is kept in extras.caustica.*other glTF readers") as seen:
            export_scene(scene, tmp_path / f"{preset}{suffix}")
        assert len(seen) == 1 and "\n" not in str(seen[0].message)
        loaded = load_scene(tmp_path / f"{preset}{suffix}")
        for technique in ("plain", "exact"):
            assert psnr_linear(render(renderer, loaded, technique), render(renderer, scene, technique)) > 60.0


def test_a_file_without_a_camera_gets_one_that_frames_it(tmp_path):
    doc = Doc()
    doc.node(mesh=doc.mesh(sphere(2.0, 2)), translation=[10, 0, 0])
    with pytest.warns(UserWarning, match="has no camera"):
        scene = load_scene(doc.save(tmp_path / "nocam.glb"))
    corners = np.array(np.meshgrid(*scene.bounds().T)).reshape(3, -1).T
    clip = np.c_[corners, np.ones(8)] @ scene.camera.clip_from_world().T
    ndc = clip[:, :3] / clip[:, 3:]
    assert np.all(np.abs(ndc[:, :2]) <= 1.0) and np.all(np.abs(ndc[:, 2]) <= 1.0)


def test_cameras_are_chosen_by_name(tmp_path):
    doc = Doc()
    doc.node(mesh=doc.mesh(box()))
    doc.camera(name="front", translation=[0, 0, 5])
    doc.camera(name="side", translation=[5, 0, 0], rotation=[0, math.sqrt(0.5), 0, math.sqrt(0.5)])
    path = doc.save(tmp_path / "cams.glb")
    np.testing.assert_allclose(load_scene(path).camera.position, [0, 0, 5])
    side = caustica.load_scene(path, camera="side").camera
    np.testing.assert_allclose(side.position, [5, 0, 0])
    np.testing.assert_allclose((side.look_at - side.position) / np.linalg.norm(side.look_at - side.position),
                               [-1, 0, 0], atol=1e-12)
    with pytest.raises(SceneError) as error:
        load_scene(path, camera="sied")
    assert "'sied' not found" in one_line(error) and "did you mean 'side'" in str(error.value)


def test_unsupported_features_are_one_warning_naming_the_nodes(tmp_path):
    doc = Doc()
    transformed = doc.material(pbr={"baseColorTexture": g.TextureInfo(
        index=doc.image(np.zeros((1, 1, 3), np.uint8)), extensions={"KHR_texture_transform": {"scale": [2, 2]}})},
        extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0}})
    quad = plane()
    doc.node(mesh=doc.mesh(quad, transformed, uvs=np.zeros((4, 2))), name="tiles")
    lines = doc.mesh(quad, name="wire")
    doc.gltf.meshes[lines].primitives[0].mode = 1
    doc.node(mesh=lines, name="wireframe")
    skinned = doc.mesh(quad)
    doc.gltf.meshes[skinned].primitives[0].targets = [{"POSITION": doc.gltf.meshes[skinned].primitives[0].attributes.POSITION}]
    doc.gltf.meshes[skinned].weights = [0.5]
    doc.node(mesh=skinned, name="blob", skin=0)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(doc.save(tmp_path / "extras.gltf"), camera=None)
    gltf_warnings = [w for w in caught if "not supported" in str(w.message)]
    assert len(gltf_warnings) == 1
    message = str(gltf_warnings[0].message)
    for expected in ("KHR_texture_transform ('tiles')", "KHR_materials_clearcoat ('tiles')", "lines primitives ('wireframe')",
                     "skins ('blob')", "morph targets ('blob')"):
        assert expected in message
    assert [o.name for o in scene.objects] == ["tiles", "blob"]


def test_external_buffers_and_images_beside_the_file(tmp_path):
    """Relative URIs (percent-encoded, in a subfolder) resolve against the glTF's folder."""
    doc = Doc()
    Image.fromarray(np.full((2, 2, 3), 255, np.uint8)).save(tmp_path / "my tex.png")
    doc.gltf.images.append(g.Image(uri="my%20tex.png"))
    doc.gltf.textures.append(g.Texture(source=0))
    material = doc.material(pbr={"baseColorTexture": g.TextureInfo(index=0)})
    doc.node(mesh=doc.mesh(plane(), material, uvs=np.zeros((4, 2))), name="floor")
    scene = quiet_load(doc.save(tmp_path / "scene.gltf", external="data/scene.bin"))
    np.testing.assert_allclose(scene.objects[0].material.texture, 1.0)


def test_toml_scene_adds_a_gltf_file_with_its_lights(tmp_path):
    """[[objects]] gltf = ... places the file's objects (position, scale), adds its lights unless
    lights = false, keeps the TOML's [camera] and takes the glTF's camera (placed with the file) without one."""
    twin_gltf(tmp_path / "model.glb")
    text = "[[objects]]\ngltf = 'model.glb'\nposition = [0, 1, 0]\n[[lights]]\ntype = 'point'\nposition = [0, 5, 0]\n"
    (tmp_path / "a.toml").write_text("[[objects]]\nshape = 'sphere'\nname = 'floor'\n" + text)
    scene = load_scene(tmp_path / "a.toml")
    assert [o.name for o in scene.objects] == ["floor", "floor-2", "glass", "mirror"]
    np.testing.assert_allclose(scene.objects[2].transform.position, [-0.6, 1.5, 0], atol=1e-9)
    assert len(scene.lights) == 2
    np.testing.assert_allclose(scene.camera.position, [0, 2, 4])  # the glTF's camera, moved with the file
    (tmp_path / "b.toml").write_text(text.replace("[0, 1, 0]\n", "[0, 1, 0]\nlights = false\n") +
                                     "[camera]\nposition = [0, 0, 9]\n")
    scene = load_scene(tmp_path / "b.toml")
    assert len(scene.lights) == 1 and scene.camera.position[2] == 9
    (tmp_path / "c.toml").write_text("[[objects]]\ngltf = 'model.glb'\nmaterial = 'glass'\n")
    with pytest.raises(SceneError, match=r"unknown key 'material' in objects\[0\]"):
        load_scene(tmp_path / "c.toml")


def test_mesh_key_on_a_gltf_file_warns_that_it_merges(tmp_path):
    twin_gltf(tmp_path / "model.glb")
    (tmp_path / "m.toml").write_text("[[objects]]\nmesh = 'model.glb'\n")
    with pytest.warns(UserWarning, match="write gltf = 'model.glb'"):
        load_scene(tmp_path / "m.toml")


# Untrusted files -----------------------------------------------------------------


def minimal(path: Path, edit=None, external: str | None = None) -> Path:
    """A one-triangle glTF, edited as JSON by ``edit(doc)`` before saving (.gltf) or packing (.glb)."""
    doc = Doc()
    triangle = caustica.scene.Mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), None,
                                   np.array([[0, 1, 2]]))
    doc.node(mesh=doc.mesh(triangle), name="tri")
    saved = doc.save(path.with_suffix(".gltf"), external=external)
    if edit is None:
        return saved
    data = json.loads(saved.read_text())
    edit(data)
    saved.write_text(json.dumps(data))
    return saved


def accessor(name: str):
    """The index of the triangle's accessor ``name`` (POSITION, NORMAL or indices)."""
    return {"NORMAL": 1, "POSITION": 0, "indices": 2}[name]


BAD_FILES = {
    "remote buffer": (lambda d: d["buffers"][0].update(uri="https://example.com/x.bin"), "remote", SceneError),
    "file scheme": (lambda d: d["buffers"][0].update(uri="file:///etc/passwd"), "remote", SceneError),
    "parent folder": (lambda d: d["buffers"][0].update(uri="../x.bin"), "leaves the glTF's folder", SceneError),
    "absolute path": (lambda d: d["buffers"][0].update(uri="/etc/passwd"), "leaves the glTF's folder", SceneError),
    "encoded parent": (lambda d: d["buffers"][0].update(uri="%2e%2e/x.bin"), "leaves the glTF's folder", SceneError),
    "parent inside": (lambda d: d["buffers"][0].update(uri="sub/../../x.bin"), "leaves the glTF's folder", SceneError),
    "backslashes": (lambda d: d["buffers"][0].update(uri="..\\x.bin"), "leaves the glTF's folder", SceneError),
    "NUL byte": (lambda d: d["buffers"][0].update(uri="a%00.bin"), "NUL", SceneError),
    "bad data uri": (lambda d: d["buffers"][0].update(uri="data:application/octet-stream;base64,@@@"),
                     "does not decode", SceneError),
    "missing buffer": (lambda d: d["buffers"][0].update(uri="gone.bin"), "not found", SceneError),
    "short buffer": (lambda d: d["buffers"][0].update(byteLength=d["buffers"][0]["byteLength"] + 4), "is short",
                     SceneError),
    "view past buffer": (lambda d: d["bufferViews"][0].update(byteOffset=10 ** 6), "runs past", SceneError),
    "accessor too long": (lambda d: d["accessors"][accessor("POSITION")].update(count=10 ** 12), "needs", MeshError),
    "wrong type": (lambda d: d["accessors"][accessor("POSITION")].update(type="VEC2"), "VEC3 is needed", MeshError),
    "wrong component": (lambda d: d["accessors"][accessor("indices")].update(componentType=g.FLOAT),
                        "componentType 5126", MeshError),
    "required extension": (lambda d: d.update(extensionsRequired=["KHR_draco_mesh_compression"]), "requires",
                           SceneError),
    "node cycle": (lambda d: d["nodes"][0].update(children=[0]), "reached twice", SceneError),
    "bad version": (lambda d: d["asset"].update(version="1.0"), "glTF 2.0", SceneError),
}


@pytest.mark.parametrize("case", list(BAD_FILES))
def test_bad_files_fail_in_one_line(tmp_path, case):
    edit, phrase, kind = BAD_FILES[case]
    path = minimal(tmp_path / "bad", edit, external="bad.bin" if case in ("short buffer",) else None)
    with pytest.raises(kind) as error:
        load_scene(path)
    assert phrase in one_line(error) and "bad.gltf" in str(error.value)


MUTANTS = (None, -1, 0, 2.5, "x", 1e308, [], {}, True, [0.0] * 16)


def json_paths(value, prefix=()):
    """Every place in a JSON document, as a tuple of keys and indices."""
    if prefix:
        yield prefix
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
    for key, item in items:
        yield from json_paths(item, prefix + (key,))


def test_any_field_of_the_wrong_kind_loads_or_fails_in_one_line(tmp_path):
    """Each value of a small file using every mapped feature (texture, glass, spot light, camera), replaced
    in turn by each of MUTANTS, either loads or raises one CausticaError line: never another exception."""
    import copy

    from caustica.errors import CausticaError
    from caustica.scene.gltf.read import choose_camera, read_gltf

    doc = Doc()
    textured = doc.material(base=(0.5, 1, 1, 1), pbr={"baseColorTexture": g.TextureInfo(
        index=doc.image(np.full((2, 2, 3), 99, np.uint8)))})
    glass = doc.material(roughness=0.0, extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0},
                                                    "KHR_materials_volume": {"attenuationColor": [0.5, 0.5, 0.5],
                                                                             "attenuationDistance": 1.0}})
    child = doc.node(False, mesh=doc.mesh(plane(), glass), name="pane", scale=[1, 2, 1])
    doc.node(mesh=doc.mesh(plane(), textured, uvs=np.zeros((4, 2))), name="floor", children=[child])
    doc.light({"type": "spot", "intensity": 900.0, "spot": {"outerConeAngle": 0.5}}, translation=[0, 3, 0])
    doc.camera(translation=[0, 1, 4])
    base = json.loads(doc.save(tmp_path / "base.gltf").read_text())
    path, outcomes = tmp_path / "mutant.gltf", {"loaded": 0, "refused": 0}
    for where in json_paths(base):
        for mutant in MUTANTS:
            mutated = copy.deepcopy(base)
            parent = mutated
            for key in where[:-1]:
                parent = parent[key]
            parent[where[-1]] = mutant
            path.write_text(json.dumps(mutated))
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    imported = read_gltf(path)
                    choose_camera([imported], None, np.array([[-1.0, -1, -1], [1, 1, 1]]))
                outcomes["loaded"] += 1
            except CausticaError as error:
                assert str(error) and "\n" not in str(error), (where, mutant)
                outcomes["refused"] += 1
    assert outcomes["loaded"] > 100 and outcomes["refused"] > 100  # both kinds happen


def test_indices_out_of_range(tmp_path):
    doc = Doc()
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
    attributes = g.Attributes(POSITION=doc.accessor(vertices))
    indices = doc.accessor(np.array([0, 1, 3], np.uint16), g.UNSIGNED_SHORT, g.SCALAR)
    doc.gltf.meshes.append(g.Mesh(primitives=[g.Primitive(attributes=attributes, indices=indices)]))
    doc.node(mesh=0)
    with pytest.raises(MeshError) as error:
        load_scene(doc.save(tmp_path / "range.glb"))
    assert "indices out of range" in one_line(error)


def test_truncated_glb(tmp_path):
    path = twin_gltf(tmp_path / "whole.glb")
    (tmp_path / "cut.glb").write_bytes(path.read_bytes()[:-100])
    with pytest.raises(SceneError) as error:
        load_scene(tmp_path / "cut.glb")
    assert "truncated" in one_line(error)
    (tmp_path / "tiny.glb").write_bytes(b"glTF\x02\x00")
    with pytest.raises(SceneError, match="truncated"):
        load_scene(tmp_path / "tiny.glb")
    from caustica.scene.gltf.read import read_gltf

    data = path.read_bytes()
    for cut in range(0, len(data), len(data) // 40):  # cut anywhere, or with its length field patched to fit
        for patched in (data[:cut], data[:8] + len(data[:cut]).to_bytes(4, "little") + data[12:cut]):
            (tmp_path / "cut.glb").write_bytes(patched)
            with pytest.raises(SceneError) as error:
                read_gltf(tmp_path / "cut.glb")
            one_line(error)


def test_unreadable_image(tmp_path):
    doc = Doc()
    doc.gltf.images.append(g.Image(bufferView=doc.view(b"not a png at all"), mimeType="image/png"))
    doc.gltf.textures.append(g.Texture(source=0))
    material = doc.material(pbr={"baseColorTexture": g.TextureInfo(index=0)})
    doc.node(mesh=doc.mesh(plane(), material, uvs=np.zeros((4, 2))))
    with pytest.raises(SceneError) as error:
        load_scene(doc.save(tmp_path / "image.glb"))
    assert "images[0]" in one_line(error) and "cannot read" in str(error.value)


def test_export_refuses_an_unknown_suffix(tmp_path):
    with pytest.raises(OutputError) as error:
        export_scene(load_scene("caustic-sphere"), tmp_path / "scene.obj")
    assert ".glb" in one_line(error) and not (tmp_path / "scene.obj").exists()


def test_export_to_xml_calls_the_mitsuba_writer(tmp_path, monkeypatch):
    from caustica.reference import mitsuba_export

    calls = []
    monkeypatch.setattr(mitsuba_export, "write_mitsuba_xml", lambda scene, path: calls.append((scene.name, path)),
                        raising=False)
    export_scene(load_scene("caustic-sphere"), tmp_path / "out.xml")
    assert calls == [("caustic-sphere", tmp_path / "out.xml")]


# Command line --------------------------------------------------------------------


def test_cli_render_and_export(tmp_path, capsys):
    model = twin_gltf(tmp_path / "model.glb")
    assert main(["render", str(model), "-t", "plain", "--size", "32x24", "-o", str(tmp_path / "a.png")]) == 0
    assert (tmp_path / "a.png").is_file()
    assert main(["export", "caustic-sphere", "-o", str(tmp_path / "cs.glb")]) == 0
    assert main(["render", str(tmp_path / "cs.glb"), "-t", "plain", "--size", "32x24", "-o",
                 str(tmp_path / "b.png")]) == 0
    capsys.readouterr()
    for argv in (["render", str(model), "--camera", "nope", "-o", str(tmp_path / "c.png")],
                 ["export", "caustic-sphere", "-o", str(tmp_path / "cs.obj")],
                 ["render", str(tmp_path / "missing.glb"), "-o", str(tmp_path / "d.png")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err.startswith("caustica: ") and err.count("\n") == 1 and "Traceback" not in err
    (tmp_path / "cut.glb").write_bytes(model.read_bytes()[:50])
    assert main(["render", str(tmp_path / "cut.glb"), "-o", str(tmp_path / "e.png")]) == 2
    assert "truncated" in capsys.readouterr().err
    assert not (tmp_path / "c.png").exists() and not (tmp_path / "cs.obj").exists()
