"""The output folder's records: ``job.json`` (which job owns the folder) and ``manifest.jsonl`` (one
JSON row per finished or failed frame), written by one process only.

``job.json`` and the compacted manifest are replaced atomically. While a job runs, each row is
appended with a single ``write`` (O_APPEND), so a kill leaves whole rows and at most one torn last
line; reading skips a torn line, and the next run (and the end of this one) rewrites the manifest
atomically, sorted by frame, one row per frame.
"""
from __future__ import annotations

import json
import os
import zipfile
from pathlib import Path

from ..atomic import write_atomic
from ..errors import OutputError

MANIFEST, JOB_FILE, LOCK_FILE = "manifest.jsonl", "job.json", ".batch.lock"


class Manifest:
    """The records of the output folder ``out_dir``."""

    def __init__(self, out_dir: str | Path):
        self.dir = Path(out_dir)
        self.path, self.job_path = self.dir / MANIFEST, self.dir / JOB_FILE
        self._fd: int | None = None
        self._lock: int | None = None

    def lock(self) -> None:
        """Hold the folder (an flock on ``.batch.lock``) until :meth:`unlock`; OutputError when another
        run holds it."""
        import fcntl

        try:
            self._lock = os.open(self.dir / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o666)
            fcntl.flock(self._lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            self.unlock()
            raise OutputError(f"another caustica batch is writing to {self.dir}; wait for it to end or use "
                              "another output folder") from None
        except OSError as exc:
            self.unlock()
            raise OutputError(f"cannot write in {self.dir}: {exc.strerror}; check its permissions") from None

    @property
    def locked(self) -> bool:
        """Whether this object holds the folder's lock."""
        return self._lock is not None

    def unlock(self) -> None:
        if self._lock is not None:
            os.close(self._lock)
            self._lock = None

    def claim(self, key: str, description: dict, force: bool) -> dict[int, dict]:
        """The rows of earlier runs of job ``key`` here; OutputError when the folder holds another job's
        manifest (unless ``force``, which starts over). Writes ``job.json`` and compacts the manifest."""
        owner = self._owner()
        if force or owner is None:
            rows = {}
        elif owner != key:
            raise OutputError(f"{self.dir} holds the frames of another job (a different scene, sweep or options); "
                              "use another output folder, or --force to start this job over in it")
        else:
            rows = self.rows()
        if owner != key or force:
            text = json.dumps({"key": key, "job": description}, indent=2, sort_keys=True)
            write_atomic(self.job_path, lambda tmp: Path(tmp).write_text(text))
        self.compact(rows)
        return rows

    def _owner(self) -> str | None:
        """The key in ``job.json``; '?' for a manifest without a readable one, None for a fresh folder."""
        try:
            return str(json.loads(self.job_path.read_text())["key"])
        except (OSError, ValueError, KeyError, TypeError):
            return "?" if self.path.exists() else None

    def rows(self) -> dict[int, dict]:
        """Each frame's last row (torn or foreign lines skipped)."""
        rows: dict[int, dict] = {}
        try:
            lines = self.path.read_bytes().splitlines()
        except FileNotFoundError:
            return rows
        except OSError as exc:
            raise OutputError(f"cannot read {self.path}: {exc.strerror}; check its permissions") from None
        for line in lines:
            try:
                row = json.loads(line)
                index = row["index"]
            except (ValueError, KeyError, TypeError):
                continue
            if isinstance(index, int) and not isinstance(index, bool):
                rows[index] = row
        return rows

    def compact(self, rows: dict[int, dict]) -> None:
        """Replace the manifest, atomically, by ``rows`` sorted by frame."""
        text = "".join(json.dumps(rows[i], sort_keys=True) + "\n" for i in sorted(rows))
        write_atomic(self.path, lambda tmp: Path(tmp).write_text(text))

    def __enter__(self):
        try:
            self._fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o666)
        except OSError as exc:
            raise OutputError(f"cannot write {self.path}: {exc.strerror}; check permissions and free space") from None
        return self

    def append(self, row: dict) -> None:
        """One row, as one write."""
        data = (json.dumps(row, sort_keys=True) + "\n").encode()
        if os.write(self._fd, data) != len(data):
            raise OutputError(f"short write to {self.path}; check free space")

    def __exit__(self, *exc) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def present(self, row: dict) -> bool:
        """Whether the row's files are here at the sizes it records."""
        try:
            return all((self.dir / rel).stat().st_size == row["sizes"][name] for name, rel in row["files"].items())
        except (OSError, KeyError, TypeError):
            return False

    def finished(self, row: dict) -> bool:
        """Whether the row is a frame rendered without error whose files are present and readable."""
        return "error" not in row and self.present(row) and all(readable(self.dir / rel)
                                                                for rel in row["files"].values())


def readable(path: Path) -> bool:
    """Whether ``path`` decodes as its suffix says: a PNG's every chunk (CRCs), an EXR's header, an
    .npz's every member (CRCs)."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".png":
            from PIL import Image

            with Image.open(path) as image:
                image.verify()
        elif suffix == ".exr":
            import OpenEXR

            with OpenEXR.File(str(path), header_only=True) as exr:
                exr.header()
        elif suffix == ".npz":
            with zipfile.ZipFile(path) as archive:
                return archive.testzip() is None
        return True
    except Exception:  # any decoder's complaint means the file is not usable
        return False
