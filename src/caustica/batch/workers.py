"""Where frames render: in this process, in N spawned processes, or as Ray tasks. Each backend yields
manifest rows as frames finish (in any order) and only the caller writes the manifest.

Spawned workers (multiprocessing 'spawn', never fork: a fork after GL hangs) each make their own
FrameWorker and EGL context. A worker that dies takes its frame with it: that frame's row is an
error and a new worker takes over. Ray runs one actor per GPU of the cluster (``num_gpus=1``), or
per CPU where it has none, each over chunks of frames.
"""
from __future__ import annotations

import math
import queue
from collections import deque

from ..errors import CausticaError, GLUnavailableError, MissingExtraError, first_line
from .frame import FrameWorker

POLL_S = 0.2  # how often the parent looks for dead workers while it waits


def render_frames(job, indices: list[int], workers: int = 1, ray: str | None = None):
    """Rows of the frames ``indices`` of ``job``, as they finish."""
    if not indices:
        return iter(())
    if ray is not None:
        return _ray_frames(job, indices, ray)
    if workers <= 1:
        return _inline(job, indices)
    return _spawned(job, indices, min(workers, len(indices)))


def _inline(job, indices):
    worker = FrameWorker(job)
    try:
        for index in indices:
            yield worker.render(index)
    finally:
        worker.close()


def _worker_main(job, tasks, results) -> None:
    """A spawned worker: render the indices ``tasks`` hands out until its None."""
    import multiprocessing
    import os

    pid, worker, parent = os.getpid(), None, multiprocessing.parent_process()
    try:
        worker = FrameWorker(job)
        while (index := tasks.get()) is not None and (parent is None or parent.is_alive()):  # stop with the parent
            results.put(("start", pid, index))
            results.put(("row", pid, worker.render(index)))
    except Exception as exc:  # the parent raises it again
        results.put(("fatal", pid, (type(exc).__name__, first_line(exc), isinstance(exc, CausticaError))))
    finally:
        if worker is not None:
            worker.close()


def _spawned(job, indices: list[int], count: int):
    import multiprocessing

    ctx = multiprocessing.get_context("spawn")
    tasks, results = ctx.Queue(), ctx.Queue()
    for index in indices:
        tasks.put(index)
    processes = {}

    def start():
        process = ctx.Process(target=_worker_main, args=(job, tasks, results), daemon=True)
        process.start()
        processes[process.pid] = process
        tasks.put(None)  # this worker's stop, behind the frames

    for _ in range(count):
        start()
    remaining, taken, restarts = set(indices), {}, 0
    try:
        while remaining:
            try:
                messages = [results.get(timeout=POLL_S)]
            except queue.Empty:
                messages = []
            dead = [pid for pid, p in processes.items() if not p.is_alive()]
            while dead:  # what a dead worker sent before it died comes first
                try:
                    messages.append(results.get_nowait())
                except queue.Empty:
                    break
            for kind, pid, payload in messages:
                if kind == "start":
                    taken[pid] = payload
                elif kind == "row":
                    taken.pop(pid, None)
                    remaining.discard(payload["index"])
                    yield payload
                else:
                    name, message, ours = payload
                    if not ours:
                        raise RuntimeError(f"a batch worker failed: {name}: {message}")
                    raise (GLUnavailableError if name == "GLUnavailableError" else CausticaError)(message)
            for pid in dead:
                process = processes.pop(pid)
                index = taken.pop(pid, None)
                if index is not None and index in remaining:
                    remaining.discard(index)
                    yield {"index": index, "values": job.values(index), "seed": job.seed,
                           "error": f"the worker process died (exit code {process.exitcode}) rendering this frame"}
                if remaining and len(processes) < count:
                    restarts += 1
                    if restarts > count + len(indices):
                        raise CausticaError("batch workers keep dying before they render; run with --workers 1 "
                                            "to see why")
                    start()
    finally:
        for process in processes.values():
            process.terminate()
        for process in processes.values():
            process.join(5)
        for q in (tasks, results):
            q.cancel_join_thread()
            q.close()


class _RayFrames:
    """A Ray actor: one FrameWorker, rendering chunks of frames."""

    def __init__(self, job):
        self.worker = FrameWorker(job)

    def render(self, indices: list[int]) -> list[dict]:
        return [self.worker.render(i) for i in indices]


def _import_ray():
    try:
        import ray
    except ImportError:
        raise MissingExtraError("--ray needs Ray, which is not installed; pip install 'caustica[batch]'") from None
    return ray


def _ray_frames(job, indices: list[int], address: str):
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
