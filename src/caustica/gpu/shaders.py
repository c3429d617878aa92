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
from collections import OrderedDict, deque
from pathlib import Path

from ..errors import CausticaError
from ..scene.codes import CODE_DEFINES
from .context import is_shared_context

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
_context_programs: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # moderngl context -> ContextPrograms
# Programs no library uses that the process's shared headless context keeps for the next library
# (least recently released first out); a context its caller owns (the viewer's window) keeps none.
IDLE_PROGRAMS = 256


class ShaderError(CausticaError, RuntimeError):
    """A shader file is missing or does not compile; the message names file and line."""


class ContextPrograms:
    """The compiled programs of one GL context, keyed by their preprocessed stage sources, shared by
    every :class:`ShaderLibrary` on that context.

    Each program counts the libraries that hold it. A program no library holds any more is kept,
    up to ``idle_limit`` of them, and released beyond that, least recently released first. Handed to
    a new library, a kept program first gets back the uniform values and block bindings it had when
    it was compiled, so that what one Renderer wrote into it cannot reach another's images.
    """

    def __init__(self, idle_limit: int):
        self.idle_limit = int(idle_limit)
        self.compiles = 0  # programs compiled on this context
        self._entries: dict = {}  # source key -> [program, libraries holding it, state when compiled]
        self._idle: OrderedDict = OrderedDict()  # source keys no library holds, least recently released first
        self._dropped: deque = deque()  # key lists of libraries garbage collected unreleased

    def acquire(self, key, build):
        """The program for ``key`` (``build()`` compiles it when this context has none), counted as
        held by one more library."""
        self._forget_dropped()
        entry = self._entries.get(key)
        if entry is None:
            program = build()
            self.compiles += 1
            entry = self._entries[key] = [program, 0, _program_state(program)]
        else:
            self._idle.pop(key, None)
            _restore_state(entry[0], entry[2])
        entry[1] += 1
        return entry[0]

    def let_go(self, keys, release: bool = True) -> None:
        """A library no longer holds the programs of ``keys``; with ``release``, free the idle ones
        beyond the limit now (not from a garbage collector's callback: it may run mid-frame)."""
        for key in keys:
            entry = self._entries.get(key)
            if entry is not None:
                entry[1] -= 1
                if entry[1] <= 0:
                    self._idle[key] = None
                    self._idle.move_to_end(key)
        if release:
            self._trim()

    def drop_later(self, keys) -> None:
        """Queue the keys of a library collected unreleased; they are let go at the next acquire."""
        self._dropped.append(keys)

    def release_idle(self) -> None:
        """Release every program no library holds."""
        self._forget_dropped()
        while self._idle:
            self._release(next(iter(self._idle)))

    def counts(self) -> dict[str, int]:
        return {"programs": len(self._entries), "idle": len(self._idle), "compiles": self.compiles}

    def _forget_dropped(self) -> None:
        while self._dropped:
            self.let_go(self._dropped.popleft(), release=False)
        self._trim()

    def _trim(self) -> None:
        while len(self._idle) > self.idle_limit:
            self._release(next(iter(self._idle)))

    def _release(self, key) -> None:
        del self._idle[key]
        use_no_program()
        self._entries.pop(key)[0].release()


def context_programs(ctx) -> ContextPrograms:
    """The program cache of ``ctx`` (made on first use): the shared headless context keeps
    IDLE_PROGRAMS unused programs for later libraries, any other context none."""
    programs = _context_programs.get(ctx)
    if programs is None:
        programs = _context_programs[ctx] = ContextPrograms(IDLE_PROGRAMS if is_shared_context(ctx) else 0)
    return programs


def _program_state(program) -> dict:
    """What a program's users can change in it: every uniform's bytes and every block's binding."""
    state = {}
    for name in program:
        member = program[name]
        if hasattr(member, "read"):
            state[name] = member.read()
        elif hasattr(member, "binding"):
            state[name] = member.binding
    return state


def _restore_state(program, state: dict) -> None:
    for name, value in state.items():
        member = program[name]
        if isinstance(value, bytes):
            member.write(value)
        else:
            member.binding = value


class ShaderLibrary:
    def __init__(self, ctx, root: Path = SHADER_ROOT, defines: dict | None = None):
        self.ctx = ctx
        self.root = Path(root)
        self.defines = dict(CODE_DEFINES if defines is None else defines)  # defined in every program
        self._programs: dict = {}
        self._context = context_programs(ctx)
        self._held: list = []  # the context's source keys of the programs in _programs
        self._drop = weakref.finalize(self, self._context.drop_later, self._held)

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
            self._programs[key] = self._shared(tuple(sorted(sources.items())), lambda: self.ctx.program(**sources),
                                               tables)
        return self._programs[key]

    def compute(self, name: str, defines: dict | None = None):
        """A cached compute shader."""
        key = ("compute", name, tuple(sorted((defines or {}).items())))
        if key not in self._programs:
            source, table = self.source(name, defines)
            self._programs[key] = self._shared((("compute_shader", source),),
                                               lambda: self.ctx.compute_shader(source), {"compute_shader": table})
        return self._programs[key]

    def _shared(self, sources: tuple, make, tables: dict):
        """The context's program for these (stage, source) pairs, compiled by ``make`` if it has none."""
        program = self._context.acquire(sources, lambda: self._build(make, sources, tables))
        self._held.append(sources)
        return program

    @staticmethod
    def _build(make, sources: tuple, tables: dict):
        try:
            program = make()
        except Exception as exc:  # moderngl.Error carries the driver log
            raise ShaderError(_translate_log(str(exc), tables)) from None
        _declared[program] = frozenset().union(*(uniform_names(source) for _, source in sources))
        return program

    def count(self) -> int:
        """Programs this library holds (one per shader files and defines)."""
        return len(self._programs)

    def release(self) -> None:
        """Let go of this library's programs: the context keeps them for the next library (up to
        its idle limit) or releases them."""
        self._context.let_go(self._held)
        self._held.clear()
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
    use_no_program()


def use_no_program() -> None:
    """Make no program current (a current program that is released is only flagged for deletion and
    stays alive: moderngl makes a program current to write its uniforms)."""
    use_program = _gl_use_program()
    if use_program is not None:
        use_program(0)


@functools.cache
def _gl_use_program():
    """glUseProgram through EGL's loader (glvnd dispatches it to whichever context is current), or None."""
    import ctypes

    from .egl import gl_function

    return gl_function("glUseProgram", None, ctypes.c_uint)
