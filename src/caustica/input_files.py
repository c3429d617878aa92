"""What an input path is, for one-line errors that say so: a missing file, a directory, a named pipe,
a device. Checked with stat before anything opens the path (opening a FIFO blocks; /dev/zero never ends)."""
from __future__ import annotations

import os
import stat
from pathlib import Path

KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISCHR, "a character device"),
         (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"))


def path_kind(path: str | Path) -> str | None:
    """None for a regular file (links followed); else what ``path`` is: 'missing' (nothing there, or a
    dangling link), 'a directory', 'a named pipe (FIFO)', 'a character device', ... ."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):  # ValueError: a NUL in the path
        return "missing"
    if stat.S_ISREG(mode):
        return None
    return next((name for test, name in KINDS if test(mode)), "not a regular file")


def described(path: str | Path, kind: str) -> str:
    """'/dev/zero is a character device' (through a link: 'env.png links to /dev/zero, a character device')."""
    path = Path(path)
    if path.is_symlink():
        return f"{path} links to {os.path.realpath(path)}, {kind}"
    return f"{path} is {kind}"


def check_regular_file(path: str | Path, what: str, suffixes, error: type[Exception], where: str = "") -> None:
    """``error`` in one line unless ``path`` is a regular file: '<what> file not found' (``where`` says how
    paths are read), or what it is instead, with the ``suffixes`` a <what> file may have."""
    kind = path_kind(path)
    if kind == "missing":
        raise error(f"{what} file not found: {path}; check the path{where}")
    if kind is not None:
        raise error(f"{described(path, kind)}, not {_article(what)} {what} file; give {_article(what)} {what} file "
                    f"({', '.join(suffixes)})")


def _article(word: str) -> str:
    return "an" if word[:1] in "aeiou" else "a"
