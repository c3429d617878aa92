"""Headless OpenGL 4.3+ core context through EGL (NVIDIA when present, Mesa llvmpipe otherwise)."""
from __future__ import annotations

import os

from ..errors import GLUnavailableError, first_line

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

_shared_context = None


def create_context():
    """Create a standalone EGL context, or raise GLUnavailableError with the fix.

    ``CAUSTICA_EGL_DEVICE`` picks an EGL device index (default: the first, which is
    the NVIDIA GPU when its driver is installed, llvmpipe otherwise).
    """
    try:
        import moderngl
    except ImportError as exc:  # pragma: no cover - a dependency of the package
        raise GLUnavailableError(f"moderngl is not installed ({exc}); run: pip install moderngl") from None
    kwargs = {"backend": "egl", "require": REQUIRED_GL}
    device = os.environ.get("CAUSTICA_EGL_DEVICE")
    if device is not None:
        kwargs["device_index"] = int(device)
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
    if ctx.version_code < REQUIRED_GL:
        version = ctx.info.get("GL_VERSION", "?")
        ctx.release()
        raise GLUnavailableError(f"OpenGL {version} is older than the required 4.3 core; {APT_HINT}")
    return ctx


def shared_context():
    """One context per process, created on first use."""
    global _shared_context
    if _shared_context is None:
        _shared_context = create_context()
    return _shared_context


def headless_context_exists() -> bool:
    """Whether this process has made the shared headless (EGL) context."""
    return _shared_context is not None


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
