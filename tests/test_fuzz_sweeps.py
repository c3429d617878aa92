"""Property-based fuzzing of sweep files (docs/batch.md): TOML text mutated, run through ``caustica batch``.

As tests/test_fuzz.py: a fixed seed (``derandomize``) and bounded examples, the same run on every
machine, a few seconds. Whatever the text, ``caustica batch`` must render (exit 0) or refuse it in one
line with exit 2, leaving no output folder behind, in a bounded time.
"""
from __future__ import annotations

import shutil
import time

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from caustica.cli import main  # noqa: E402

SCENE = """
[camera]
size = [8, 8]
position = [0, 1, 4]
look_at = [0, 0, 0]
[environment]
procedural = "white"
[[objects]]
name = "ball"
shape = "sphere"
subdivisions = 1
material = { type = "glass", ior = 1.5 }
[[lights]]
type = "point"
position = [0, 3, 0]
"""

SWEEP = """scene = "scene.toml"
frames = 2
seed = 7
output = "frame_{index:04d}"
technique = "plain"
size = [8, 8]
labels = ["depth"]

[camera]
orbit = 90
distance = { uniform = [3.0, 5.0] }

[objects.ball]
ior = { uniform = [1.3, 1.7] }
absorption_color = { list = [[1, 0.5, 0.5], [0.5, 1, 0.5]], cycle = true }

[environment]
strength = { list = [0.5, 1.0] }

[lights.0]
intensity = [1, 1, 1]
"""

# What a mutation inserts: TOML syntax, sweep forms and keys, format fields, absurd numbers and text.
PIECES = st.sampled_from([
    "{", "}", "[", "]", "=", '"', "'", ",", ".", "\n", "#", " ", "0", "-1", "1e309", "nan", "inf", "10000001",
    "true", "uniform", "list", "cycle", "scene", "frames", "output", "{index}", "{index:c}", "{index:99999d}",
    "{index!r}", "{other}", "../", "/", "\\u0000", "[objects.ball]", "[objects.nobody]", "[lights.9]",
    "[camera]", "path = [[0, 1, 4], [1, 1, 4]]", "image = 'missing.exr'", "material = 'glass'", "labels_format",
    "antialias = 'msaa'", "spp = 4", "spp = 3", "x" * 300,
])

# What a value edit writes after a key's '=': values of every kind, good and bad.
VALUES = st.sampled_from([
    "0", "-1", "1.5", "1e309", "-1e300", "nan", "inf", "true", "'text'", "''", "[]", "[1, 2]", "[1, 2, 3]",
    "[[1, 2, 3]]", "{}", "{ uniform = [2, 1] }", "{ uniform = [1, 2] }", "{ uniform = [[0, 0, 0], [1, 1, 1]] }",
    "{ list = [] }", "{ list = [1, 'a'] }", "{ list = [0.5], cycle = 1 }", "{ uniform = [0, 1], list = [1] }",
    "{ cycle = true }", "'{index:c}'", "'{index:1000000000d}'", "'f{index}/{index:x}'", "'../{index}'",
    "'frame'", "'exact'", "'EXACT'", "'auto'", "'nope'", "['depth', 'nope']", "[8, 8]", "[0, 8]", "[99999, 99999]",
    "'glass-sphere'", "'missing.toml'", "'scene.toml'", "{ type = 'glass', ior = 1e9 }", "10000000", "10000001",
])


def fuzz(examples: int) -> settings:
    """Fixed-seed settings with ``examples`` examples (tests/test_fuzz.py's)."""
    return settings(max_examples=examples, derandomize=True, deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])


@st.composite
def mutated_sweeps(draw) -> str:
    """SWEEP with some keys' values replaced, then up to three edits of the text: a span deleted, a piece
    inserted, or a span replaced by a piece."""
    lines = SWEEP.splitlines()
    keyed = [i for i, line in enumerate(lines) if " = " in line]
    for index in draw(st.lists(st.sampled_from(keyed), max_size=3)):
        lines[index] = lines[index].split(" = ")[0] + " = " + draw(VALUES)
    text = "\n".join(lines) + "\n"
    for _ in range(draw(st.sampled_from([0, 0, 1, 2, 3]))):
        start = draw(st.integers(0, len(text)))
        end = min(len(text), start + draw(st.integers(0, 12)))
        kind = draw(st.sampled_from(["delete", "insert", "replace"]))
        piece = "" if kind == "delete" else draw(PIECES)
        text = text[:start] + piece + text[end if kind != "insert" else start:]
    return text


@fuzz(150)
@given(text=mutated_sweeps())
def test_any_sweep_text_renders_or_is_one_line(text, tmp_path, capsys):
    folder = tmp_path / "in"
    folder.mkdir(exist_ok=True)
    (folder / "scene.toml").write_text(SCENE)
    (folder / "sweep.toml").write_text(text, encoding="utf-8", errors="surrogatepass")
    out = tmp_path / "out"
    shutil.rmtree(out, ignore_errors=True)  # tmp_path is shared by the examples
    start = time.monotonic()
    code = main(["batch", str(folder / "sweep.toml"), "-o", str(out), "--no-progress", "-q"])
    elapsed = time.monotonic() - start
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err + captured.out
    if code == 0:
        event("rendered")
        assert (out / "manifest.jsonl").is_file()
    else:
        event("refused")
        assert code == 2, captured.err
        lines = captured.err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("caustica: ") and len(lines[0]) <= 420, captured.err[:500]
        assert not out.exists(), "a refused sweep left its output folder"
    assert elapsed < 10.0
