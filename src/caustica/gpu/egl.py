"""libEGL through ctypes, and GL/EGL entry points through its loader: no display, no context (the
context, the device list and the census all start here)."""
from __future__ import annotations

import ctypes
import ctypes.util
import functools


@functools.cache
def libegl():
    """libEGL through ctypes with ``eglGetProcAddress`` typed, or None where it cannot be loaded."""
    try:
        egl = ctypes.CDLL(ctypes.util.find_library("EGL") or "libEGL.so.1")
    except OSError:
        return None
    egl.eglGetProcAddress.restype = ctypes.c_void_p
    egl.eglGetProcAddress.argtypes = [ctypes.c_char_p]
    return egl


def gl_function(name: str, restype, *argtypes):
    """The GL (or EGL) entry point ``name`` through EGL's loader, or None; glvnd dispatches a GL
    function to whichever context is current."""
    egl = libegl()
    address = egl.eglGetProcAddress(name.encode()) if egl is not None else None
    return ctypes.CFUNCTYPE(restype, *argtypes)(address) if address else None
