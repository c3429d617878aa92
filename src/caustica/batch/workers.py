"""Where frames render: in this process, in N spawned processes, or as Ray tasks. Each backend yields
manifest rows as frames finish (in any order) and only the caller writes the manifest.

Spawned workers (multiprocessing 'spawn', never fork: a fork after GL hangs) each make their own
FrameWorker and EGL context, on the EGL device devices.py places them on (round robin). A worker
that dies takes its frame with it: that frame's row is an error and a new worker takes over, on the
same device. Ray runs one actor per GPU of the cluster (``num_gpus=1``), on the EGL device of the GPU
Ray gives it (devices.ray_device), or per CPU where it has none, each over chunks of frames.
"""
from __future__ import annotations

import math
import os
import time
from collections import deque

from ..errors import CausticaError, GLUnavailableError, MissingExtraError, first_line
from ..gpu.egl_devices import ENV, env_device_or_first
from .devices import assign
from .frame import FrameWorker

POLL_S = 0.2  # how often the parent looks for dead workers while it waits


def render_frames(job, indices: list[int], workers: int = 1, ray: str | None = None, devices=None):
    """Rows of the frames ``indices`` of ``job``, as they finish: in this process (one worker, no
    ``devices``), else in ``workers`` spawned processes placed round robin on the EGL device indices
    ``devices`` (default: this process's, CAUSTICA_EGL_DEVICE or 0), or on Ray."""
    if not indices:
        return iter(())
    if ray is not None:
        return _ray_frames(job, indices, ray)
    if workers <= 1 and devices is None:
        return _inline(job, indices)
    spread = assign(min(workers, len(indices)), devices or [env_device_or_first()])
    return _spawned(job, indices, spread)


def _inline(job, indices):
    worker = FrameWorker(job)
    try:
        for index in indices:
            yield worker.render(index)
    finally:
        worker.close()


def _worker_main(job, conn, device: int) -> None:
    """A spawned worker on EGL device ``device``: render each index the parent sends on ``conn`` until
    None (or the parent's end)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C reaches the whole group: the parent stops the workers
    worker = None
    try:
        os.environ[ENV] = str(device)  # read when the context is made (gpu/context.py)
        worker = FrameWorker(job)
        while (index := conn.recv()) is not None:
            conn.send(("row", worker.render(index)))
    except EOFError:
        pass  # the parent is gone
    except Exception as exc:  # the parent raises it again
        conn.send(("fatal", (type(exc).__name__, first_line(exc), isinstance(exc, CausticaError))))
    finally:
        if worker is not None:
            worker.close()


def _spawned(job, indices: list[int], devices: list[int]):
    """One worker per entry of ``devices`` (its EGL device index). Each worker has its own pipe and one
    frame at a time: a worker killed at any moment holds no lock another needs, and the parent knows
    which frame it took with it."""
    import multiprocessing
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context("spawn")
    waiting, remaining, restarts, count = deque(indices), set(indices), 0, len(devices)
    workers: dict = {}  # parent end of the pipe -> [process, the index it renders or None, its device]

    def start(device: int):
        ours, theirs = ctx.Pipe()
        process = ctx.Process(target=_worker_main, args=(job, theirs, device), daemon=True)
        process.start()
        theirs.close()
        workers[ours] = [process, None, device]
        hand(ours)

    def hand(conn):
        index = waiting.popleft() if waiting else None
        workers[conn][1] = index
        try:
            conn.send(index)
        except OSError:
            pass  # it died: found below

    def receive(conn):
        """The row ``conn`` sent (the next frame handed out first), or None."""
        try:
            kind, payload = conn.recv()
        except (EOFError, OSError):
            return None
        if kind == "fatal":
            name, message, caustica_error = payload
            if not caustica_error:
                raise RuntimeError(f"a batch worker failed: {name}: {message}")
            raise (GLUnavailableError if name == "GLUnavailableError" else CausticaError)(message)
        remaining.discard(payload["index"])
        hand(conn)
        return payload

    for device in devices:
        start(device)
    try:
        while remaining:
            sentinels = {w[0].sentinel: conn for conn, w in workers.items()}
            for ready in wait(list(workers) + list(sentinels), timeout=POLL_S):
                if ready in workers and (row := receive(ready)) is not None:
                    yield row
            for conn, (process, index, device) in list(workers.items()):
                if process.is_alive():
                    continue
                while conn.poll() and (row := receive(conn)) is not None:  # sent before it died
                    yield row
                handed = workers.pop(conn)[1]
                conn.close()
                if handed is not None and handed != index:
                    waiting.appendleft(handed)  # handed out after it died: never started
                elif index is not None and index in remaining:
                    remaining.discard(index)
                    yield {"index": index, "values": job.values(index), "seed": job.seed, "time": round(time.time(), 3),
                           "worker": process.pid, "device": device,
                           "error": f"the worker process died (exit code {process.exitcode}) rendering this frame"}
                if waiting and process.exitcode != 0 and len(workers) < count:
                    restarts += 1
                    if restarts > count + len(indices):
                        raise CausticaError("batch workers keep dying before they render; run with --workers 1 "
                                            "to see why")
                    start(device)
    finally:
        for process, *_ in workers.values():
            process.terminate()
        for process, *_ in workers.values():
            process.join(5)
        for conn in workers:
            conn.close()


class _RayFrames:
    """A Ray actor: one FrameWorker, rendering chunks of frames; given a GPU, on its EGL device."""

    def __init__(self, job):
        import ray

        from .devices import egl_devices, ray_device

        device = ray_device(ray.get_gpu_ids(), egl_devices())
        if device is not None:
            os.environ[ENV] = str(device)
        self.worker = FrameWorker(job)

    def render(self, indices: list[int]) -> list[dict]:
        return [self.worker.render(i) for i in indices]


def _import_ray():
    try:
        import ray
    except ImportError:
        raise MissingExtraError("--ray needs Ray, which is not installed; pip install 'caustica[batch]'") from None
    return ray


RAY_CONNECT_S = 3.0  # how long a cluster's port may take to accept a connection


def _check_reachable(address: str) -> None:
    """CausticaError in one line, within RAY_CONNECT_S, when ``address`` (host:port or ray://host:port)
    accepts no TCP connection: ray.init would retry a dead cluster for minutes. Other forms ('auto', a
    client scheme) go to Ray as they are."""
    import socket

    host, colon, port = address.removeprefix("ray://").rpartition(":")
    if "://" in address.removeprefix("ray://") or not colon or not port.isdigit():
        return
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=RAY_CONNECT_S).close()
    except (OSError, ValueError, OverflowError) as exc:
        reason = "timed out" if isinstance(exc, TimeoutError) else getattr(exc, "strerror", None) or first_line(exc)
        raise CausticaError(f"cannot reach the Ray cluster at {address!r} ({reason}); start it (ray start --head) "
                            "or give its address (ray://host:10001 or host:6379), or 'local'") from None


def _ray_frames(job, indices: list[int], address: str):
    import sys

    running = "ray" in sys.modules and sys.modules["ray"].is_initialized()
    if address != "local" and not running:
        _check_reachable(address)  # before Ray's import: a dead address fails the same with Ray or without
    ray = _import_ray()
    started = not ray.is_initialized()
    if started:
        try:
            if address == "local":
                ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
            else:
                ray.init(address=address, log_to_driver=False, configure_logging=False)
        except (ConnectionError, RuntimeError, ValueError) as exc:
            raise CausticaError(f"cannot reach the Ray cluster at {address!r} ({first_line(exc)}); give its "
                                "address (ray://host:10001 or host:6379) or 'local'") from None
    actors = []
    try:
        gpus = int(ray.cluster_resources().get("GPU", 0))
        slots = gpus or max(1, int(ray.cluster_resources().get("CPU", 1)))
        actor_class = ray.remote(num_gpus=1, num_cpus=0) if gpus else ray.remote(num_cpus=1)
        actor_class = actor_class(_RayFrames)
        size = max(1, min(16, math.ceil(len(indices) / (4 * slots))))
        chunks = deque(indices[i:i + size] for i in range(0, len(indices), size))
        pending = {}
        for _ in range(min(slots, len(chunks))):
            actor = actor_class.remote(job)
            actors.append(actor)
            chunk = chunks.popleft()
            pending[actor.render.remote(chunk)] = (actor, chunk)
        while pending:
            (ref,), _ = ray.wait(list(pending), num_returns=1)
            actor, chunk = pending.pop(ref)
            try:
                rows = ray.get(ref)
            except ray.exceptions.RayError as exc:
                cause = getattr(exc, "cause", None)
                if isinstance(cause, CausticaError):
                    raise type(cause)(first_line(cause)) from None
                rows = [{"index": i, "values": job.values(i), "seed": job.seed,
                         "error": f"the Ray task failed: {first_line(exc)}"} for i in chunk]
                actor = actor_class.remote(job)
                actors.append(actor)
            yield from rows
            if chunks:
                chunk = chunks.popleft()
                pending[actor.render.remote(chunk)] = (actor, chunk)
    finally:
        for actor in actors:
            ray.kill(actor)
        if started:
            ray.shutdown()
