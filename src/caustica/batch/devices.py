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

from ..errors import DeviceError, short
from ..gpu.egl_devices import ENV, NVIDIA, SOFTWARE, EglDevice, check_index, checked_env_device, egl_devices

__all__ = ["ENV", "NVIDIA", "SOFTWARE", "EglDevice", "assign", "egl_devices", "gpus", "placement", "ray_device"]


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
    DeviceError in one line for an index this machine has not."""
    available = egl_devices() if available is None else available
    if devices is None:
        preset = checked_env_device(available)
        return gpus(available) if preset is None else [preset]
    return [check_index(index, "devices", available, "give indices from that list, or leave the devices out")
            for index in _indices(devices, "devices")]


def _indices(devices, where: str) -> list[int]:
    items = devices.split(",") if isinstance(devices, str) else devices
    try:
        indices = [int(item.strip()) if isinstance(item, str) else item for item in items]
    except (TypeError, ValueError):
        indices = None
    if not indices or any(isinstance(i, bool) or not isinstance(i, int) for i in indices):
        raise DeviceError(f"{where} {short(devices)} must be EGL device indices, e.g. 0,1")
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
