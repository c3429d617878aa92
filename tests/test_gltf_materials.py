"""glTF 2.0's metallic-roughness materials in and out of caustica.Principled (scene/gltf, docs/materials.md), the
TOML ``principled`` material, tangents from the file, and what ``caustica plan`` says of each material."""
from __future__ import annotations

import base64
import io
import json
import warnings

import numpy as np
import pygltflib as g
import pytest
from PIL import Image
from test_gltf import Doc, one_line

from caustica.errors import MeshError, SceneError
from caustica.images import srgb_to_linear
from caustica.planning.rules import drawn_as, plan
from caustica.scene import Diffuse, Glass, Mirror, Scene, SceneObject
from caustica.scene.io import export_scene, load_scene
from caustica.scene.materials import Principled
from caustica.scene.mesh import Mesh
from caustica.scene.shapes import plane, sphere
from caustica.scene.tangents import mesh_tangents

RNG = np.random.default_rng(45)
CODES = RNG.integers(0, 256, (3, 5, 3), dtype=np.uint8)  # 8-bit images: what a PNG holds exactly


def colour(codes=CODES) -> np.ndarray:
    """The linear texture an sRGB PNG of ``codes`` decodes to."""
    return srgb_to_linear(codes / 255.0).astype(np.float32)


def data(codes=CODES) -> np.ndarray:
    """The texture a data PNG (normal, metallic-roughness, occlusion) of ``codes`` is."""
    return (codes / 255.0).astype(np.float32)


def every_field() -> Principled:
    """A Principled with every field away from its default, its textures 8-bit exact."""
    return Principled(base_color=[0.7, 0.5, 0.3], base_color_texture=colour(), metallic=0.6, roughness=0.35,
                      metallic_roughness_texture=data(CODES[::-1]), normal_texture=data(CODES[:, ::-1]),
                      normal_scale=0.75, occlusion_texture=data(CODES[::-1, ::-1]), occlusion_strength=0.5,
                      emission=[3.0, 1.5, 0.75], emission_texture=colour(CODES[:, :, ::-1]), specular=0.4,
                      specular_color=[1.2, 0.9, 0.6], transmission=0.3, ior=1.6, attenuation_color=[0.9, 0.7, 0.5],
                      attenuation_distance=2.5, thickness=0.2, dispersion=0.25)


FIELDS = ("base_color", "metallic", "roughness", "normal_scale", "occlusion_strength", "emission", "specular",
          "specular_color", "transmission", "ior", "attenuation_color", "attenuation_distance", "thickness",
          "dispersion") + Principled.TEXTURES


def assert_same_material(back, material) -> None:
    assert type(back) is type(material)
    for name in FIELDS:
        x, y = getattr(material, name), getattr(back, name)
        assert (x is None) == (y is None), name
        if x is not None:
            np.testing.assert_allclose(y, x, rtol=1e-6, atol=1e-6, err_msg=name)


def textured_scene(material, tangents: bool = True) -> Scene:
    quad = plane((2.0, 2.0), 2)
    if tangents:
        frames = np.tile([0.0, 0.0, 1.0, -1.0], (len(quad.vertices), 1))
        quad = Mesh(quad.vertices, quad.normals, quad.faces, name="quad", uvs=quad.uvs, tangents=frames)
    return Scene(objects=[SceneObject("panel", quad, material)])


def written(path) -> dict:
    if path.suffix == ".gltf":
        return json.loads(path.read_text())
    raw = path.read_bytes()
    length = int.from_bytes(raw[12:16], "little")
    return json.loads(raw[20:20 + length])


def quiet_load(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_scene(path)


def quiet_export(scene, path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return export_scene(scene, path)


@pytest.fixture(autouse=True)
def _one_texture(monkeypatch):
    """Every Doc of these tests has one texture at index 0 (an image of CODES) before its materials."""
    original = Doc.__init__

    def init(self):
        original(self)
        self.image(CODES)

    monkeypatch.setattr(Doc, "__init__", init)


# Round trips ------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".glb", ".gltf"])
def test_principled_round_trips_every_field(tmp_path, suffix):
    """Every field of a Principled, its five textures and the mesh's own tangents come back from caustica's glTF;
    the file declares each extension it uses and puts emission above 1 into KHR_materials_emissive_strength."""
    material = every_field()
    scene = textured_scene(material)
    path = quiet_export(scene, tmp_path / f"panel{suffix}")
    back = quiet_load(path).objects[0]
    assert_same_material(back.material, material)
    np.testing.assert_array_equal(back.mesh.tangents, scene.objects[0].mesh.tangents)
    doc = written(path)
    entry = doc["materials"][0]
    assert set(doc["extensionsUsed"]) == {"KHR_materials_specular", "KHR_materials_emissive_strength",
                                          "KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                                          "KHR_materials_dispersion"} == set(entry["extensions"])
    assert entry["extensions"]["KHR_materials_emissive_strength"] == {"emissiveStrength": 3.0}
    assert entry["emissiveFactor"] == pytest.approx([1.0, 0.5, 0.25])
    assert entry["normalTexture"]["scale"] == 0.75 and entry["occlusionTexture"]["strength"] == 0.5
    assert "TANGENT" in doc["meshes"][0]["primitives"][0]["attributes"]


def test_glass_role_principled_round_trips(tmp_path):
    """Frosted, tinted glass (drawn smooth and clear for now) keeps its roughness and tint through glTF."""
    material = Principled(base_color=[0.8, 0.9, 1.0], roughness=0.35, transmission=0.9, ior=1.45,
                          attenuation_color=[0.6, 0.8, 0.9], attenuation_distance=0.5, thickness=0.1)
    assert material.kind == "glass"
    back = quiet_load(quiet_export(textured_scene(material, tangents=False), tmp_path / "frosted.glb"))
    assert_same_material(back.objects[0].material, material)


def test_texture_colour_spaces_on_export(tmp_path):
    """Base colour and emission PNGs hold sRGB codes, the data textures their linear values (8-bit codes both)."""
    material = every_field()
    doc = written(quiet_export(textured_scene(material), tmp_path / "panel.gltf"))
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    entry, pbr = doc["materials"][0], doc["materials"][0]["pbrMetallicRoughness"]

    def codes(info) -> np.ndarray:
        image = doc["images"][doc["textures"][info["index"]]["source"]]
        view = doc["bufferViews"][image["bufferView"]]
        png = blob[view.get("byteOffset", 0):view.get("byteOffset", 0) + view["byteLength"]]
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))

    np.testing.assert_array_equal(codes(pbr["baseColorTexture"]), CODES)
    np.testing.assert_array_equal(codes(entry["emissiveTexture"]), CODES[:, :, ::-1])
    np.testing.assert_array_equal(codes(pbr["metallicRoughnessTexture"]), CODES[::-1])
    np.testing.assert_array_equal(codes(entry["normalTexture"]), CODES[:, ::-1])
    np.testing.assert_array_equal(codes(entry["occlusionTexture"]), CODES[::-1, ::-1])


def test_shorthands_round_trip_as_themselves(tmp_path):
    """caustica's Diffuse is written with KHR_materials_specular factor 0 (glTF's dielectric has a 0.04 specular
    layer without it) and read back a Diffuse; Mirror and Glass come back as themselves."""
    quad = plane()
    scene = Scene(objects=[SceneObject("chalk", quad, Diffuse([0.3, 0.5, 0.7], texture=colour())),
                           SceneObject("chrome", quad, Mirror([0.9, 0.8, 0.7])),
                           SceneObject("glass", sphere(0.5, 2), Glass(ior=1.7, abbe=40.0))])
    path = quiet_export(scene, tmp_path / "three.gltf")
    chalk = written(path)["materials"][0]
    assert chalk["extensions"] == {"KHR_materials_specular": {"specularFactor": 0.0}}
    back = quiet_load(path)
    for a, b in zip(scene.objects, back.objects, strict=True):
        assert type(b.material) is type(a.material)
    np.testing.assert_allclose(back.objects[0].material.texture, colour(), atol=1e-6)
    assert back.objects[2].material.abbe == pytest.approx(40.0)


# Reading ------------------------------------------------------------------------------


def one_material(tmp_path, uvs=True, generator=None, asset_extras=None, **material) -> tuple:
    """(the material of a one-quad file with ``material``, the warnings while loading it)."""
    doc = Doc()
    if generator is not None:
        doc.gltf.asset.generator = generator
    if asset_extras is not None:
        doc.gltf.asset.extras = asset_extras
    quad = plane()
    doc.node(mesh=doc.mesh(quad, doc.material(**material), uvs=quad.uvs if uvs else None), name="panel")
    doc.camera(translation=[0, 0, 5])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = load_scene(doc.save(tmp_path / "one.glb"))
    notes = [str(w.message) for w in caught if "not supported" in str(w.message)]
    return scene.objects[0].material, notes


def test_plain_dielectric_is_glossy_and_specular_zero_is_diffuse(tmp_path):
    glossy, _ = one_material(tmp_path, base=(0.2, 0.4, 0.8, 1), roughness=0.5)
    assert isinstance(glossy, Principled) and glossy.glossy and glossy.kind == "diffuse"
    np.testing.assert_allclose(glossy.f0, 0.04)
    lambertian, _ = one_material(tmp_path, base=(0.2, 0.4, 0.8, 1), roughness=0.5,
                                 extensions={"KHR_materials_specular": {"specularFactor": 0.0}})
    assert isinstance(lambertian, Diffuse)
    np.testing.assert_allclose(lambertian.color, [0.2, 0.4, 0.8])


def test_files_of_earlier_caustica_read_as_before(tmp_path):
    """caustica wrote its Diffuse as metallic 0 alone before its materials were glTF's: such a file (caustica's
    generator, no asset.extras.caustica.materials) still reads as a Diffuse; with the mark, as glTF says."""
    fields = dict(base=(0.7, 0.6, 0.5, 1), metallic=0.0, roughness=1.0, generator="caustica 0.1.0")
    old, _ = one_material(tmp_path, **fields)
    assert isinstance(old, Diffuse)
    new, _ = one_material(tmp_path, asset_extras={"caustica": {"materials": "metallic-roughness"}}, **fields)
    assert isinstance(new, Principled) and new.specular == 1.0
    other, _ = one_material(tmp_path, **dict(fields, generator="Khronos glTF Blender I/O v5.0.21"))
    assert isinstance(other, Principled)


def test_every_glTF_field_is_read(tmp_path):
    doc_textures = Doc()
    image = doc_textures.image(CODES)
    material = dict(base=(0.9, 0.8, 0.7, 1), metallic=1.0, roughness=0.25,
                    pbr={"baseColorTexture": g.TextureInfo(index=image),
                         "metallicRoughnessTexture": g.TextureInfo(index=image)},
                    normalTexture=g.NormalMaterialTexture(index=image, scale=0.5),
                    occlusionTexture=g.OcclusionTextureInfo(index=image, strength=0.25),
                    emissiveTexture=g.TextureInfo(index=image), emissiveFactor=[1.0, 0.5, 0.0],
                    extensions={"KHR_materials_emissive_strength": {"emissiveStrength": 4.0},
                                "KHR_materials_specular": {"specularFactor": 0.5,
                                                           "specularColorFactor": [1.0, 0.9, 0.8]}})
    quad = plane()
    doc_textures.node(mesh=doc_textures.mesh(quad, doc_textures.material(**material), uvs=quad.uvs), name="cap")
    doc_textures.camera(translation=[0, 0, 5])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # all of it is drawn: nothing is warned
        read = load_scene(doc_textures.save(tmp_path / "cap.glb")).objects[0].material
    assert isinstance(read, Principled) and (read.metallic, read.roughness) == (1.0, 0.25)
    assert (read.normal_scale, read.occlusion_strength, read.specular) == (0.5, 0.25, 0.5)
    np.testing.assert_allclose(read.emission, [4.0, 2.0, 0.0])
    np.testing.assert_allclose(read.specular_color, [1.0, 0.9, 0.8])
    # One image, decoded per use: colour (base, emission) from sRGB, data (the others) as its codes.
    for name in ("base_color_texture", "emission_texture"):
        np.testing.assert_allclose(getattr(read, name), colour(), atol=1e-6, err_msg=name)
    for name in ("metallic_roughness_texture", "normal_texture", "occlusion_texture"):
        np.testing.assert_allclose(getattr(read, name), data(), atol=1e-6, err_msg=name)


def test_what_is_drawn_is_not_warned_and_what_is_not_is(tmp_path):
    info = {"pbr": {"metallicRoughnessTexture": g.TextureInfo(index=0)}}
    _, notes = one_material(tmp_path, metallic=1.0, roughness=0.5, **info)
    assert notes == []
    cases = [
        (dict(roughness=0.35, extensions={"KHR_materials_transmission": {"transmissionFactor": 1.0}}),
         "roughness on glass"),
        (dict(base=(0.5, 0.8, 1, 1), roughness=0.0, extensions={"KHR_materials_transmission": {"transmissionFactor": 1}}),
         "baseColorFactor tint on glass"),
        (dict(extensions={"KHR_materials_clearcoat": {"clearcoatFactor": 1.0}}), "KHR_materials_clearcoat"),
        (dict(alphaMode="MASK"), "alphaMode 'MASK'"),
        (dict(extensions={"KHR_materials_specular": {"specularTexture": {"index": 0}}}),
         "KHR_materials_specular textures"),
        (dict(normalTexture=g.NormalMaterialTexture(index=0, texCoord=1)), "normalTexture on TEXCOORD_1"),
        (dict(pbr={"baseColorTexture": g.TextureInfo(index=0, extensions={"KHR_texture_transform": {}})}),
         "KHR_texture_transform"),
        (dict(extensions={"KHR_materials_transmission": {"transmissionFactor": 0.3}}), "transmission below 0.5"),
    ]
    for fields, feature in cases:
        _, notes = one_material(tmp_path, **fields)
        assert len(notes) == 1 and f"{feature}" in notes[0] and "'panel'" in notes[0], (feature, notes)


def test_a_normal_map_on_a_mesh_without_uvs_is_warned(tmp_path):
    _, notes = one_material(tmp_path, uvs=False, normalTexture=g.NormalMaterialTexture(index=0))
    assert len(notes) == 1 and "textures on a mesh without TEXCOORD_0 ('panel')" in notes[0]


# Tangents ------------------------------------------------------------------------------


def test_file_tangents_are_read_normalised_and_preferred(tmp_path):
    quad = plane()
    doc = Doc()
    index = doc.mesh(quad, doc.material(normalTexture=g.NormalMaterialTexture(index=0)), uvs=quad.uvs)
    frames = np.tile([0.0, 0.0, 2.0, -1.0], (len(quad.vertices), 1)).astype(np.float32)  # xyz not unit
    doc.gltf.meshes[index].primitives[0].attributes.TANGENT = doc.accessor(frames, kind=g.VEC4)
    doc.node(mesh=index, name="panel")
    doc.camera(translation=[0, 0, 5])
    mesh = quiet_load(doc.save(tmp_path / "tangents.glb")).objects[0].mesh
    np.testing.assert_allclose(mesh.tangents, np.tile([0.0, 0.0, 1.0, -1.0], (len(quad.vertices), 1)))
    assert mesh_tangents(mesh) is mesh.tangents
    generated = mesh_tangents(plane())
    assert not np.allclose(generated, mesh.tangents)  # the file's own frames, not the generated ones
    frames[:, 3] = 0.0  # no handedness: the file's frames are dropped, and generated from the uvs instead
    doc.gltf.meshes[index].primitives[0].attributes.TANGENT = doc.accessor(frames, kind=g.VEC4)
    mesh = quiet_load(doc.save(tmp_path / "no-handedness.glb")).objects[0].mesh
    assert mesh.tangents is None
    np.testing.assert_allclose(mesh_tangents(mesh), generated, atol=1e-6)


def test_mesh_tangents_are_checked_and_hashed():
    quad = plane()
    good = np.tile([1.0, 0.0, 0.0, 1.0], (len(quad.vertices), 1))
    with_tangents = Mesh(quad.vertices, quad.normals, quad.faces, uvs=quad.uvs, tangents=good)
    plain = Mesh(quad.vertices, quad.normals, quad.faces, uvs=quad.uvs)
    assert with_tangents.tangents.dtype == np.float32
    assert with_tangents.content_hash() != plain.content_hash()
    flipped = good * [1, 1, 1, -1]
    assert Mesh(quad.vertices, quad.normals, quad.faces, uvs=quad.uvs, tangents=flipped).content_hash() != \
        with_tangents.content_hash()
    for bad in (good[:, :3], good[:-1], good * [1, 1, 1, 0], np.where(good == 1.0, np.nan, good)):
        with pytest.raises(MeshError, match="invalid tangents"):
            Mesh(quad.vertices, quad.normals, quad.faces, uvs=quad.uvs, tangents=bad)


def test_mirroring_a_mesh_flips_its_handedness():
    quad = plane()
    frames = np.tile([1.0, 0.0, 0.0, 1.0], (len(quad.vertices), 1))
    mesh = Mesh(quad.vertices, quad.normals, quad.faces, uvs=quad.uvs, tangents=frames)
    mirrored = mesh.transformed(np.diag([-1.0, 1.0, 1.0, 1.0]))
    np.testing.assert_allclose(mirrored.tangents, np.tile([-1.0, 0.0, 0.0, -1.0], (len(quad.vertices), 1)))
    # The frame agrees with the one generated from the mirrored uvs and positions.
    np.testing.assert_allclose(mirrored.tangents, mesh_tangents(Mesh(mirrored.vertices, mirrored.normals,
                                                                     mirrored.faces, uvs=mirrored.uvs)), atol=1e-6)


# TOML -----------------------------------------------------------------------------------


def test_toml_principled_with_every_key(tmp_path):
    Image.fromarray(CODES, "RGB").save(tmp_path / "tex.png")
    (tmp_path / "scene.toml").write_text("""
[[objects]]
shape = "plane"
[objects.material]
type = "principled"
base_color = [0.7, 0.5, 0.3]
base_color_texture = "tex.png"
metallic = 0.6
roughness = 0.35
metallic_roughness_texture = "tex.png"
normal_texture = "tex.png"
normal_scale = 0.75
occlusion_texture = "tex.png"
occlusion_strength = 0.5
emission = [3, 1.5, 0.75]
emission_texture = "tex.png"
specular = 0.4
specular_color = [1.2, 0.9, 0.6]
transmission = 0.3
ior = 1.6
attenuation_color = [0.9, 0.7, 0.5]
attenuation_distance = 2.5
thickness = 0.2
dispersion = 0.25
""")
    read = load_scene(tmp_path / "scene.toml").objects[0].material
    expected = every_field()
    for name in FIELDS:
        if not name.endswith("_texture"):
            np.testing.assert_allclose(getattr(read, name), getattr(expected, name), err_msg=name)
    for name in ("base_color_texture", "emission_texture"):
        np.testing.assert_allclose(getattr(read, name), colour(), atol=1e-6, err_msg=name)
    for name in ("metallic_roughness_texture", "normal_texture", "occlusion_texture"):
        np.testing.assert_allclose(getattr(read, name), data(), atol=1e-6, err_msg=name)
    # and through glTF back to the same fields
    back = quiet_load(quiet_export(load_scene(tmp_path / "scene.toml"), tmp_path / "scene.glb")).objects[0].material
    assert_same_material(back, read)


@pytest.mark.parametrize("material, message", [
    ("{ type = 'principled', metalic = 1 }", "unknown key 'metalic' in objects[0].material (did you mean 'metallic'?)"),
    ("{ type = 'principled', roughness = 1.5 }", "objects[0].material.roughness 1.5 must be a number in [0, 1]"),
    ("{ type = 'principled', base_color = 'red' }", "objects[0].material.base_color must be a number or three"),
    ("{ type = 'principled', normal_texture = 'bumps' }", "objects[0].material.normal_texture 'bumps' is no procedural"),
    ("{ type = 'principled', occlusion_texture = 'missing.png' }",
     "objects[0].material.occlusion_texture file not found"),
])
def test_toml_principled_errors_are_one_line_naming_the_key(tmp_path, material, message):
    (tmp_path / "bad.toml").write_text(f"[[objects]]\nshape = 'plane'\nmaterial = {material}\n")
    with pytest.raises(SceneError) as error:
        load_scene(tmp_path / "bad.toml")
    assert message in one_line(error)


def test_toml_texture_needs_uvs(tmp_path):
    (tmp_path / "ball.toml").write_text("[[objects]]\nshape = 'sphere'\n"
                                        "material = { type = 'principled', normal_texture = 'checker' }\n")
    with pytest.raises(SceneError) as error:
        load_scene(tmp_path / "ball.toml")
    assert "objects[0].material.normal_texture needs texture coordinates" in one_line(error)


# caustica plan ---------------------------------------------------------------------------


def test_plan_says_how_each_material_is_drawn(capsys, tmp_path):
    assert drawn_as(Principled(base_color=[1, 0.8, 0.4], metallic=1.0, roughness=0.25)) == \
        "glossy metal, GGX roughness 0.25"
    assert drawn_as(Principled(base_color=[1, 1, 1], transmission=1.0, roughness=0.35)) == \
        "glass, smooth: roughness 0.35 not drawn"
    assert drawn_as(Principled(metallic=0.0, specular=0.0, normal_texture=data())) == "diffuse, normal map"
    assert drawn_as(Principled(roughness=0.2)) == "glossy dielectric, GGX roughness 0.2"
    assert drawn_as(Principled(metallic=0.95, roughness=0.02)) == \
        "mirror, perfectly smooth: roughness 0.02 not drawn"
    assert (drawn_as(Diffuse()), drawn_as(Mirror()), drawn_as(Glass())) == ("diffuse", "mirror", "glass")
    (tmp_path / "shot.toml").write_text("""
[[objects]]
name = "cap"
shape = "sphere"
material = { type = "principled", base_color = [1, 0.8, 0.4], metallic = 1, roughness = 0.25 }
[[objects]]
name = "floor"
shape = "plane"
size = [4, 4]
position = [0, -1, 0]
""")
    chosen = plan(load_scene(tmp_path / "shot.toml"), "draft")
    assert [e.material for e in chosen.objects] == ["glossy metal, GGX roughness 0.25", "diffuse"]
    from caustica.cli import main

    assert main(["plan", str(tmp_path / "shot.toml"), "--quality", "draft"]) == 0
    out = capsys.readouterr().out
    assert "  cap (glossy metal, GGX roughness 0.25): " in out and "  floor (diffuse): " in out
