"""The GPU layer: shader includes with #line mapping, defines, program cache, targets, pass wiring."""
from __future__ import annotations

import numpy as np
import pytest

from caustica.gpu.shaders import ShaderError, ShaderLibrary
from caustica.render.frame import Channel, Frame, Pass, PassWiringError
from caustica.render.graph import run_passes


@pytest.fixture()
def ctx(renderer):
    return renderer.device.ctx


def _write(root, name, text):
    path = root / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_compile_error_points_at_included_file_and_line(ctx, tmp_path):
    _write(tmp_path, "common/helper.glsl", "// helper\nfloat twice(float x) {\n    return 2.0 * x + undefined_name;\n}\n")
    _write(tmp_path, "main.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n#include \"common/helper.glsl\"\nvoid main() { twice(1.0); }\n")
    library = ShaderLibrary(ctx, tmp_path)
    with pytest.raises(ShaderError) as err:
        library.compute("main.comp")
    assert "common/helper.glsl:3" in str(err.value)
    assert "\n" not in str(err.value)


def test_error_after_include_maps_back_to_including_file(ctx, tmp_path):
    _write(tmp_path, "common/ok.glsl", "float one() { return 1.0; }\n")
    _write(tmp_path, "main.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n#include \"common/ok.glsl\"\nvoid main() {\n    float x = one() + oops;\n}\n")
    with pytest.raises(ShaderError) as err:
        ShaderLibrary(ctx, tmp_path).compute("main.comp")
    assert "main.comp:5" in str(err.value)


def test_unknown_include_fails_loudly(ctx, tmp_path):
    _write(tmp_path, "main.comp", "#version 430 core\n#include \"common/nope.glsl\"\nvoid main() {}\n")
    with pytest.raises(ShaderError, match="common/nope.glsl.*not found"):
        ShaderLibrary(ctx, tmp_path).source("main.comp")


def test_defines_injected_after_version_and_programs_cached(ctx, tmp_path):
    _write(tmp_path, "value.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n"
           "layout(std430, binding = 0) buffer Out { float result; };\nvoid main() { result = VALUE; }\n")
    library = ShaderLibrary(ctx, tmp_path)
    source, files = library.source("value.comp", {"VALUE": 2.5})
    assert source.splitlines()[0] == "#version 430 core" and "#define VALUE 2.5" in source
    program = library.compute("value.comp", {"VALUE": 2.5})
    assert library.compute("value.comp", {"VALUE": 2.5}) is program
    assert library.compute("value.comp", {"VALUE": 1.0}) is not program
    buffer = ctx.buffer(reserve=4)
    buffer.bind_to_storage_buffer(0)
    program.run(1)
    assert np.frombuffer(buffer.read(), "f4")[0] == 2.5


def test_library_defines_the_codes_in_every_program_and_keeps_them(ctx, tmp_path):
    from caustica.scene.codes import CODE_DEFINES, LIGHT_SPOT, MATERIAL_GLASS

    _write(tmp_path, "codes.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n"
           "layout(std430, binding = 0) buffer Out { int result[2]; };\n"
           "void main() { result[0] = MATERIAL_GLASS; result[1] = LIGHT_SPOT; }\n")
    library = ShaderLibrary(ctx, tmp_path)
    assert library.defines == CODE_DEFINES
    buffer = ctx.buffer(reserve=8)
    buffer.bind_to_storage_buffer(0)
    library.compute("codes.comp").run(1)
    assert np.frombuffer(buffer.read(), "i4").tolist() == [MATERIAL_GLASS, LIGHT_SPOT]
    with pytest.raises(ShaderError, match="LIGHT_SPOT is set by the shader library"):
        library.source("codes.comp", {"LIGHT_SPOT": 7})


def test_strict_uniforms_catch_a_misspelling_but_not_an_optimised_away_uniform(ctx, tmp_path, monkeypatch):
    from caustica.gpu import meshes
    from caustica.gpu.meshes import set_uniform, write_uniform_array

    _write(tmp_path, "u.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n"
           "uniform float used_value;\nuniform float unused_value, unused_list[4];  // optimised away\n"
           "layout(std430, binding = 0) buffer Out { float result; };\nvoid main() { result = used_value; }\n")
    program = ShaderLibrary(ctx, tmp_path).compute("u.comp")
    monkeypatch.setattr(meshes, "STRICT_UNIFORMS", True)
    set_uniform(program, "used_value", 1.0)
    set_uniform(program, "unused_value", 1.0)  # declared: the driver dropped it, no error
    write_uniform_array(program, "unused_list", np.zeros(4, "f4"))
    with pytest.raises(ShaderError, match="'used_valeu'.*did you mean 'used_value'"):
        set_uniform(program, "used_valeu", 1.0)
    monkeypatch.setattr(meshes, "STRICT_UNIFORMS", False)
    set_uniform(program, "used_valeu", 1.0)  # production: silent


def test_second_renderer_on_the_context_compiles_no_program():
    """Programs belong to the GL context: a Renderer made after another one closed renders the same
    images without compiling a program, and holds its own count of them."""
    from caustica.gpu.shaders import context_programs
    from caustica.renderer import Renderer
    from caustica.scene.io import load_scene

    scene = load_scene("caustic-sphere")
    jobs = [("env-map", {}), ("caustic-mapping", {"map_size": 64})]
    with Renderer((32, 24)) as first:
        before = [first.render(scene, technique, **options) for technique, options in jobs]
        programs = first.device.counts()["programs"]
    with Renderer((32, 24)) as second:
        cache = context_programs(second.device.ctx)
        compiles = cache.compiles
        after = [second.render(scene, technique, **options) for technique, options in jobs]
        assert cache.compiles == compiles
        assert second.device.counts()["programs"] == programs > 0
    assert all(np.array_equal(a, b) for a, b in zip(before, after))


def _value_shader(tmp_path):
    _write(tmp_path, "value.comp", "#version 430 core\nlayout(local_size_x = 1) in;\nuniform float offset;\n"
           "layout(std430, binding = 0) buffer Out { float result; };\nvoid main() { result = VALUE + offset; }\n")


def test_a_shared_program_comes_back_as_compiled(ctx, tmp_path):
    """What one library wrote into a program (a uniform, a block binding) is undone before the next
    library gets it: a new Renderer sees a program as if freshly compiled."""
    from caustica.gpu.meshes import set_uniform

    _value_shader(tmp_path)
    first = ShaderLibrary(ctx, tmp_path)
    program = first.compute("value.comp", {"VALUE": 2.0})
    set_uniform(program, "offset", 5.0)
    program["Out"].binding = 3
    first.release()
    second = ShaderLibrary(ctx, tmp_path)
    assert second.compute("value.comp", {"VALUE": 2.0}) is program
    assert program["offset"].value == 0.0 and program["Out"].binding == 0
    buffer = ctx.buffer(reserve=4)
    buffer.bind_to_storage_buffer(0)
    program.run(1)
    assert np.frombuffer(buffer.read(), "f4")[0] == 2.0
    buffer.release()
    second.release()


def test_idle_programs_are_bounded_and_released(ctx, tmp_path, monkeypatch):
    """Programs no library holds stay up to the context's idle limit, least recently released going
    first; a library dropped without release lets go of its programs at the next compile; with no
    idle limit (a context the caller owns, the viewer's window) release frees every program."""
    from caustica.gpu import shaders
    from caustica.gpu.census import live_gl_names

    _value_shader(tmp_path)
    cache = shaders.ContextPrograms(idle_limit=1)
    monkeypatch.setitem(shaders._context_programs, ctx, cache)
    library = ShaderLibrary(ctx, tmp_path)
    old, kept = (library.compute("value.comp", {"VALUE": float(v)}) for v in (1, 2))
    other = ShaderLibrary(ctx, tmp_path)
    assert other.compute("value.comp", {"VALUE": 1.0}) is old and cache.compiles == 2
    library.release()
    assert cache.counts() == {"programs": 2, "idle": 1, "compiles": 2}  # `old` is still held by `other`
    other.release()
    assert cache.counts() == {"programs": 1, "idle": 1, "compiles": 2}  # `old` released last: `kept` went
    assert ShaderLibrary(ctx, tmp_path).compute("value.comp", {"VALUE": 1.0}) is old
    import gc

    gc.collect()  # the library above was dropped unreleased
    names = live_gl_names(ctx)["program"]
    ShaderLibrary(ctx, tmp_path).compute("value.comp", {"VALUE": 3.0})
    gc.collect()
    assert cache.counts()["idle"] == 1 and cache.compiles == 3
    cache.idle_limit = 0
    cache.release_idle()
    assert cache.counts()["programs"] == 0 and live_gl_names(ctx)["program"] < names

def test_target_pool_reuses_by_size_and_format(renderer):
    pool = renderer.device.targets
    a = pool.texture((32, 16), "r32f")
    pool.give_back(a)
    assert pool.texture((32, 16), "r32f") is a
    b = pool.texture((32, 16), "rgba32f")
    assert b is not a and b.components == 4
    pool.give_back(b)
    pool.give_back(a)  # the session's shared renderer keeps nothing lent


def test_pass_wiring_checks_reads_and_writes():
    class Writes(Pass):
        writes = (Channel("x", "r32f", "a value"),)

        def run(self, frame):
            frame.write("x", 1)

    class Reads(Pass):
        reads = ("x",)

        def run(self, frame):
            frame.write("y", frame.read("x") + 1)

    class Lies(Pass):
        writes = (Channel("z", "r32f", "never written"),)

        def run(self, frame):
            pass

    frame = Frame(None, None, None, None)
    run_passes([Writes(), Reads()], frame)
    assert frame.read("y") == 2
    with pytest.raises(PassWiringError, match="reads"):
        run_passes([Reads()], Frame(None, None, None, None))
    with pytest.raises(PassWiringError, match="did not write"):
        run_passes([Lies()], Frame(None, None, None, None))


def test_glsl_fresnel_matches_closed_form(renderer, tmp_path):
    """The shaders' Fresnel equals the exact unpolarised formula; 0.04 at normal incidence for IOR 1.5."""
    ctx = renderer.device.ctx
    _write(tmp_path, "fresnel.comp", "#version 430 core\nlayout(local_size_x = 1) in;\n"
           "#include \"common/optics.glsl\"\n"
           "layout(std430, binding = 0) buffer In { vec4 args[]; };\n"
           "layout(std430, binding = 1) buffer Out { float result[]; };\n"
           "void main() { uint i = gl_GlobalInvocationID.x; result[i] = fresnel_dielectric(args[i].x, args[i].y, args[i].z); }\n")
    library = ShaderLibrary(ctx, tmp_path)
    library._expand  # the shipped common/optics.glsl is what we test: copy it in
    from caustica.gpu.shaders import SHADER_ROOT

    _write(tmp_path, "common/optics.glsl", (SHADER_ROOT / "common/optics.glsl").read_text())
    angles = np.radians([0.0, 30.0, 60.0, 80.0, 0.0, 30.0, 45.0])
    etas = [(1.0, 1.5)] * 4 + [(1.5, 1.0)] * 3
    args = np.array([[np.cos(a), ei, et, 0.0] for a, (ei, et) in zip(angles, etas)], dtype="f4")
    inp, out = ctx.buffer(args.tobytes()), ctx.buffer(reserve=4 * len(args))
    inp.bind_to_storage_buffer(0)
    out.bind_to_storage_buffer(1)
    library.compute("fresnel.comp").run(len(args))
    got = np.frombuffer(out.read(), "f4")

    def closed_form(theta, n1, n2):
        s = n1 / n2 * np.sin(theta)
        if s >= 1:
            return 1.0
        ct, ci = np.sqrt(1 - s * s), np.cos(theta)
        rs = ((n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)) ** 2
        rp = ((n1 * ct - n2 * ci) / (n1 * ct + n2 * ci)) ** 2
        return 0.5 * (rs + rp)

    expected = [closed_form(a, ei, et) for a, (ei, et) in zip(angles, etas)]
    assert got[0] == pytest.approx(0.04, abs=1e-6)
    assert got[4] == pytest.approx(0.04, abs=1e-6)
    assert got[6] == 1.0  # 45 degrees inside glass is past the critical angle (41.8)
    np.testing.assert_allclose(got, expected, atol=1e-5)


@pytest.mark.parametrize("spp", [4, 9])
def test_supersampled_frames_are_box_filtered_on_the_gpu(spp):
    """k x k samples per pixel are averaged on the GPU: the same image as the block mean of the
    full-resolution colour channel."""
    import caustica
    from caustica.renderer import Renderer
    from caustica.techniques.raster import box_downsample, read_rgb

    scene = caustica.load_scene("glass-sphere")
    keeper = Renderer((40, 30), keep_channels=True)
    image = keeper.render(scene, "depth-search", spp=spp)
    full = read_rgb(keeper.channels["color"])
    k = int(round(spp ** 0.5))
    assert full.shape == (30 * k, 40 * k, 3)
    np.testing.assert_allclose(image, box_downsample(full, k), rtol=1e-5, atol=1e-6)


def test_face_order_keeps_every_face_and_its_winding_and_shares_vertices():
    """GpuMesh draws faces along a Morton curve: the same triangles, wound the same way, with
    neighbours close in the index buffer (fewer distinct vertices per batch of 96 indices)."""
    from caustica.gpu.meshes import local_face_order
    from caustica.scene.shapes import sphere

    mesh = sphere(1.0, subdivisions=4)
    ordered = local_face_order(mesh.vertices, mesh.faces)

    def canonical(faces):  # each face rotated to start at its smallest index: winding kept
        shift = np.argmin(faces, axis=1)
        rows = np.array([np.roll(f, -s) for f, s in zip(faces, shift)])
        return rows[np.lexsort(rows.T[::-1])]

    np.testing.assert_array_equal(canonical(ordered), canonical(mesh.faces))

    def shaded(faces):
        indices = faces.ravel()
        return sum(len(np.unique(indices[s:s + 96])) for s in range(0, len(indices), 96))

    assert shaded(ordered) < 0.5 * shaded(mesh.faces)


def test_include_may_carry_a_trailing_comment(ctx, tmp_path):
    _write(tmp_path, "common/one.glsl", "float one() { return 1.0; }\n")
    _write(tmp_path, "main.comp", "#version 430 core\n#include \"common/one.glsl\"  // one()\nvoid main() {}\n")
    source, files = ShaderLibrary(ctx, tmp_path).source("main.comp")
    assert "float one()" in source and files == ["main.comp", "common/one.glsl"]


def test_unreadable_include_line_names_the_file_and_line(ctx, tmp_path):
    _write(tmp_path, "main.comp", "#version 430 core\n\n#include <common/one.glsl>\nvoid main() {}\n")
    with pytest.raises(ShaderError, match=r"main.comp:3: cannot read the include"):
        ShaderLibrary(ctx, tmp_path).source("main.comp")
