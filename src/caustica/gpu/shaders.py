"""Shader library: GLSL files under ``caustica/shaders``.

``#include "common/x.glsl"`` is resolved recursively, once per file (an
unknown file fails loudly). ``#line`` directives encode the file in the line
number itself (file_id * LINE_STRIDE + line), because drivers disagree on
reporting source-string numbers (Mesa mixes them up); compile errors are
translated back to ``file:line``. The host injects
``#define`` lines right after ``#version``: the library's own (every program: the
material and light codes of ``scene.codes``), then the program's. Compiled programs are cached by
(files, defines). Each program remembers the uniform names its source declares
(``declared_uniforms``), so that a strict ``set_uniform`` can tell a misspelled name from
one the driver optimised away.
"""
from __future__ import annotations

import functools
import re
import weakref
from pathlib import Path

from ..errors import CausticaError
from ..scene.codes import CODE_DEFINES

SHADER_ROOT = Path(__file__).resolve().parent.parent / "shaders"
_INCLUDE = re.compile(r'^\s*#include\s+"([^"]+)"\s*(//.*)?$')
_ANY_INCLUDE = re.compile(r'^\s*#include\b')
_VERSION = re.compile(r"^\s*#version\b")
# Right after #version in every program (GLSL allows it nowhere later): fine derivatives where the driver
# has them (common/environment.glsl); "enable" only warns where it does not.
EXTENSIONS = "#extension GL_ARB_derivative_control : enable\n"
# Mesa: "0:12(3): error: ..."; NVIDIA: "0(12) : error C...".
LINE_STRIDE = 100000
_ERROR_LOCATION = re.compile(r"\b(\d+)[:(](\d+)\)?(?:\(\d+\))?\s*:")
_COMMENT = re.compile(r"//[^\n]*|/\*.*?\*/", re.S)
_UNIFORM = re.compile(r"\buniform\b([^;{]*);")  # a block ("uniform Name {") is not a plain uniform
_DECLARED_NAME = re.compile(r"(\w+)\s*(?:\[[^\]]*\]\s*)?(?:,|$)")
_declared: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # program -> uniform names in its source


class ShaderError(CausticaError, RuntimeError):
    """A shader file is missing or does not compile; the message names file and line."""


class ShaderLibrary:
    def __init__(self, ctx, root: Path = SHADER_ROOT, defines: dict | None = None):
        self.ctx = ctx
        self.root = Path(root)
        self.defines = dict(CODE_DEFINES if defines is None else defines)  # defined in every program
        self._programs: dict = {}

    def source(self, name: str, defines: dict | None = None) -> tuple[str, list[str]]:
        """Preprocessed source of ``name`` and the file table its ``#line`` ids index."""
        files: list[str] = []
        lines = self._expand(name, files, stack=())
        header = "#version 430 core\n"
        if lines and _VERSION.match(lines[0]):
            header = lines.pop(0) + "\n"
        shared = sorted(set(self.defines) & set(defines or {}))
        if shared:
            raise ShaderError(f"{name}: define {', '.join(shared)} is set by the shader library in every program")
        define_lines = "".join(f"#define {k} {_glsl_value(v)}\n"
                               for k, v in [*sorted(self.defines.items()), *sorted((defines or {}).items())])
        return header + EXTENSIONS + define_lines + "\n".join(lines) + "\n", files

    def _expand(self, name: str, files: list[str], stack: tuple) -> list[str]:
        path = self.root / name
        if not path.is_file():
            raise ShaderError(f"shader file '{name}' not found under {self.root}" + (f" (included from {stack[-1]})" if stack else ""))
        if name in stack:
            raise ShaderError(f"shader include cycle: {' -> '.join(stack + (name,))}")
        if name in files:  # every file is included once per program
            return []
        file_id = len(files)
        files.append(name)
        out: list[str] = []
        for number, line in enumerate(path.read_text().splitlines(), start=1):
            match = _INCLUDE.match(line)
            if match:
                out.extend(self._expand(match.group(1), files, stack + (name,)))
                out.append(_line_directive(file_id, number + 1))
            elif _ANY_INCLUDE.match(line):
                raise ShaderError(f"{name}:{number}: cannot read the include {line.strip()!r}; "
                                  'write it as #include "folder/file.glsl", optionally followed by a // comment')
            elif _VERSION.match(line) and number == 1 and not stack:
                out.append(line)
                out.append(_line_directive(file_id, number + 1))
            elif _VERSION.match(line):
                out.append("")
            else:
                out.append(line)
        if not (out and out[0].startswith("#version")):
            out.insert(0, _line_directive(file_id, 1))
        return out

    def program(self, vertex: str, fragment: str | None = None, defines: dict | None = None, geometry: str | None = None):
        """A cached moderngl Program from shader files."""
        key = ("render", vertex, fragment, geometry, tuple(sorted((defines or {}).items())))
        if key not in self._programs:
            stages = {"vertex_shader": vertex, "fragment_shader": fragment, "geometry_shader": geometry}
            sources, tables = {}, {}
            for stage, name in stages.items():
                if name:
                    sources[stage], tables[stage] = self.source(name, defines)
            self._programs[key] = self._build(lambda: self.ctx.program(**sources), tables)
            _declared[self._programs[key]] = frozenset().union(*map(uniform_names, sources.values()))
        return self._programs[key]

    def compute(self, name: str, defines: dict | None = None):
        """A cached compute shader."""
        key = ("compute", name, tuple(sorted((defines or {}).items())))
        if key not in self._programs:
            source, table = self.source(name, defines)
            self._programs[key] = self._build(lambda: self.ctx.compute_shader(source), {"compute_shader": table})
            _declared[self._programs[key]] = uniform_names(source)
        return self._programs[key]

    @staticmethod
    def _build(make, tables: dict):
        try:
            return make()
        except Exception as exc:  # moderngl.Error carries the driver log
            raise ShaderError(_translate_log(str(exc), tables)) from None

    def count(self) -> int:
        """Programs built (one per shader files and defines; kept while the library lives)."""
        return len(self._programs)

    def release(self) -> None:
        for program in self._programs.values():
            program.release()
        self._programs.clear()


def uniform_names(source: str) -> frozenset[str]:
    """The names of the plain uniforms that GLSL ``source`` declares (``uniform T a, b[N];``)."""
    names: set[str] = set()
    for match in _UNIFORM.finditer(_COMMENT.sub("", source)):
        body = re.sub(r"=[^,]*", "", match.group(1)).strip()
        names.update(_DECLARED_NAME.findall(body))
    return frozenset(names)


def declared_uniforms(program) -> frozenset[str] | None:
    """The uniform names ``program``'s shader source declares (used or optimised away), or None
    for a program the library did not build."""
    return _declared.get(program)


def _line_directive(file_id: int, line: int) -> str:
    return f"#line {file_id * LINE_STRIDE + line}"


def _glsl_value(value) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value) if "." in repr(value) or "e" in repr(value) else f"{value}.0"
    return str(value)


def _translate_log(log: str, tables: dict) -> str:
    """Rewrite driver locations 'id:line' into 'file:line', keep the first error line."""
    stage = next((s for s in tables if s.replace("_", " ").split()[0] in log.lower()), None)
    files = tables.get(stage) or next(iter(tables.values()), [])
    messages = []
    for line in log.splitlines():
        match = _ERROR_LOCATION.search(line)
        if match and "error" in line.lower():
            file_id, number = divmod(int(match.group(2)), LINE_STRIDE)
            name = files[file_id] if file_id < len(files) else f"<{file_id}>"
            text = line[match.end():].strip()
            messages.append(f"{name}:{number}: {text}")
    if not messages:
        return "shader compile error: " + " ".join(log.split())[:400]
    return "shader compile error at " + messages[0]


def run_compute(program, group_x: int, group_y: int = 1, group_z: int = 1) -> None:
    """Dispatch a compute shader, then make no program current.

    Mesa (llvmpipe, 23.x) keeps a reference to the first render program made current after
    a compute dispatch, so that program outlives glDeleteProgram (found as a GL object left
    after the viewer closes); glUseProgram(0) after the dispatch avoids it.
    """
    program.run(group_x=int(group_x), group_y=int(group_y), group_z=int(group_z))
    use_program = _gl_use_program()
    if use_program is not None:
        use_program(0)


@functools.cache
def _gl_use_program():
    """glUseProgram through EGL's loader (glvnd dispatches it to whichever context is current), or None."""
    import ctypes

    from .egl import gl_function

    return gl_function("glUseProgram", None, ctypes.c_uint)
