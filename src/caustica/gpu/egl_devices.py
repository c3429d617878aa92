"""EGL's device list and ``CAUSTICA_EGL_DEVICE``, the one place that reads the variable.

EGL numbers the devices it can open (``eglQueryDevicesEXT``): NVIDIA's GPUs (extension
``EGL_NV_device_cuda``), Mesa's GPUs and Mesa's software device (``EGL_MESA_device_software``:
llvmpipe). ``CAUSTICA_EGL_DEVICE`` and moderngl's ``device_index`` index that list, which follows
neither ``CUDA_VISIBLE_DEVICES`` nor CUDA's order (batch/devices.py places workers on it).
"""
from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass

from ..errors import DeviceError, short
from .egl import gl_function

ENV = "CAUSTICA_EGL_DEVICE"
MAX_DEVICES = 32
EGL_EXTENSIONS, EGL_CUDA_DEVICE_NV = 0x3055, 0x323A
SOFTWARE, NVIDIA = "EGL_MESA_device_software", "EGL_NV_device_cuda"


@dataclass(frozen=True)
class EglDevice:
    """One entry of EGL's device list: its index, extensions and CUDA ordinal (NVIDIA's only, else None)."""

    index: int
    extensions: frozenset = frozenset()
    cuda: int | None = None

    @property
    def is_software(self) -> bool:
        return SOFTWARE in self.extensions

    @property
    def is_nvidia(self) -> bool:
        return NVIDIA in self.extensions


def egl_devices() -> list[EglDevice]:
    """EGL's devices, in its order ([] where EGL cannot list them); opens no display and no context."""
    pointer, integer = ctypes.c_void_p, ctypes.c_int
    query = gl_function("eglQueryDevicesEXT", ctypes.c_uint, integer, ctypes.POINTER(pointer), ctypes.POINTER(integer))
    text = gl_function("eglQueryDeviceStringEXT", ctypes.c_char_p, pointer, integer)
    attribute = gl_function("eglQueryDeviceAttribEXT", ctypes.c_uint, pointer, integer, ctypes.POINTER(ctypes.c_long))
    handles, count = (pointer * MAX_DEVICES)(), integer(0)
    if query is None or not query(MAX_DEVICES, handles, ctypes.byref(count)):
        return []
    devices = []
    for index in range(count.value):
        names = frozenset((text(handles[index], EGL_EXTENSIONS) or b"").decode(errors="replace").split()) \
            if text is not None else frozenset()
        cuda = ctypes.c_long(-1)
        known = NVIDIA in names and attribute is not None and attribute(handles[index], EGL_CUDA_DEVICE_NV,
                                                                        ctypes.byref(cuda))
        devices.append(EglDevice(index, names, int(cuda.value) if known and cuda.value >= 0 else None))
    return devices


def env_device() -> int | None:
    """The EGL device index ``CAUSTICA_EGL_DEVICE`` names, None when unset; DeviceError in one line
    for anything but an integer of 0 or more."""
    value = os.environ.get(ENV)
    if value is None:
        return None
    text = value.strip()
    if not text.isdecimal() or not text.isascii():
        raise DeviceError(f"{ENV}={short(value)} must be an EGL device index (0, 1, ...); set it to one, "
                          f"or unset it for the first device")
    return int(text)


def env_device_or_first() -> int:
    """The device this process's context opens: ``CAUSTICA_EGL_DEVICE``'s, else 0."""
    device = env_device()
    return 0 if device is None else device


def checked_env_device(available: list[EglDevice] | None = None) -> int | None:
    """``CAUSTICA_EGL_DEVICE``'s index checked against EGL's list (``available``, default: this machine's),
    None when unset; DeviceError in one line otherwise."""
    device = env_device()
    if device is None:
        return None
    return check_index(device, f"{ENV}={short(os.environ[ENV])}", egl_devices() if available is None else available,
                       "set it to an index from that list, or unset it")


def check_index(index: int, where: str, available: list[EglDevice], fix: str) -> int:
    """``index`` when it is 0 or more and EGL lists a device of that index (or lists none: nothing to
    check against);
    DeviceError naming ``where``, how many devices there are and ``fix`` otherwise."""
    have = len(available)
    if index < 0 or have and index >= have:
        listed = f"{have}, indices 0 to {have - 1}" if have > 1 else "1, index 0" if have else "none"
        kinds = ": " + ", ".join(f"{d.index} {_kind(d)}" for d in available[:8]) if have else ""
        raise DeviceError(f"{where}: there is no EGL device {index} on this machine (EGL lists {listed}{kinds}); "
                          f"{fix}")
    return index


def _kind(device: EglDevice) -> str:
    return "NVIDIA GPU" if device.is_nvidia else "software (llvmpipe)" if device.is_software else "GPU"
