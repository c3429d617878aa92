"""Property-based fuzzing of the scene loader and the command line: always a typed error or a render.

Fixed seed (``derandomize``) and bounded examples, so the run is the same on every machine and
takes well under a minute. A scene that loads must render to a finite image; a scene that does not
load must fail with a :class:`caustica.CausticaError` of one line. The command line must answer any
argument list with exit code 0 (and its output written) or 2 (one line on stderr, nothing written).
"""
from __future__ import annotations

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from caustica import CausticaError  # noqa: E402
from caustica.cli import main  # noqa: E402
from caustica.scene.io import parse_scene  # noqa: E402

def fuzz(examples: int) -> settings:
    """Fixed-seed settings with ``examples`` examples."""
    return settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])

# Values a key may receive: plausible ones, absurd ones, non-finite ones, wrong types.
NUMBERS = st.one_of(
    st.sampled_from([0.0, -1.0, 1.0, 1.5, 0.5, 2.0, 40.0, 1e-30, 1e30, 1e300, -1e300, 1e6, 1e-6]),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.integers(min_value=-(10 ** 6), max_value=10 ** 6),
)
WRONG = st.one_of(st.text(max_size=8), st.booleans(), st.just([]), st.just({}), st.just([1.0, 2.0]))
VALUES = st.one_of(NUMBERS, st.lists(NUMBERS, min_size=3, max_size=3), WRONG,
                   st.lists(NUMBERS, min_size=0, max_size=5))
SMALL_COUNTS = st.one_of(st.integers(min_value=-3, max_value=6), st.sampled_from([14, 200000, 10 ** 9]), WRONG)


def _table(keys: dict) -> st.SearchStrategy:
    """A dict drawing a subset of ``keys`` (name -> strategy), sometimes with an unknown key."""
    return st.fixed_dictionaries({}, optional={**keys, "bogus_key": VALUES})


# Hostile tables: any subset of keys, each with any value.
CAMERA = _table({"position": VALUES, "look_at": VALUES, "up": VALUES, "fov_y": NUMBERS, "fov_x": NUMBERS,
                 "near": NUMBERS, "far": NUMBERS,
                 "size": st.one_of(st.just([8, 8]), st.lists(SMALL_COUNTS, min_size=2, max_size=2), WRONG)})
LIGHT = st.one_of(
    _table({"type": st.just("point"), "position": VALUES, "intensity": VALUES}),
    _table({"type": st.just("directional"), "direction": VALUES, "intensity": VALUES}),
    _table({"type": st.just("spot"), "position": VALUES, "direction": VALUES, "intensity": VALUES,
            "inner_angle": NUMBERS, "outer_angle": NUMBERS}),
    _table({"type": st.sampled_from(["line", "laser", 3]), "start": VALUES, "end": VALUES, "intensity": VALUES,
            "samples": SMALL_COUNTS}),
)
MATERIAL = st.one_of(
    st.sampled_from(["glass", "diffuse", "mirror", "water", "gold", 7]),
    _table({"type": st.just("glass"), "ior": NUMBERS, "abbe": NUMBERS, "absorption_color": VALUES,
            "absorption_distance": NUMBERS}),
    _table({"type": st.sampled_from(["diffuse", "mirror"]), "color": VALUES}),
)
OBJECT = st.one_of(
    _table({"shape": st.just("sphere"), "radius": NUMBERS, "subdivisions": SMALL_COUNTS, "material": MATERIAL,
            "position": VALUES, "scale": VALUES, "rotation": VALUES}),
    _table({"shape": st.just("plane"), "size": VALUES, "resolution": SMALL_COUNTS, "material": MATERIAL,
            "position": VALUES}),
    _table({"shape": st.sampled_from(["box", "torus", "ring", "teapot"]), "material": MATERIAL, "scale": VALUES}),
)


# Plausible values: most scenes the fuzzer builds are valid, so that it reaches the renderer.
def _sane(low: float, high: float) -> st.SearchStrategy:
    return st.floats(min_value=low, max_value=high, allow_nan=False, allow_infinity=False)


VEC = st.lists(_sane(-3.0, 3.0), min_size=3, max_size=3)
COLOR = st.lists(_sane(0.0, 1.0), min_size=3, max_size=3)
SANE_MATERIAL = st.one_of(
    st.sampled_from(["glass", "diffuse", "mirror", "water"]),
    st.fixed_dictionaries({"type": st.just("glass"), "ior": _sane(0.5, 2.5)},
                          optional={"abbe": _sane(10.0, 90.0), "absorption_color": COLOR,
                                    "absorption_distance": _sane(0.1, 10.0)}),
    st.fixed_dictionaries({"type": st.sampled_from(["diffuse", "mirror"]), "color": COLOR}),
)
SANE_OBJECT = st.one_of(
    st.fixed_dictionaries({"shape": st.just("sphere"), "material": SANE_MATERIAL},
                          optional={"radius": _sane(0.1, 2.0), "subdivisions": st.integers(1, 4), "position": VEC}),
    st.fixed_dictionaries({"shape": st.just("plane"), "material": SANE_MATERIAL},
                          optional={"size": st.lists(_sane(0.5, 8.0), min_size=2, max_size=2),
                                    "resolution": st.integers(1, 8), "position": VEC}),
    st.fixed_dictionaries({"shape": st.sampled_from(["box", "torus", "ring"]), "material": SANE_MATERIAL},
                          optional={"position": VEC, "rotation": st.lists(_sane(-180, 180), min_size=3, max_size=3)}),
)
SANE_LIGHT = st.one_of(
    st.fixed_dictionaries({"type": st.just("point"), "position": VEC}, optional={"intensity": _sane(0.0, 50.0)}),
    st.fixed_dictionaries({"type": st.just("directional"), "direction": VEC}),
    st.fixed_dictionaries({"type": st.just("spot"), "position": VEC, "look_at": VEC}),
)
SANE_SCENE = st.fixed_dictionaries(
    {"camera": st.fixed_dictionaries({"size": st.just([8, 8]), "position": st.just([0.0, 1.0, 5.0])},
                                     optional={"fov_y": _sane(10.0, 90.0), "look_at": VEC})},
    optional={"objects": st.lists(SANE_OBJECT, max_size=3), "lights": st.lists(SANE_LIGHT, max_size=2),
              "environment": st.sampled_from([{}, {"procedural": "sky-checker"}])},
)

# Where a mutation may land, and what it writes there (any value: absurd, non-finite, of the wrong type).
PLACES = [("camera", k) for k in ("position", "look_at", "up", "fov_y", "fov_x", "near", "far", "size", "bogus")] + [
    ("objects", k) for k in ("radius", "subdivisions", "resolution", "size", "position", "scale", "rotation",
                             "material", "shape", "mesh", "name", "bogus")] + [
    ("objects.material", k) for k in ("ior", "abbe", "absorption_color", "absorption_distance", "color", "type")] + [
    ("lights", k) for k in ("position", "direction", "intensity", "type", "inner_angle", "outer_angle",
                            "samples", "bogus")] + [
    ("", k) for k in ("intensity_scale", "name", "environment", "objects", "lights", "camera", "bogus")]
MUTATION = st.tuples(st.sampled_from(PLACES), st.one_of(VALUES, SMALL_COUNTS, MATERIAL, LIGHT, OBJECT))


def _mutated(scene: dict, mutations) -> dict:
    """``scene`` with each (place, value) written into it (the first entry of an array of tables)."""
    for (table, key), value in mutations:
        if table == "":
            scene[key] = value
        elif table == "camera":
            scene["camera"][key] = value
        elif scene.get(table.split(".")[0]):
            entry = scene[table.split(".")[0]][0]
            if table == "objects.material":
                material = entry.get("material")
                entry["material"] = material = dict(material) if isinstance(material, dict) else {"type": "glass"}
                material[key] = value
            else:
                entry[key] = value
    return scene


SCENE = st.one_of(
    st.builds(_mutated, SANE_SCENE, st.lists(MUTATION, min_size=0, max_size=2)),
    st.fixed_dictionaries(  # wholly hostile scenes
        {"camera": CAMERA},
        optional={"objects": st.lists(OBJECT, max_size=3), "lights": st.lists(LIGHT, max_size=2),
                  "intensity_scale": NUMBERS, "name": st.one_of(st.text(max_size=12), NUMBERS),
                  "environment": st.sampled_from([{}, {"procedural": "sky-checker"}, {"procedural": "nowhere"},
                                                  {"file": "missing.exr"}, {"file": 3}])},
    ),
)


def assert_one_line(exc: BaseException) -> None:
    text = str(exc)
    assert text and "\n" not in text and len(text) <= 400, text[:500]


@pytest.mark.slow
@fuzz(200)
@given(data=SCENE, technique=st.sampled_from(["env-map", "depth-search", "exact", "depth-search+caustic-mapping"]))
def test_scene_loader_gives_a_typed_error_or_a_finite_render(data, technique, renderer, tmp_path):
    try:
        scene = parse_scene(data, base_dir=tmp_path)
    except CausticaError as exc:
        event("refused by the loader")
        assert_one_line(exc)
        return
    try:
        image = renderer.render(scene, technique, spp=1)
    except CausticaError as exc:  # e.g. a size over the device's limits, found only at render time
        event("refused by the renderer")
        assert_one_line(exc)
        return
    event("rendered")
    assert image.dtype == np.float32 and image.ndim == 3
    assert np.all(np.isfinite(image)), "a scene that loads must render to finite pixels"


# Command-line tokens: commands, options, and values good and bad, including ones that look like options.
TOKENS = st.sampled_from([
    "render", "techniques", "presets", "glass-sphere", "caustic-sphere", "no-such-preset", "scene.toml", "",
    "-o", "OUT.png", "OUT.exr", "OUT.txt", "OUT_DIR", "-t", "env-map", "exact", "depth-search+caustic-mapping",
    "no-such-technique", "--size", "8x8", "0x8", "-5x5", "8x", "x", "99999x99999", "--spp", "1", "4", "3", "0", "-1",
    "1e9", "abc", "--exposure", "nan", "inf", "-inf", "1e6", "-2", "--frames", "-p", "shadow_map_size=64",
    "shadow_map_size=nan", "shadow_map_size=-4", "nope=1", "=3", "x==", "--bogus", "--help",
])
# Option-value pairs, mostly valid, for a render command that is otherwise well formed.
OPTION = st.one_of(
    st.tuples(st.just("--size"), st.sampled_from(["8x8", "6x10", "0x8", "-5x5", "8x", "99999x99999", "8x8x8"])),
    st.tuples(st.just("--spp"), st.sampled_from(["1", "4", "9", "2", "3", "0", "-1", "1e9", "abc"])),
    st.tuples(st.just("--exposure"), st.sampled_from(["0", "-1.5", "3", "nan", "inf", "-inf", "1e6", "x"])),
    st.tuples(st.just("-t"), st.sampled_from(["env-map", "exact", "depth-search", "depth-search+caustic-mapping",
                                              "image-space", "per-vertex", "no-such", "+", "env-map+"])),
    st.tuples(st.just("-p"), st.sampled_from(["shadow_map_size=64", "shadow_map_size=nan", "shadow_map_size=-4",
                                              "shadow_map_size=1e9", "shadow_map_size=abc", "nope=1", "=3", "x=="])),
    st.tuples(st.just("--frames"), st.sampled_from(["1", "2", "0", "-3", "1e3"])),
)


@pytest.mark.slow
@fuzz(150)
@given(tokens=st.one_of(
    st.lists(TOKENS, min_size=0, max_size=9),
    st.builds(lambda scene, out, options: ["render", scene, "-o", out] + [v for pair in options for v in pair],
              st.sampled_from(["glass-sphere", "caustic-sphere", "glass-sphere", "caustic-sphere", "no-such-preset"]),
              st.sampled_from(["OUT.png", "OUT.exr", "OUT.png", "OUT.exr", "OUT.txt", "OUT_DIR"]),
              st.lists(OPTION, max_size=2)),
))
def test_cli_answers_any_arguments_with_0_or_2(tokens, tmp_path_factory, capsys):
    workdir = tmp_path_factory.mktemp("cli")
    (workdir / "OUT_DIR").mkdir()
    args = [str(workdir / t) if t.startswith("OUT") else t for t in tokens]
    # Keep every render cheap: a fuzzed --size is still parsed, but this last one is what renders.
    if "render" in tokens:
        args += ["--size", "8x8", "--frames", "1"]
    code = main(args)
    event(f"exit {code}")
    captured = capsys.readouterr()
    assert code in (0, 2), (args, code, captured.err[-500:])
    assert "Traceback" not in captured.err
    written = sorted(p.name for p in workdir.iterdir() if p.name != "OUT_DIR")
    if code == 2:
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("caustica: "), captured.err[-500:]
        assert written == [], (args, written)
        assert list((workdir / "OUT_DIR").iterdir()) == []
    else:
        assert all(not name.endswith(".tmp") for name in written), written
