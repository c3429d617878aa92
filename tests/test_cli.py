"""The command line: renders presets, and answers every bad input with one line and exit code 2."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from caustica.cli import main

GOOD_SCENE = """
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
size = [32, 32]

[environment]
procedural = "sky-checker"

[[objects]]
shape = "sphere"
radius = 1.0
material = { type = "glass", ior = 1.5 }
"""


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def write_scene(tmp_path: Path, text: str, name="scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def assert_one_line_error(code, err, *fragments):
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("caustica: ")
    assert "Traceback" not in err
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


@pytest.mark.parametrize("preset", ["glass-sphere", "caustic-sphere"])
def test_render_preset_writes_non_blank_image(preset, tmp_path, capsys):
    from caustica.images import read_image

    out = tmp_path / f"{preset}.png"
    code, stdout, _ = run_cli(["render", preset, "-o", out, "--size", "64x64", "--frames", "1"], capsys)
    assert code == 0
    assert f"wrote {out}" in stdout and "ms per frame" in stdout
    image = read_image(out)
    assert image.shape == (64, 64, 3)
    assert image.std() > 0.02 and image.max() > 0.1


def test_render_exr_is_linear_float(tmp_path, capsys):
    from caustica.images import read_image

    out = tmp_path / "x.exr"
    code, _, _ = run_cli(["render", write_scene(tmp_path, GOOD_SCENE), "-o", out], capsys)
    assert code == 0
    image = read_image(out)
    from caustica import load_scene
    from caustica.renderer import Renderer

    expected = Renderer().render(load_scene(tmp_path / "scene.toml"), "auto")  # the default technique
    assert image.dtype == np.float32
    np.testing.assert_allclose(image, expected, atol=1e-6)  # linear, unclipped, row 0 at the top


def test_techniques_lists_each_with_a_line(capsys):
    code, out, _ = run_cli(["techniques"], capsys)
    assert code == 0
    names = [line.split()[0] for line in out.strip().splitlines()]
    assert {"env-map", "exact", "plain"} <= set(names)


def test_info_prints_renderer_and_float_atomics(capsys):
    code, out, _ = run_cli(["info"], capsys)
    assert code == 0 and "renderer:" in out and "float atomics:" in out


BAD_SCENES = {
    "toml_syntax": ("[camera\nposition = [0, 0, 4]\n", ["line 1"]),
    "unknown_key": (GOOD_SCENE.replace("radius = 1.0", "radiu = 1.0"), ["radiu", "radius"]),
    "ior_zero": (GOOD_SCENE.replace("ior = 1.5", "ior = 0.0"), ["ior"]),
    "negative_radius": (GOOD_SCENE.replace("radius = 1.0", "radius = -1.0"), ["radius"]),
    "size_zero": (GOOD_SCENE.replace("size = [32, 32]", "size = [0, 32]"), ["size"]),
    "missing_mesh": (GOOD_SCENE.replace('shape = "sphere"\nradius = 1.0', 'mesh = "nowhere.obj"'), ["nowhere.obj"]),
    "unsupported_mesh": (GOOD_SCENE.replace('shape = "sphere"\nradius = 1.0', 'mesh = "model.xyz"'), [".xyz"]),
    "bad_environment": (GOOD_SCENE.replace('procedural = "sky-checker"', 'file = "broken.exr"'), ["broken.exr"]),
}


@pytest.mark.parametrize("case", sorted(BAD_SCENES))
def test_bad_scene_gives_one_line_and_no_output(case, tmp_path, capsys):
    text, fragments = BAD_SCENES[case]
    (tmp_path / "model.xyz").write_text("not a mesh")
    (tmp_path / "broken.exr").write_bytes(b"this is not an exr file")
    out = tmp_path / "out.png"
    code, _, err = run_cli(["render", write_scene(tmp_path, text), "-o", out], capsys)
    assert_one_line_error(code, err, *fragments)
    assert not out.exists()
    assert list(tmp_path.glob("out*")) == []


MESH_CASES = {
    "empty_mesh": ("empty.obj", "# nothing here\n", ["empty.obj"]),
    "nan_vertices": ("nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", ["NaN"]),
}


@pytest.mark.parametrize("case", sorted(MESH_CASES))
def test_bad_mesh_gives_one_line(case, tmp_path, capsys):
    name, content, fragments = MESH_CASES[case]
    (tmp_path / name).write_text(content)
    scene = write_scene(tmp_path, GOOD_SCENE.replace('shape = "sphere"\nradius = 1.0', f'mesh = "{name}"'))
    code, _, err = run_cli(["render", scene, "-o", tmp_path / "out.png"], capsys)
    assert_one_line_error(code, err, *fragments)
    assert not (tmp_path / "out.png").exists()


def test_missing_scene_file(tmp_path, capsys):
    code, _, err = run_cli(["render", tmp_path / "nope.toml", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "nope.toml")


def test_unknown_preset_suggests_nearest(tmp_path, capsys):
    code, _, err = run_cli(["render", "glass-spere", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "glass-spere", "glass-sphere")


def test_unknown_technique_suggests_nearest(tmp_path, capsys):
    code, _, err = run_cli(["render", "glass-sphere", "-t", "env-mapp", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "env-mapp", "env-map")


def test_unknown_technique_parameter(tmp_path, capsys):
    code, _, err = run_cli(["render", "glass-sphere", "-p", "shadow_map_sise=64", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "shadow_map_sise", "shadow_map_size")


def test_a_parameter_qualified_by_its_technique(tmp_path, capsys):
    """technique.name, as the error for a name two techniques of a combination share asks for, is taken from
    -p (it was refused as 'not a name'); a bad qualifier is a one-line error."""
    out = tmp_path / "o.png"
    args = ["render", "caustic-sphere", "--size", "24x24", "-t", "depth-search+caustic-mapping"]
    code, _, err = run_cli([*args, "-p", "caustic-mapping.map_size=64", "-o", out], capsys)
    assert code == 0 and out.is_file(), err
    code, _, err = run_cli([*args, "-p", "env-map.map_size=64", "-o", tmp_path / "p.png"], capsys)
    assert_one_line_error(code, err, "env_map", "caustic-mapping")
    code, _, err = run_cli([*args, "-p", "caustic-mapping..map_size=64", "-o", tmp_path / "q.png"], capsys)
    assert_one_line_error(code, err, "not a name")


def test_missing_output_directory(tmp_path, capsys):
    """A missing output folder is made (as batch makes its folder), only once the render succeeded; one that
    cannot be made (below a file) is refused before the render (issue 43: the quick start's out/)."""
    (tmp_path / "file").write_text("")
    code, _, err = run_cli(["render", "glass-sphere", "-o", tmp_path / "file" / "no" / "dir.png"], capsys)
    assert_one_line_error(code, err, "is a file, not a directory")
    code, _, err = run_cli(["render", "glass-sphere", "-o", tmp_path / "no" / "dir.png", "--size", "16x16",
                            "--timing-frames", "1"], capsys)
    assert code == 0 and (tmp_path / "no" / "dir.png").is_file(), err


def test_size_above_gl_limit(tmp_path, capsys, renderer):
    limit = renderer.info()["max_texture_size"]
    code, _, err = run_cli(["render", "glass-sphere", "--size", f"{limit + 1}x8", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "limit")
    assert not (tmp_path / "o.png").exists()


def test_size_zero_on_command_line(tmp_path, capsys):
    code, _, err = run_cli(["render", "glass-sphere", "--size", "0x64", "-o", tmp_path / "o.png"], capsys)
    assert_one_line_error(code, err, "0x64")


def test_real_process_exit_code_and_no_traceback(tmp_path):
    """Through a real process: exit status 2 and a single line on stderr."""
    result = subprocess.run([sys.executable, "-m", "caustica.cli", "render", str(tmp_path / "missing.toml"),
                             "-o", str(tmp_path / "o.png")], capture_output=True, text=True)
    assert result.returncode == 2
    assert_one_line_error(2, result.stderr, "missing.toml")


def test_python_dash_m_caustica_is_the_command(tmp_path):
    """``python -m caustica`` runs the same command line as the ``caustica`` script (it had no __main__)."""
    import caustica

    version = subprocess.run([sys.executable, "-m", "caustica", "--version"], capture_output=True, text=True)
    assert version.returncode == 0 and version.stdout.strip() == f"caustica {caustica.__version__}", version.stderr
    bad = subprocess.run([sys.executable, "-m", "caustica", "render", str(tmp_path / "missing.toml"),
                          "-o", str(tmp_path / "o.png")], capture_output=True, text=True)
    assert_one_line_error(bad.returncode, bad.stderr, "missing.toml")


def test_presets_lists_each_with_its_whole_first_paragraph(capsys):
    """One line per preset, its description whole (a wrapped docstring's first line stopped mid-sentence,
    'aberration-lens ... (red/green/blue) from an'), the names in one column."""
    from caustica.scene.presets import PRESETS

    code, out, _ = run_cli(["presets"], capsys)
    lines = out.splitlines()
    assert code == 0 and len(lines) == len(PRESETS)
    starts = {len(line) - len(line[len(line.split()[0]):].lstrip()) for line in lines}
    assert len(starts) == 1, starts  # every description starts in the same column
    assert all(line.rstrip().endswith(".") for line in lines), [line for line in lines if not line.endswith(".")]


def test_missing_egl_names_apt_packages(monkeypatch):
    import moderngl

    from caustica.errors import GLUnavailableError
    from caustica.gpu import context

    def no_egl(**kwargs):
        raise Exception("libEGL.so: cannot open shared object file: No such file or directory")

    monkeypatch.setattr(moderngl, "create_standalone_context", no_egl)
    with pytest.raises(GLUnavailableError) as err:
        context.create_context()
    assert "libegl1 libegl-mesa0 libgl1-mesa-dri" in str(err.value) and "\n" not in str(err.value)


def test_compare_without_metrics_extra_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "flip_evaluator", None)  # None in sys.modules: every import of it fails
    code, _, err = run_cli(["compare", "glass-sphere", "--json", tmp_path / "c.json"], capsys)
    assert_one_line_error(code, err, "flip_evaluator", "caustica[metrics]")
    assert list(tmp_path.iterdir()) == []


def test_library_warnings_are_not_printed_before_an_error(capsys, monkeypatch):
    import warnings

    from caustica import cli
    from caustica.errors import SceneError

    def warn_then_fail(args):
        warnings.warn("overflow encountered in multiply", RuntimeWarning)
        raise SceneError("objects[0].scale 1e300 is too large; keep it within 1e6")

    monkeypatch.setitem(cli.COMMANDS, "presets", warn_then_fail)
    code, _, err = run_cli(["presets"], capsys)
    assert_one_line_error(code, err, "scale")
    assert "overflow" not in err


def test_a_long_message_is_cut_to_one_short_line(capsys, monkeypatch):
    from caustica import cli
    from caustica.errors import SceneError

    def fail(args):
        raise SceneError("value " + "1.0, " * 100_000 + "\nsecond line")

    monkeypatch.setitem(cli.COMMANDS, "presets", fail)
    code, _, err = run_cli(["presets"], capsys)
    assert_one_line_error(code, err, "value 1.0")
    assert len(err.strip()) <= cli.MAX_MESSAGE + len("caustica: ")


def test_render_tonemap_filmic_png_and_exr(tmp_path, capsys):
    from caustica.images import read_image, to_srgb8

    scene = write_scene(tmp_path, GOOD_SCENE)
    exr = tmp_path / "x.exr"
    assert run_cli(["render", scene, "-o", exr, "--frames", "1"], capsys)[0] == 0
    linear = read_image(exr)
    outputs = {}
    for mode in ("clip", "filmic"):
        out = tmp_path / f"{mode}.png"
        code, stdout, _ = run_cli(["render", scene, "-o", out, "--tonemap", mode, "--exposure", "3", "--frames", "1"], capsys)
        assert code == 0 and f"wrote {out}" in stdout
        from PIL import Image

        with Image.open(out) as img:
            outputs[mode] = np.asarray(img.convert("RGB"))
        np.testing.assert_array_equal(outputs[mode], to_srgb8(linear, 3.0, mode))
    assert (outputs["clip"] == 255).mean() > (outputs["filmic"] == 255).mean()
    exr_filmic = tmp_path / "f.exr"
    assert run_cli(["render", scene, "-o", exr_filmic, "--tonemap", "filmic", "--frames", "1"], capsys)[0] == 0
    np.testing.assert_array_equal(read_image(exr_filmic), linear)  # EXR stays linear


def test_render_bad_tonemap_is_one_line(tmp_path, capsys):
    code, _, err = run_cli(["render", "glass-sphere", "-o", tmp_path / "o.png", "--tonemap", "aces"], capsys)
    assert_one_line_error(code, err, "--tonemap", "'aces'", "clip", "filmic")
    assert not (tmp_path / "o.png").exists()


def test_a_closed_pipe_ends_quietly():
    """`caustica techniques --json | head -1`: the reader is gone; no traceback, SIGPIPE's exit code. The
    pipe's read end is closed before the child starts, so its first write fails whatever the output's size."""
    import os
    import subprocess
    import sys

    read_end, write_end = os.pipe()
    os.close(read_end)
    try:
        done = subprocess.run([sys.executable, "-m", "caustica.cli", "techniques", "--json"], stdout=write_end,
                              stderr=subprocess.PIPE, timeout=120)
    finally:
        os.close(write_end)
    err = done.stderr.decode()
    assert done.returncode == 141, err
    assert "Traceback" not in err and err == ""
