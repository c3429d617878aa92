"""What caustica prints while it works: one policy for the command line and the library's long steps.

Verbosity (:func:`output_policy`, the CLI's ``-q``/``-v``): quiet prints nothing on success (no notes, no
progress, no reports; errors still print), normal, verbose (:func:`detail` lines too).

Progress of a step that can take over a second (:func:`progress`):

- stderr a terminal: a tqdm bar (shown after ``DELAY_S``, gone when the step ends);
- stderr not a terminal (a log, a pipe): a plain line at each ``LINE_STEP`` of the work and, while a step
  of the work takes longer, every ``LINE_INTERVAL_S`` (a heartbeat thread writes it), and one at the end;
  never a carriage return;
- quiet: nothing.

Whether it shows at all: the command line shows it (unless ``-q`` or ``--no-progress``); a library call
shows it on a terminal only, unless its caller passes ``enabled=True`` (always) or ``False`` (never).
``CAUSTICA_PROGRESS=1`` forces it on with no delay (tests, logs of short runs), ``CAUSTICA_PROGRESS=0``
off; ``-q``, ``--no-progress`` and ``enabled=False`` win over it. ``Renderer(progress=True)`` (or ``with
progress_policy(True):``) shows a library call's progress off a terminal too (a notebook, a log).
"""
from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
import weakref

QUIET, NORMAL, VERBOSE = -1, 0, 1
DELAY_S = 1.0  # a step shorter than this shows no progress
LINE_STEP = 0.1  # plain lines: one each tenth of the work ...
LINE_INTERVAL_S = 10.0  # ... or after this long without one
ENV = "CAUSTICA_PROGRESS"

_policy = {"verbosity": NORMAL, "progress": None}  # progress None: on a terminal only (a library call)
clock = time.monotonic  # the plain lines' clock (tests put a fake one here)


@contextlib.contextmanager
def output_policy(verbosity: int = NORMAL, progress: bool | None = True):
    """Within the block: ``verbosity`` (QUIET, NORMAL or VERBOSE), and ``progress`` True (shown, as the
    command line shows it), False (never) or None (on a terminal only). The previous policy comes back after."""
    saved = dict(_policy)
    _policy.update(verbosity=verbosity, progress=progress)
    try:
        yield
    finally:
        _policy.update(saved)


@contextlib.contextmanager
def progress_policy(progress: bool | None):
    """Within the block progress shows (True) or not (False) whatever the policy was; None changes nothing."""
    saved = _policy["progress"]
    if progress is not None:
        _policy["progress"] = progress
    try:
        yield
    finally:
        _policy["progress"] = saved


def is_quiet() -> bool:
    return _policy["verbosity"] <= QUIET


def is_verbose() -> bool:
    return _policy["verbosity"] >= VERBOSE


def note(message: str) -> None:
    """``caustica: message`` on stderr, unless quiet."""
    if not is_quiet():
        _lines(message)


def detail(message: str) -> None:
    """``caustica: message`` on stderr (each line of it), when verbose."""
    if is_verbose():
        _lines(message)


def _lines(message: str) -> None:
    for line in str(message).splitlines() or [""]:
        print(f"caustica: {line}", file=sys.stderr, flush=True)


def _forced() -> str:
    return os.environ.get(ENV, "").strip()


def _isatty(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # no isatty, or a closed stream
        return False


def progress_mode(enabled: bool | None = None, stream=None) -> str | None:
    """How progress on ``stream`` (default stderr) shows under the policy: ``"bar"``, ``"lines"`` or None."""
    stream = sys.stderr if stream is None else stream
    forced = _forced()
    if enabled is False or is_quiet() or _policy["progress"] is False or forced == "0":
        return None
    tty = _isatty(stream)
    if enabled is None and forced != "1" and not (_policy["progress"] or tty):
        return None
    return "bar" if tty else "lines"


def status(message: str, enabled: bool | None = None) -> None:
    """``caustica: message`` on stderr where progress would show: the start of a long step that has no bar."""
    if progress_mode(enabled) is not None:
        _lines(message)


def progress(total: int, desc: str, unit: str = "it", enabled: bool | None = None, stream=None, *,
             initial: int = 0, unit_scale: bool = False, leave: bool = False, delay: float | None = None,
             line=None) -> "Progress":
    """A progress display of ``total`` units under the policy (see the module docstring); ``update(n)``
    it as work finishes (from any thread) and ``close()`` it. ``line()``, when given, writes the plain
    lines' text instead of the default one; ``delay`` replaces ``DELAY_S``."""
    stream = sys.stderr if stream is None else stream
    mode = progress_mode(enabled, stream)
    delay = 0.0 if _forced() == "1" else DELAY_S if delay is None else delay
    if mode == "bar":
        try:
            from tqdm import tqdm
        except ImportError:
            mode = "lines"
        else:
            return Progress(tqdm(total=total, desc=desc, unit=unit, file=stream, initial=initial, leave=leave,
                                 unit_scale=unit_scale, dynamic_ncols=True, delay=delay))
    if mode == "lines":
        return _Lines(total, desc, unit, stream, initial, delay, line)
    return Progress(None)


class Progress:
    """A tqdm bar, or nothing (``bar`` None): ``update``, ``set_postfix_str`` and ``close``."""

    def __init__(self, bar):
        self.bar = bar

    def update(self, n: int = 1) -> None:
        if self.bar is not None:
            self.bar.update(n)

    def set_postfix_str(self, text: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(text, refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class _Lines(Progress):
    """Plain progress lines for a log: each LINE_STEP of the work, every LINE_INTERVAL_S while none comes
    (:meth:`tick`, called by a heartbeat thread), at the end."""

    def __init__(self, total, desc, unit, stream, initial, delay, line, heartbeat: bool = True):
        super().__init__(None)
        self.total, self.desc, self.unit, self.stream, self.delay, self.line = total, desc, unit, stream, delay, line
        self.done = self.shown = initial
        self.postfix = ""
        self.start = self.last = clock()
        self.lock = threading.Lock()
        self.closed = threading.Event()
        if heartbeat:  # by weak reference: a display dropped unclosed (an exception) stops its thread
            threading.Thread(target=_beat, args=(weakref.ref(self), self.closed), name=f"progress {desc}",
                             daemon=True).start()

    def update(self, n: int = 1) -> None:
        with self.lock:
            self.done += n
            now = clock()
            if now - self.start < self.delay:
                return
            if (self.done >= self.total or self.done - self.shown >= LINE_STEP * self.total
                    or now - self.last >= LINE_INTERVAL_S):
                self._write(now)

    def tick(self) -> None:
        """A line when LINE_INTERVAL_S passed since the last one (the work has not moved a LINE_STEP)."""
        with self.lock:
            now = clock()
            if (not self.closed.is_set() and self.done < self.total and now - self.start >= self.delay
                    and now - self.last >= LINE_INTERVAL_S):
                self._write(now)

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def close(self) -> None:
        self.closed.set()
        with self.lock:
            now = clock()
            if self.shown != self.done and now - self.start >= self.delay:
                self._write(now)

    def _write(self, now: float) -> None:
        self.shown, self.last = self.done, now
        print(self.line() if self.line is not None else self._text(now), file=self.stream, flush=True)

    def __del__(self):
        self.closed.set()

    def _text(self, now: float) -> str:
        elapsed = now - self.start
        share = self.done / self.total if self.total else 1.0
        eta = f", ETA {elapsed * (1 - share) / share:.0f} s" if 0 < share < 1 else ""
        postfix = f" [{self.postfix}]" if self.postfix else ""
        return (f"{self.desc}: {self.done}/{self.total} {self.unit} ({100 * share:.0f}%), "
                f"{elapsed:.1f} s{eta}{postfix}")


def _beat(display: "weakref.ref[_Lines]", closed: threading.Event) -> None:
    """The heartbeat of a plain-lines display: :meth:`_Lines.tick` ten times an interval until it is closed
    or dropped."""
    while not closed.wait(LINE_INTERVAL_S / 10):
        shown = display()
        if shown is None:
            return
        shown.tick()
        del shown
