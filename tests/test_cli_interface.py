"""The command line's interface (issue 24): --version, -q/-v, progress policy, completion, --timing-frames."""
from __future__ import annotations

import io
import shutil
import subprocess

import pytest

from caustica import __version__, progress as policy
from caustica.cli import completion_script, main

TINY_GL = ["glass-sphere", "-t", "env-map", "--size", "32x32"]
TINY_EXACT = ["-t", "exact", "--size", "32x32", "-p", "caustic_photons=2000", "-p", "environment_samples=4"]


@pytest.fixture(autouse=True)
def private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("CAUSTICA_CACHE", str(tmp_path_factory.getbasetemp() / "interface-cache"))
    monkeypatch.delenv(policy.ENV, raising=False)


def run_cli(args, capsys):
    code = main([str(a) for a in args])
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def tiny_mesh(tmp_path):
    import trimesh

    from caustica.scene.shapes import sphere

    path = tmp_path / "ball.obj"
    m = sphere(1.0, subdivisions=1)
    trimesh.Trimesh(m.vertices, m.faces, vertex_normals=m.normals, process=False).export(path)
    return path


def test_version_prints_the_package_version(capsys):
    code, out, err = run_cli(["--version"], capsys)
    assert code == 0 and out.strip() == f"caustica {__version__}" and not err


@pytest.mark.parametrize("command", [
    ["-q", "render", *TINY_GL, "-o", "{tmp}/r.png", "--timing-frames", "1"],
    ["render", *TINY_GL, "-o", "{tmp}/r.exr", "--frames", "1", "-q"],  # the deprecation note silenced too
    ["render", "caustic-sphere", "-o", "{tmp}/e.png", *TINY_EXACT, "-q"],
    ["compare", "caustic-sphere", "--size", "32x32", "--spp", "1", "--reference-spp", "4", "--timing-frames", "1",
     "--techniques", "env-map", "--json", "{tmp}/c.json", "-q"],
    ["-q", "precompute", "{mesh}", "--ior", "1.5", "--directions", "9", "-o", "{tmp}/t.npz"],
    ["precompute", "{mesh}", "--ior", "1.5", "--directions", "9", "-q"],
    ["-q", "presets"],
], ids=["render-before", "render-after", "exact", "compare", "precompute-before", "precompute-after", "presets"])
def test_quiet_prints_nothing_on_success(command, tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(policy.ENV, "1")  # progress forced on: -q still wins
    mesh = tiny_mesh(tmp_path) if "precompute" in command else ""
    args = [a.format(tmp=tmp_path, mesh=mesh) for a in command]
    code, out, err = run_cli(args, capsys)
    assert (code, out, err) == (0, "", "")
    written = [a for a in args if a.startswith(str(tmp_path)) and a.endswith((".png", ".exr", ".json", ".npz"))]
    assert all((tmp_path / a).stat().st_size > 0 for a in written)


def test_quiet_errors_still_print_one_line(tmp_path, capsys):
    code, out, err = run_cli(["-q", "render", tmp_path / "missing.toml", "-o", tmp_path / "x.png"], capsys)
    assert code == 2 and not out and len(err.strip().splitlines()) == 1 and err.startswith("caustica: ")
    code, _, err = run_cli(["-q", "presets", "-v"], capsys)
    assert code == 2 and err.strip() == "caustica: give -q (quiet) or -v (verbose), not both"


def test_verbose_adds_the_renderer_the_plan_and_timings(tmp_path, capsys):
    code, out, err = run_cli(["render", *TINY_GL, "-o", tmp_path / "v.png", "--timing-frames", "2", "-v"], capsys)
    assert code == 0 and out.startswith("wrote ")
    assert "caustica: GL: " in err and "technique: " in err and "(timed)" in err and "render took" in err


def test_frames_is_a_deprecated_alias_of_timing_frames(tmp_path, capsys):
    from caustica.cli import build_parser

    assert build_parser().parse_args(["render", "s", "-o", "x.png", "--frames", "2"]).timing_frames == 2
    code, out, err = run_cli(["render", *TINY_GL, "-o", tmp_path / "f.png", "--frames", "1"], capsys)
    assert code == 0 and "ms per frame" in out
    assert err.strip() == "caustica: --frames is deprecated; use --timing-frames (frames timed, not an animation frame count)"
    assert "--frames" not in command_help("render") and "--timing-frames" in command_help("render")


def command_help(command: str) -> str:
    from caustica.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.choices and command in a.choices).choices[command]
    return sub.format_help()


def test_precompute_long_quiet_keeps_its_meaning(tmp_path, capsys):
    code, out, err = run_cli(["precompute", tiny_mesh(tmp_path), "--ior", "1.5", "--directions", "9", "--quiet"],
                             capsys)
    assert code == 0 and "B/sample" in out  # the report, as before
    assert err.startswith("caustica: --quiet is deprecated") and "--no-progress" in err and "\r" not in err


def test_forced_progress_on_an_exact_render_is_plain_lines(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv(policy.ENV, "1")
    code, out, err = run_cli(["render", "caustic-sphere", "-o", tmp_path / "p.png", *TINY_EXACT], capsys)
    assert code == 0 and "wrote" in out
    assert "exact caustic-sphere" in err and "32/32 rows (100%)" in err and "\r" not in err
    code, _, err = run_cli(["render", "caustic-sphere", "-o", tmp_path / "n.png", *TINY_EXACT, "--no-progress"], capsys)
    assert code == 0 and "rows" not in err


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_progress_policy_bar_lines_or_nothing(monkeypatch):
    def shown(stream, enabled=None, verbosity=policy.NORMAL, cli=None):
        with policy.output_policy(verbosity, cli):
            with policy.progress(50, "step", unit="rows", enabled=enabled, stream=stream, delay=0.0) as bar:
                for _ in range(50):
                    bar.update(1)
        return stream.getvalue()

    lines = shown(io.StringIO(), enabled=True).splitlines()
    assert len(lines) == 10 and lines[-1].startswith("step: 50/50 rows (100%)") and "ETA" in lines[0]
    assert "\r" in shown(Terminal())  # a tqdm bar
    assert shown(io.StringIO()) == ""  # a library call off a terminal: nothing unless asked
    assert shown(io.StringIO(), cli=True) != ""  # the command line: lines in a log
    assert shown(Terminal(), enabled=True, verbosity=policy.QUIET) == ""
    assert shown(io.StringIO(), enabled=False, cli=True) == ""
    monkeypatch.setenv(policy.ENV, "0")
    assert shown(Terminal(), enabled=True) == ""
    monkeypatch.setenv(policy.ENV, "1")
    assert policy.progress_mode(stream=io.StringIO()) == "lines"


def test_a_short_step_shows_no_progress():
    with policy.output_policy(progress=True):
        stream = io.StringIO()
        with policy.progress(4, "quick", stream=stream) as bar:  # the default delay: done before it
            bar.update(4)
    assert stream.getvalue() == ""


def complete(line: str, script: str) -> list[str]:
    """What bash offers for ``line`` (the last word being completed) with ``script`` loaded."""
    words = line.split(" ")
    program = (f"{script}\nCOMP_WORDS=({' '.join(repr(w) for w in words)}); COMP_CWORD={len(words) - 1}\n"
               '_caustica; printf "%s\\n" "${COMPREPLY[@]}"')
    done = subprocess.run(["bash", "-c", program], capture_output=True, text=True, timeout=10)
    assert done.returncode == 0, done.stderr
    return done.stdout.split()


@pytest.mark.skipif(shutil.which("bash") is None, reason="bash is not installed")
def test_bash_completion_offers_commands_options_and_values(capsys):
    code, script, _ = run_cli(["completion", "bash"], capsys)
    assert code == 0 and script.rstrip().endswith("complete -o default -F _caustica caustica")
    assert complete("caustica ren", script) == ["render"]
    assert complete("caustica -q pre", script) == ["precompute", "presets"]
    assert complete("caustica render scene.toml --tim", script) == ["--timing-frames"]
    assert complete("caustica render x --tonemap ", script) == ["clip", "filmic"]
    assert complete("caustica render caustic-sph", script) == ["caustic-sphere"]
    assert "exact" in complete("caustica render x -t ", script)
    assert complete("caustica render x --size ", script) == []  # no words: bash completes file names
    assert complete("caustica view x --fr", script) == ["--frames"]
    assert complete("caustica completion ", script) == ["bash", "zsh"]


def test_zsh_completion_loads_the_bash_one_through_bashcompinit():
    script = completion_script("zsh")
    assert script.startswith("autoload -U +X bashcompinit && bashcompinit\n")
    assert script.endswith(completion_script("bash"))
    if shutil.which("zsh"):
        done = subprocess.run(["zsh", "-c", script], capture_output=True, text=True, timeout=10)
        assert done.returncode == 0, done.stderr
