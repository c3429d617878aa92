"""Atomic file writes: every output and cache file of caustica goes through :func:`write_atomic`.

A file is written to a temporary beside it, ``.NAME.<pid>.<12 hex>.tmp``, and
renamed over the target only once complete, so a reader never sees half a
file. The temporary is removed on any exception, KeyboardInterrupt and
SystemExit included (the CLI turns SIGTERM and SIGHUP into an exception so
that this runs). What a SIGKILL or a power cut leaves behind is swept by the
next write to the same target: temporaries of its name whose process is gone,
or older than :data:`STALE_SECONDS`.

:func:`check_writable` answers, before any work, whether a target can be
written: it creates (and removes) the very temporary a write would, so a
read-only directory or file system, a virtual one (``/proc``, ``/sys``), a
directory in the way, a parent that is a file or a name too long all fail in
one line up front. Names near the file system's limit keep a shortened stem in
the temporary's name (``NAME_MAX`` counts bytes; the temporary adds about 25).
"""
from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import secrets
import stat
import time
from pathlib import Path

from .errors import OutputError, first_line

STALE_SECONDS = 600.0
_SUFFIX = ".tmp"
_TOKEN_HEX = 12  # characters of random hex in a temporary's name


def _shown(path, limit: int = 80) -> str:
    """A path for a one-line message: long ones keep their start and end."""
    text = str(path)
    return text if len(text) <= limit else text[: limit // 2 - 2] + "..." + text[-(limit // 2 - 1):]


def _name_max(directory: Path) -> int:
    try:
        return int(os.pathconf(directory, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def temp_label(name: str, room: int) -> str:
    """``name`` as it appears in a temporary's name: whole when it fits in ``room`` bytes, else a
    prefix and a hash of the whole name (deterministic, so the sweep finds it again)."""
    if len(os.fsencode(name)) <= room:
        return name
    tag = "~" + hashlib.sha1(os.fsencode(name)).hexdigest()[:10]
    prefix = name
    while prefix and len(os.fsencode(prefix + tag)) > room:
        prefix = prefix[:-1]
    return prefix + tag


def _label_for(path: Path, pid: int) -> str:
    overhead = len(f"..{pid}.{'0' * _TOKEN_HEX}{_SUFFIX}")
    return temp_label(path.name, max(_name_max(_directory(path)) - overhead, 16))


def temp_path(path: Path) -> Path:
    """A fresh temporary name beside ``path`` that fits the file system's name limit."""
    path = Path(path)
    pid = os.getpid()
    return _directory(path) / f".{_label_for(path, pid)}.{pid}.{secrets.token_hex(_TOKEN_HEX // 2)}{_SUFFIX}"


def _directory(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # alive under another user (or not a pid we can ask about): keep its file
    return True


def sweep_stale(path: Path, now: float | None = None) -> list[Path]:
    """Remove the temporaries of ``path`` that a killed write left behind; return what was removed.

    Only names of our own making for this very target are touched: ``.LABEL.<pid>.<hex>.tmp`` whose
    pid is no longer running or which is older than :data:`STALE_SECONDS`, and the older form
    ``.NAME.<hex>.tmp`` once older than that. Never raises."""
    path = Path(path)
    directory = _directory(path)
    now = time.time() if now is None else now
    labels = {re.escape(_label_for(path, os.getpid())), re.escape(path.name)}
    pattern = re.compile(rf"\.(?:{'|'.join(labels)})\.(?:(\d+)\.)?[0-9a-f]{{{_TOKEN_HEX}}}{re.escape(_SUFFIX)}")
    removed = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return removed
    for entry in entries:
        match = pattern.fullmatch(entry.name)
        if match is None:
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if not stat.S_ISREG(info.st_mode):
                continue
            old = now - info.st_mtime > STALE_SECONDS
            orphan = match.group(1) is not None and not _pid_alive(int(match.group(1)))
            if old or orphan:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
        except OSError:
            continue
    return removed


def missing_folders(path: str | Path) -> list[Path]:
    """The folders above ``path`` that are not there (nothing at all at their name), outermost first."""
    missing = []
    directory = _directory(Path(path))
    while not os.path.lexists(directory) and directory != directory.parent:
        missing.insert(0, directory)
        directory = directory.parent
    return missing


def check_writable(path: str | Path, make_folders: bool = False) -> Path:
    """``path`` when a file can be written there now, else OutputError in one line (nothing left on disk).
    ``make_folders``: missing folders above it are fine where they can be created (:func:`folders_made`)."""
    path = Path(path)
    directory = _directory(path)
    missing = missing_folders(path) if make_folders else []
    if missing:
        base = _directory(missing[0])
        limit = _name_max(base) if os.path.isdir(base) else 255
        for name in [m.name for m in missing] + [path.name]:
            if len(os.fsencode(name)) > limit:
                raise OutputError(f"output folder or name '{name[:40]}...' is {len(os.fsencode(name))} bytes, longer "
                                  f"than the {limit} this file system allows; use a shorter name")
        check_writable(missing[0])  # the folder is created where a file could be: same checks, same messages
        return path
    if not os.path.isdir(directory):
        if os.path.lexists(directory):
            raise OutputError(f"output directory '{_shown(directory)}' is a file, not a directory; "
                              "choose another location")
        raise OutputError(f"output directory '{_shown(directory)}' does not exist; create it first")
    limit, size = _name_max(directory), len(os.fsencode(path.name))
    if size > limit:
        raise OutputError(f"output name '{path.name[:40]}...' is {size} bytes, longer than the {limit} this file "
                          "system allows; use a shorter name")
    _check_target(path, directory)
    tmp = temp_path(path)
    try:
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        try:
            os.write(fd, b"\0")
        finally:
            os.close(fd)
            os.unlink(tmp)
    except OSError as exc:
        raise OutputError(f"cannot write '{_shown(path)}': {_reason(exc, directory)}") from None
    return path


def _check_target(path: Path, directory: Path) -> None:
    """What is at ``path`` now must be a file that a rename can replace: not a directory, not a device
    (renaming over /dev/null would replace the device), not another user's file in a sticky directory."""
    try:
        target, folder = os.stat(path), os.stat(directory)
    except OSError:
        return  # nothing there (or a dangling link, which the rename replaces)
    if stat.S_ISDIR(target.st_mode):
        example = f", e.g. '{path / ('out' + path.suffix)}'" if path.suffix else ""
        raise OutputError(f"output '{_shown(path)}' is a directory; give a file name inside it{example}")
    if not stat.S_ISREG(target.st_mode):
        raise OutputError(f"output '{_shown(path)}' is not a regular file (a device or pipe); give a file name")
    euid = os.geteuid() if hasattr(os, "geteuid") else 0
    if folder.st_mode & stat.S_ISVTX and euid not in (0, target.st_uid, folder.st_uid):
        raise OutputError(f"cannot replace '{_shown(path)}': it belongs to another user in a sticky directory; "
                          "choose another name")


def _reason(exc: OSError, directory: Path) -> str:
    """Why a file cannot be created in ``directory``, and what to do, for one-line errors."""
    if exc.errno == errno.EROFS:
        return f"'{_shown(directory)}' is on a read-only file system; choose a writable directory"
    if exc.errno in (errno.EACCES, errno.EPERM):
        return f"no permission to create files in '{_shown(directory)}'; choose a writable directory"
    if exc.errno == errno.ENAMETOOLONG:
        return "the path is too long for this file system; use a shorter name or directory"
    if exc.errno == errno.ENOSPC or exc.errno == errno.EDQUOT:
        return f"no space left in '{_shown(directory)}'; free some space or choose another directory"
    if exc.errno in (errno.EISDIR, errno.ENOTEMPTY):
        return "a directory is in the way; remove it or choose another name"
    if exc.errno == errno.ENOENT:
        return f"'{_shown(directory)}' does not accept new files (a virtual file system?); choose a writable directory"
    return f"{exc.strerror or first_line(exc)}; choose a writable directory"


@contextlib.contextmanager
def folders_made(path: str | Path):
    """``with folders_made(out):`` the missing folders above ``out`` are created for the block (``mkdir -p``);
    those it created are removed again (where still empty) when the block raises, so a failed write leaves
    nothing behind."""
    made = []
    try:
        for folder in missing_folders(path):
            try:
                os.mkdir(folder)
            except OSError as exc:
                raise OutputError(f"cannot create the folder '{_shown(folder)}': "
                                  f"{_reason(exc, _directory(folder))}") from None
            made.append(folder)
        yield Path(path)
    except BaseException:
        for folder in reversed(made):
            try:
                os.rmdir(folder)
            except OSError:
                break  # no longer empty: something else wrote there
        raise


def write_atomic(path: str | Path, write) -> Path:
    """Call ``write(temp_path)`` beside ``path``, then rename the result over ``path``.

    Any failure raises OutputError in one line, leaving neither the temporary nor a partial
    ``path``; KeyboardInterrupt and other BaseExceptions remove the temporary and pass through."""
    path = Path(path)
    directory = _directory(path)
    if not directory.is_dir():
        raise OutputError(f"output directory {_shown(directory)} does not exist; create it first")
    sweep_stale(path)
    tmp = temp_path(path)
    try:
        # Created like any new file (mode 0o666 less the umask), unlike mkstemp's 0o600.
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
    except OSError as exc:
        raise OutputError(f"cannot write {_shown(path)}: {_reason(exc, directory)}") from None
    try:
        write(str(tmp))
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if not isinstance(exc, Exception):
            raise
        if isinstance(exc, OutputError):
            raise
        if isinstance(exc, OSError) and exc.errno:
            raise OutputError(f"cannot write {_shown(path)}: {_reason(exc, directory)}") from None
        raise OutputError(f"cannot write {_shown(path)}: {first_line(exc)}; check permissions and free space") from None
    return path


class Terminated(BaseException):
    """SIGTERM or SIGHUP, raised in the main thread so that cleanup (``finally``, temporaries) runs.

    A BaseException like KeyboardInterrupt: ``except Exception`` does not swallow it."""

    def __init__(self, signum: int):
        import signal

        self.signum = int(signum)
        self.name = signal.Signals(signum).name
        super().__init__(f"terminated by {self.name}")


class signals_raise:
    """``with signals_raise():`` SIGTERM and SIGHUP raise :class:`Terminated` instead of killing the
    process outright (only where their handler is the default, and in the main thread); a second
    signal while the first unwinds is ignored. The previous handlers come back on exit."""

    def __init__(self):
        self.previous: dict[int, object] = {}
        self.raised = False

    def _handle(self, signum, frame):
        if not self.raised:
            self.raised = True
            raise Terminated(signum)

    def __enter__(self):
        import signal
        import threading

        if threading.current_thread() is threading.main_thread():
            for name in ("SIGTERM", "SIGHUP"):
                signum = getattr(signal, name, None)
                if signum is not None and signal.getsignal(signum) is signal.SIG_DFL:
                    self.previous[signum] = signal.signal(signum, self._handle)
        return self

    def __exit__(self, *exc):
        import signal

        for signum, handler in self.previous.items():
            signal.signal(signum, handler)
        self.previous.clear()
        return False
