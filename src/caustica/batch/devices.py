"""Which EGL device each batch worker renders on (docs/batch.md, "GPU placement").

EGL numbers the devices it can open (``eglQueryDevicesEXT``): NVIDIA's GPUs (extension
``EGL_NV_device_cuda``), Mesa's GPUs and Mesa's software device (``EGL_MESA_device_software``:
llvmpipe). ``CAUSTICA_EGL_DEVICE`` (gpu/context.py) and moderngl's ``device_index`` index that list,
which follows neither ``CUDA_VISIBLE_DEVICES`` nor CUDA's order. Spawned workers are placed round robin
over the GPUs of this list (NVIDIA's where there are any, else any that is not software, else the
first device), or over ``devices`` when given; each sets ``CAUSTICA_EGL_DEVICE`` before its context
exists. A Ray task maps the GPU Ray gave it to its EGL device by CUDA ordinal (:func:`ray_device`).
"""
from __future__ import annotations

import ctypes
import os
from dataclasses import dataclass

from ..errors import RenderOptionError, short

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
    from ..gpu.context import gl_function

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


def gpus(devices: list[EglDevice]) -> list[int]:
    """The indices workers spread over: NVIDIA's devices where any, else those that are not software,
    else the first device (llvmpipe)."""
    for chosen in ([d for d in devices if d.is_nvidia], [d for d in devices if not d.is_software], devices[:1]):
        if chosen:
            return [d.index for d in chosen]
    return [0]


def assign(workers: int, devices: list[int]) -> list[int]:
    """The device of each of ``workers`` workers: worker i on ``devices[i % len(devices)]``."""
    return [devices[i % len(devices)] for i in range(workers)]


def placement(devices=None, available: list[EglDevice] | None = None) -> list[int]:
    """The devices spawned workers take turns on: ``devices`` (indices, or a comma-separated string),
    each checked against EGL's list; else ``CAUSTICA_EGL_DEVICE`` when set; else :func:`gpus`.
    RenderOptionError in one line for an index this machine has not."""
    available = egl_devices() if available is None else available
    if devices is None:
        preset = os.environ.get(ENV)
        if preset is None:
            return gpus(available)
        devices, where = [preset], f"{ENV}={short(preset)}"
    else:
        where = "devices"
    indices = _indices(devices, where)
    have = len(available)
    for index in indices:
        if not 0 <= index < have:
            listed = f"{have}, indices 0 to {have - 1}" if have > 1 else "1, index 0" if have else "none"
            raise RenderOptionError(f"{where}: there is no EGL device {index} on this machine (EGL lists {listed}); "
                                    "give indices from that list, or leave the devices out")
    return indices


def _indices(devices, where: str) -> list[int]:
    items = devices.split(",") if isinstance(devices, str) else devices
    try:
        indices = [int(item.strip()) if isinstance(item, str) else item for item in items]
    except (TypeError, ValueError):
        indices = None
    if not indices or any(isinstance(i, bool) or not isinstance(i, int) for i in indices):
        raise RenderOptionError(f"{where} {short(devices)} must be EGL device indices, e.g. 0,1")
    return indices


def ray_device(gpu_ids, devices: list[EglDevice]) -> int | None:
    """The EGL device of the GPU Ray gave a task (``gpu_ids``: ``ray.get_gpu_ids()``, which Ray also puts
    in ``CUDA_VISIBLE_DEVICES``), or None without one. NVIDIA's EGL lists every GPU whatever
    ``CUDA_VISIBLE_DEVICES`` says and tells each one's CUDA ordinal: the device that is the only one
    with an ordinal (a driver that applies ``CUDA_VISIBLE_DEVICES`` to it), else the one whose ordinal is
    Ray's id, else the id's place among :func:`gpus` (no ordinals: EGL's order taken as CUDA's)."""
    if not gpu_ids:
        return None
    with_ordinal = [d for d in devices if d.cuda is not None]
    if len(with_ordinal) == 1:
        return with_ordinal[0].index
    try:
        ordinal = int(gpu_ids[0])
    except (TypeError, ValueError):  # a UUID: no ordinal to match
        return gpus(devices)[0] if devices else None
    match = [d.index for d in with_ordinal if d.cuda == ordinal]
    if match:
        return match[0]
    spread = gpus(devices)
    return spread[ordinal % len(spread)]
