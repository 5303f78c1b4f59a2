"""Content-addressed data files: ``data/<first 2 hex>/<sha256><ext>``.

A file is first written (or copied) into ``data/.tmp`` while it is hashed, fsynced,
then renamed into place with ``os.replace`` and its folder fsynced. So a file under
its final name is always complete: a crash leaves at most a stray temp file, never a
truncated data file. Only after that does the store commit a row naming the hash.

The extension is kept so that readers can pick the format from the name. Identical
content is stored once; a second copy under another extension keeps the first name.
"""

from __future__ import annotations

import hashlib
import os
import re
import shutil
import tempfile
import time
from pathlib import Path

from ..errors import InputError, ProjectError

CHUNK = 1 << 20
HASH_RE = re.compile(r"^[0-9a-f]{64}$")
_EXT_RE = re.compile(r"^\.[a-z0-9_]{1,15}$")
TMP_DIR = ".tmp"


def normalise_ext(name: str | os.PathLike) -> str:
    """The lower-case suffix of ``name`` (``".ply"``), or ``""`` when it has none or
    an odd one that should not end up in a file name."""
    ext = Path(name).suffix.lower()
    return ext if _EXT_RE.match(ext) else ""


def check_hash(h: str) -> str:
    if not isinstance(h, str) or not HASH_RE.match(h):
        raise ProjectError(f"{h!r} is not a file hash (64 lower-case hex digits, sha256)")
    return h


def fsync_dir(path: Path) -> None:
    """Make a rename or a new entry in ``path`` durable. Not possible on Windows,
    where NTFS journals metadata anyway, hence the quiet fallback."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


class BlobStore:
    """The ``data`` folder of a project. Knows nothing of the database."""

    def __init__(self, root: Path):
        self.root = root

    def path(self, h: str, ext: str) -> Path:
        return self.root / h[:2] / f"{h}{ext}"

    def tmp_dir(self) -> Path:
        d = self.root / TMP_DIR
        d.mkdir(parents=True, exist_ok=True)
        return d

    def new_tmp(self, suffix: str = "") -> Path:
        """A fresh, empty temp file inside the project (same file system as the final
        place, so that ``os.replace`` is an atomic rename)."""
        fd, name = tempfile.mkstemp(prefix=f"{os.getpid()}-", suffix=suffix, dir=self.tmp_dir())
        os.close(fd)
        return Path(name)

    def copy_in(self, src: str | os.PathLike) -> tuple[Path, str, int]:
        """Copy ``src`` to a temp file while hashing it; fsync it. Returns (temp path,
        sha256, size). Hashing the bytes actually copied (not the source afterwards)
        means the name always matches the content, even if the source changes."""
        src = Path(src)
        if not src.exists():
            raise InputError(f"no such file: {src}")
        if not src.is_file():
            raise InputError(f"{src} is not a file")
        tmp = self.new_tmp()
        h = hashlib.sha256()
        size = 0
        try:
            with open(src, "rb") as fin, open(tmp, "wb") as fout:
                for chunk in iter(lambda: fin.read(CHUNK), b""):
                    h.update(chunk)
                    fout.write(chunk)
                    size += len(chunk)
                fout.flush()
                os.fsync(fout.fileno())
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise InputError(f"cannot copy {src} into the project: {exc.strerror or exc}") from exc
        return tmp, h.hexdigest(), size

    def seal(self, tmp: Path) -> tuple[str, int]:
        """Hash and fsync a temp file written by someone else (e.g. ``camcmm.io.write``)."""
        h = hashlib.sha256()
        size = 0
        with open(tmp, "rb+") as fh:
            for chunk in iter(lambda: fh.read(CHUNK), b""):
                h.update(chunk)
                size += len(chunk)
            os.fsync(fh.fileno())
        return h.hexdigest(), size

    def place(self, tmp: Path, h: str, ext: str, size: int) -> Path:
        """Move a complete, fsynced temp file to its content address. If a complete
        file is already there the temp file is dropped (same hash, same bytes)."""
        final = self.path(h, ext)
        try:
            if final.is_file() and final.stat().st_size == size:
                tmp.unlink(missing_ok=True)
                return final
            folder = final.parent
            new_folder = not folder.exists()
            folder.mkdir(parents=True, exist_ok=True)
            os.replace(tmp, final)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise ProjectError(f"cannot write {final}: {exc.strerror or exc}") from exc
        fsync_dir(folder)
        if new_folder:
            fsync_dir(folder.parent)
        return final

    def find(self, h: str) -> Path | None:
        """The file for ``h`` whatever its extension (for files left by a crash between
        writing the file and committing its row)."""
        folder = self.root / h[:2]
        if not folder.is_dir():
            return None
        for p in folder.iterdir():
            if p.name == h or (p.name.startswith(h) and p.name[64:65] == "."):
                return p
        return None

    def sweep_tmp(self, max_age_s: float = 24 * 3600) -> int:
        """Remove temp files left by crashed writers. Only old ones: a young temp file
        may belong to another process writing into the same project right now."""
        d = self.root / TMP_DIR
        if not d.is_dir():
            return 0
        n, now = 0, time.time()
        for p in d.iterdir():
            try:
                if now - p.stat().st_mtime > max_age_s:
                    if p.is_dir():
                        shutil.rmtree(p)
                    else:
                        p.unlink()
                    n += 1
            except OSError:
                pass
        return n
