"""Typed errors. Each carries a one-line message naming the problem and the fix.

The CLI prints ``caustica: <message>`` and exits with code 2 for any of them.
"""


class CausticaError(Exception):
    """Base class of every error caustica raises on bad input or a missing system part."""


class SceneError(CausticaError, ValueError):
    """A scene file, preset or scene object is invalid."""


class MeshError(SceneError):
    """A mesh file is missing, unreadable, empty or holds non-finite vertices."""


class EnvironmentImageError(SceneError):
    """An environment image cannot be read."""


class TechniqueError(CausticaError, ValueError):
    """An unknown technique or an invalid technique parameter."""


class GLUnavailableError(CausticaError, RuntimeError):
    """No usable OpenGL 4.3 core context (EGL or Mesa missing, or the GL too old)."""


class OutputError(CausticaError, OSError):
    """An output file cannot be written (missing directory, unknown format)."""


def first_line(exc: BaseException) -> str:
    """An exception's message reduced to one line (its type name when empty), for one-line errors."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def closest_name(name: str, candidates) -> str:
    """A ' (did you mean X?)' hint for the candidate nearest to ``name``, or '': the one that differs only in
    case first ('EXACT' -> 'exact'), else the closest by difflib."""
    import difflib

    candidates = [str(c) for c in candidates]
    match = [c for c in candidates if c.lower() == name.lower()] or \
        difflib.get_close_matches(name, candidates, n=1, cutoff=0.5)
    return f" (did you mean '{match[0]}'?)" if match else ""


class ReferenceUnavailableError(CausticaError, RuntimeError):
    """The Mitsuba ground truth cannot run (Mitsuba not installed, or its variant unavailable)."""


class MissingExtraError(CausticaError, ImportError):
    """An optional package is not installed (a ``caustica[extra]`` of pyproject.toml)."""


def short(value, limit: int = 60) -> str:
    """``repr(value)`` cut to about ``limit`` characters, for one-line messages that echo user input
    (a 100,000-element array or a key with a newline must not make a message of many lines or pages)."""
    text = repr(value.tolist() if hasattr(value, "tolist") and getattr(value, "size", 2) < 2 * limit else value)
    text = text.replace("\n", "\\n").replace("\r", "\\r")
    return text if len(text) <= limit else text[: limit - 5] + " ...]" if text[0] == "[" else text[: limit - 3] + "..."


class RenderOptionError(SceneError):
    """An invalid render option: image size, samples per pixel, or a frame too large for the GL."""


class DeviceError(GLUnavailableError, RenderOptionError):
    """An EGL device index (``CAUSTICA_EGL_DEVICE``, batch ``devices``) that is not one, or that EGL does not list."""


class RendererClosedError(CausticaError, RuntimeError):
    """A Renderer used after ``close()`` (or after its ``with`` block)."""
