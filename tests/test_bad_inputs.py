"""The corpus of bad inputs (tests/data/bad/cases*.toml) through the command line.

Each case must exit 2 with one line, ``caustica: <problem>; <fix>``, holding the case's fragment, print no
traceback and leave its output folder empty. Cases run in-process through ``caustica.cli.main`` (fast); two
also run as a subprocess, which shows that nothing else reaches stderr.
"""
from __future__ import annotations

import functools
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

from caustica.cli import main

BAD = Path(__file__).resolve().parent / "data" / "bad"
CASE_FILES = sorted(BAD.glob("cases*.toml"))
CASES = [case for path in CASE_FILES for case in tomllib.loads(path.read_text())["case"]]
MAX_LINE = len("caustica: ") + 300


@functools.cache
def gl_texture_limit() -> int | None:
    """GL_MAX_TEXTURE_SIZE of this machine's context, or None without a usable GL."""
    from caustica.errors import GLUnavailableError
    from caustica.gpu.device import GpuDevice

    try:
        return GpuDevice().max_texture_size
    except GLUnavailableError:
        return None


def arguments(case: dict, out: Path) -> list[str]:
    return [a.replace("{dir}", str(BAD)).replace("{out}", str(out)) for a in case["args"]]


def skip_unless_it_applies(case: dict) -> None:
    """Cases whose error comes from the GL's limits need a context whose limit is low enough."""
    if not case.get("gl"):
        return
    limit = gl_texture_limit()
    if limit is None:
        pytest.skip("no OpenGL 4.3 context")
    if limit >= case.get("gl_limit_below", float("inf")):
        pytest.skip(f"this GL's texture limit {limit} takes the case's texture")


def check_one_line(code: int, err: str, out_text: str, case: dict, out: Path) -> None:
    lines = err.splitlines()
    assert code == 2, f"exit {code}; stderr: {err[:500]}"
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}: {err[:500]}"
    line = lines[0]
    assert line.startswith("caustica: "), line
    assert case["expect"] in line, f"{case['expect']!r} not in {line!r}"
    assert len(line) <= MAX_LINE, f"{len(line)} characters: {line[:200]}..."
    assert "Traceback" not in err + out_text
    assert sorted(p.name for p in out.iterdir()) == [], "the failed command left files behind"


@pytest.mark.parametrize("case", CASES, ids=[c["name"] for c in CASES])
def test_bad_input_fails_in_one_line(case, tmp_path, capsys):
    skip_unless_it_applies(case)
    out = tmp_path / "out"
    out.mkdir()
    code = main(arguments(case, out))
    captured = capsys.readouterr()
    check_one_line(code, captured.err, captured.out, case, out)


@pytest.mark.parametrize("name", ["ior-1e300", "scene-mesh-nan-obj"])
def test_bad_input_in_a_subprocess(name, tmp_path):
    case = next(c for c in CASES if c["name"] == name)
    out = tmp_path / "out"
    out.mkdir()
    run = subprocess.run([sys.executable, "-c", "import sys; from caustica.cli import main; sys.exit(main())",
                          *arguments(case, out)], capture_output=True, text=True, timeout=120)
    check_one_line(run.returncode, run.stderr, run.stdout, case, out)


def test_corpus_is_complete():
    """At least 60 bad files, each named by a case, and every case's files present."""
    files = {p.name for p in BAD.iterdir()} - {p.name for p in CASE_FILES} - {"ok.toml"}
    used = set()
    for case in CASES:
        for arg in case["args"]:
            if arg.startswith("{dir}/"):
                used.add(arg[len("{dir}/"):].split("/")[0])  # ok.toml/x.png: a file as a parent
    text = "\n".join((BAD / name).read_text(errors="replace") for name in used if name.endswith(".toml"))
    referenced = {name for name in files if f'"{name}"' in text}
    assert len(files) >= 60
    assert files <= used | referenced, f"files no case uses: {sorted(files - used - referenced)}"
    assert all((BAD / name).exists() for name in used)
    assert len({c["name"] for c in CASES}) == len(CASES), "case names must be unique"
