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
#: Temp names in ``data/.tmp`` start with the writer's pid: ``<pid>-<random><ext>``
#: (:meth:`BlobStore.new_tmp`) and ``.<pid>-<random>.<pid>-<hex>.tmp<ext>`` (camcmm.io's
#: atomic write of such a file).
_TMP_PID = re.compile(r"^\.?(\d+)-")
#: A file younger than its writer's start by more than this [s] is not that writer's
#: (the pid was reused); /proc gives start times to ~1 s (boot time in whole seconds).
_START_SLACK_S = 2.0


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
        """Remove temp files left by killed writers: those whose writer (the pid in the
        name) is no longer running, and any older than ``max_age_s``. A temp file of a
        running writer stays: it may be writing into this project right now."""
        d = self.root / TMP_DIR
        if not d.is_dir():
            return 0
        n, now = 0, time.time()
        for p in d.iterdir():
            try:
                m = _TMP_PID.match(p.name)
                if orphaned(p.stat().st_mtime, int(m.group(1)) if m else None, now, max_age_s):
                    if p.is_dir():
                        shutil.rmtree(p)
                    else:
                        p.unlink()
                    n += 1
            except OSError:
                pass
        return n


def orphaned(mtime: float, pid: int | None, now: float, max_age_s: float) -> bool:
    """Whether a temp file (modified at ``mtime``, named with writer ``pid``) is left over:
    older than ``max_age_s``, or its writer is gone. Never true for a running writer's."""
    return now - mtime > max_age_s or (pid is not None and writer_gone(pid, mtime))


def writer_gone(pid: int, mtime: float) -> bool:
    """True only when process ``pid`` surely is not the one that wrote a file at ``mtime``:
    no such process, a zombie, or (Linux) one that started after the file was written
    (its pid was reused). False when unsure, e.g. outside POSIX: the age limit decides.

    The process table is this machine's: a project's writers all run on one machine
    (SQLite's WAL, which the store uses, does not work across machines either).
    """
    if os.name != "posix" or pid <= 0:  # os.kill(0, ...) would mean the process group
        return False
    try:
        os.kill(pid, 0)  # signal 0: existence check, nothing is sent
    except ProcessLookupError:
        return True
    except PermissionError:
        pass  # exists, another user's
    except (OSError, OverflowError):
        return False
    state, started = _proc_stat(pid)
    return state == "Z" or (started is not None and mtime < started - _START_SLACK_S)


def _proc_stat(pid: int) -> tuple[str | None, float | None]:
    """(state letter, start time in epoch seconds) of ``pid`` from Linux's /proc, or Nones."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        fields = stat[stat.rindex(")") + 2 :].split()  # the command name may hold spaces
        with open("/proc/stat") as fh:
            btime = next(int(line.split()[1]) for line in fh if line.startswith("btime "))
        # fields[0] is field 3 (state) of proc(5); starttime is field 22, in clock ticks after boot
        return fields[0], btime + int(fields[19]) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError, StopIteration):
        return None, None
