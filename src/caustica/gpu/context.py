"""Headless OpenGL 4.3+ core context through EGL (NVIDIA when present, Mesa llvmpipe otherwise).

One context per process. A process forked after its parent used GL inherits the parent's
context, whose driver threads did not survive the fork (Mesa's llvmpipe then waits for them
forever at the first finish): the child must never call into it. ``shared_context`` notices the
new process id, keeps the inherited context unreleased and untouched, and opens a fresh one on a
new EGL display (Mesa's surfaceless platform: a new driver screen with its own threads). Where no
fresh display is left (a fork of a fork that both rendered, or no Mesa EGL) it raises
GLUnavailableError naming the fix: multiprocessing's 'spawn' start method.
"""
from __future__ import annotations

import atexit
import ctypes
import os
from collections import deque

from ..errors import GLUnavailableError, first_line
from .egl import gl_function, libegl
from .egl_devices import checked_env_device

REQUIRED_GL = 430
APT_HINT = "install Mesa's EGL and llvmpipe: apt-get install -y libegl1 libegl-mesa0 libgl1-mesa-dri"
MATTERING_EXTENSIONS = (
    "GL_NV_shader_atomic_float",
    "GL_ARB_shader_atomic_counters",
    "GL_ARB_compute_shader",
    "GL_ARB_shader_image_load_store",
    "GL_ARB_texture_float",
    "GL_EXT_texture_filter_anisotropic",
)

FORK_HINT = ("use multiprocessing's 'spawn' start method (multiprocessing.get_context('spawn')), "
             "or make the first Renderer inside each worker")
EGL_PLATFORM_SURFACELESS_MESA = 0x31DD
EGL_OPENGL_API = 0x30A2
EGL_EXTENSIONS = 0x3055
# eglCreateContext attributes: OpenGL 4.3 core profile, then EGL_NONE.
EGL_CORE_43 = (0x3098, REQUIRED_GL // 100, 0x30FB, REQUIRED_GL % 100 // 10, 0x30FD, 1, 0x3038)

_shared_context = None
_shared_pid = None  # the process that made _shared_context
_inherited: list = []  # contexts made before a fork, kept so that nothing releases them
_displays: dict[str, int] = {}  # EGL display kind ("device", "surfaceless") -> pid that started its driver


def create_context():
    """Create a standalone EGL context, or raise GLUnavailableError with the fix.

    ``CAUSTICA_EGL_DEVICE`` picks an EGL device index (default: the first, which is
    the NVIDIA GPU when its driver is installed, llvmpipe otherwise).
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - a dependency of the package
        raise GLUnavailableError(f"moderngl is not installed ({exc}); run: pip install moderngl") from None
    if _started_elsewhere("device"):
        return _context_after_fork()
    kwargs = {"backend": "egl", "require": REQUIRED_GL}
    device = checked_env_device()
    if device is not None:
        kwargs["device_index"] = device
    try:
        ctx = moderngl.create_standalone_context(**kwargs)
    except Exception as exc:  # glcontext raises plain Exceptions for missing libraries
        reason = first_line(exc)
        if "version" in reason.lower() or "require" in reason.lower():
            raise GLUnavailableError(
                f"OpenGL {REQUIRED_GL // 100}.{REQUIRED_GL % 100 // 10} core is required but not available ({reason}); "
                f"{APT_HINT}"
            ) from None
        raise GLUnavailableError(f"cannot create a headless OpenGL context ({reason}); {APT_HINT}") from None
    _displays.setdefault("device", os.getpid())
    return _checked_version(ctx)


def _checked_version(ctx):
    """``ctx``, or GLUnavailableError (the context released) when its GL is older than 4.3."""
    if ctx.version_code < REQUIRED_GL:
        version = ctx.info.get("GL_VERSION", "?")
        ctx.release()
        raise GLUnavailableError(f"OpenGL {version} is older than the required 4.3 core; {APT_HINT}")
    return ctx


def shared_context():
    """One context per process, created on first use (again in a forked child: see the module notes).

    Its moderngl objects that are garbage collected unreleased are queued (gc_mode 'context_gc')
    and released by :func:`collect_dropped`, in the thread that renders, at the end of each frame.
    """
    global _shared_context, _shared_pid
    if _shared_context is not None and _shared_pid != os.getpid():
        _shared_context.gc_mode = None  # its objects' finalizers must not queue or release anything
        _inherited.append(_shared_context)
        _shared_context = None
    if _shared_context is None:
        ctx = create_context()
        ctx.gc_mode = "context_gc"
        _shared_context, _shared_pid = ctx, os.getpid()
    return _shared_context


def headless_context_exists() -> bool:
    """Whether this process has made the shared headless (EGL) context (one inherited through a fork is not)."""
    return _shared_context is not None and is_shared_context(_shared_context)


def is_shared_context(ctx) -> bool:
    """Whether ``ctx`` is this process's own shared headless context (made here, not inherited)."""
    return ctx is _shared_context and _shared_pid == os.getpid()


def is_inherited(ctx) -> bool:
    """Whether ``ctx`` is a shared context this process inherited through a fork (never call into it)."""
    return any(ctx is old for old in _inherited) or (ctx is _shared_context and _shared_pid != os.getpid())


def collect_dropped(ctx) -> int:
    """Release the GL objects of ``ctx`` whose moderngl wrappers were garbage collected unreleased.

    moderngl's own ``Context.gc`` stops at the placeholder an already released object leaves; this
    skips those. Returns how many objects it released.
    """
    queue = getattr(ctx, "objects", None)
    released = 0
    while queue:
        obj = queue.popleft()
        if hasattr(obj, "release"):
            obj.release()
            released += 1
    return released


def _started_elsewhere(kind: str) -> bool:
    """Whether another process (our parent, before a fork) started the driver of this EGL display."""
    pid = _displays.get(kind)
    return pid is not None and pid != os.getpid()


class _SurfacelessLoader:
    """moderngl's loader protocol over a new OpenGL 4.3 core context on Mesa's surfaceless EGL display."""

    def __init__(self):
        egl, pointer = libegl(), ctypes.c_void_p
        extensions = b""
        if egl is not None:
            egl.eglQueryString.restype = ctypes.c_char_p
            egl.eglQueryString.argtypes = [pointer, ctypes.c_int]
            extensions = egl.eglQueryString(None, EGL_EXTENSIONS) or b""
        if b"EGL_MESA_platform_surfaceless" not in extensions:
            raise GLUnavailableError("this process was forked after OpenGL was used, and this EGL has no fresh "
                                     f"display to start over on (no EGL_MESA_platform_surfaceless); {FORK_HINT}")
        get_display = gl_function("eglGetPlatformDisplayEXT", pointer, ctypes.c_uint, pointer, pointer)
        egl.eglInitialize.argtypes = [pointer, pointer, pointer]
        egl.eglCreateContext.restype = pointer
        egl.eglCreateContext.argtypes = [pointer, pointer, pointer, pointer]
        egl.eglMakeCurrent.argtypes = [pointer, pointer, pointer, pointer]
        egl.eglDestroyContext.argtypes = [pointer, pointer]
        self.egl, self.pid = egl, os.getpid()
        self.display = get_display(EGL_PLATFORM_SURFACELESS_MESA, None, None) if get_display else None
        if not self.display or not egl.eglInitialize(self.display, None, None) or not egl.eglBindAPI(EGL_OPENGL_API):
            raise GLUnavailableError(f"this process was forked after OpenGL was used, and a fresh EGL display "
                                     f"could not be opened; {FORK_HINT}")
        self.context = egl.eglCreateContext(self.display, None, None, (ctypes.c_int * len(EGL_CORE_43))(*EGL_CORE_43))
        if not self.context:
            raise GLUnavailableError(f"this process was forked after OpenGL was used, and no OpenGL 4.3 core "
                                     f"context could be made on a fresh EGL display; {FORK_HINT}")
        self.__enter__()

    def load_opengl_function(self, name: str) -> int:
        return self.egl.eglGetProcAddress(name.encode()) or 0

    load = load_opengl_function

    def __enter__(self):
        self.egl.eglMakeCurrent(self.display, None, None, self.context)

    def __exit__(self, *exc):
        pass

    def release(self) -> None:
        self.egl.eglMakeCurrent(self.display, None, None, None)
        self.egl.eglDestroyContext(self.display, self.context)

    def terminate(self) -> None:
        """Close the display while its driver threads run (at exit: Mesa's own exit handler, run
        after them, waits forever on the threads of a display made in a forked child)."""
        if self.pid != os.getpid():  # inherited through another fork: never call into it
            return
        self.egl.eglTerminate.argtypes = [ctypes.c_void_p]
        self.egl.eglMakeCurrent(self.display, None, None, None)
        self.egl.eglTerminate(self.display)


def _context_after_fork():
    """A moderngl context on a fresh EGL display, for a process forked after its parent used GL."""
    import moderngl
    from moderngl import mgl

    if _started_elsewhere("surfaceless"):
        raise GLUnavailableError("this process was forked from a process that was itself forked after OpenGL "
                                 f"was used, and no fresh EGL display is left; {FORK_HINT}")
    loader = _SurfacelessLoader()
    atexit.register(loader.terminate)
    ctx = moderngl.Context.__new__(moderngl.Context)
    ctx.mglo, ctx.version_code = mgl.create_context(context=loader)
    ctx._info = ctx._extensions = ctx.extra = ctx._gc_mode = ctx._screen = ctx.fbo = None  # as a standalone one
    ctx._objects = deque()
    _displays["surfaceless"] = os.getpid()
    return _checked_version(ctx)


def describe(ctx) -> dict:
    """Renderer, version and the extensions caustica cares about."""
    extensions = set(ctx.extensions)
    return {
        "renderer": ctx.info.get("GL_RENDERER", "?"),
        "vendor": ctx.info.get("GL_VENDOR", "?"),
        "version": ctx.info.get("GL_VERSION", "?"),
        "max_texture_size": int(ctx.info.get("GL_MAX_TEXTURE_SIZE", 0)),
        "max_viewport": tuple(ctx.info.get("GL_MAX_VIEWPORT_DIMS", (0, 0))),
        "extensions": {name: name in extensions for name in MATTERING_EXTENSIONS},
        "float_atomics": "GL_NV_shader_atomic_float" in extensions,
        "is_software": is_software_renderer(ctx),
    }


def is_software_renderer(ctx) -> bool:
    """True on llvmpipe/softpipe, where GPU timer queries mean nothing."""
    name = ctx.info.get("GL_RENDERER", "").lower()
    return any(s in name for s in ("llvmpipe", "softpipe", "swrast", "lavapipe"))
