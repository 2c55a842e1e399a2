"""Writing programs so that a failed run leaves nothing behind.

Output goes to a spool file first, in the destination's own directory (so the final
rename is atomic) or in the temporary directory for standard output. Only when the whole
run has succeeded is the spool renamed over the destination or copied to stdout; on any
error it is deleted. ``-o`` therefore never leaves a half-written or truncated file.
"""

from __future__ import annotations

import errno
import os
import shutil
import sys
import tempfile
from typing import BinaryIO

from .diagnostics import Location, PostprocError

STDOUT = "-"


class OutputError(PostprocError):
    """The output cannot be written (directory missing or read-only, disk full...)."""


def _explain(exc: OSError) -> str:
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return "no space left for it (disk full, quota or file size limit); nothing was written"
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "permission denied; nothing was written"
    if exc.errno == errno.ENOENT:
        return "the directory does not exist; nothing was written"
    return f"{exc.strerror or exc}; nothing was written"


class Spool:
    """A file with no name until :meth:`commit` makes it the output.

    Where the system allows (Linux ``O_TMPFILE``), the spool is an anonymous file in the
    destination's directory: a run killed at any moment, even by SIGKILL, leaves nothing behind
    (unless ``/proc`` cannot name it: see :meth:`_name`). Elsewhere it is a hidden temporary
    file, removed on every error the process survives.
    """

    def __init__(self, destination: str = STDOUT):
        self.destination = destination
        self.directory = tempfile.gettempdir() if destination == STDOUT else (
            os.path.dirname(os.path.abspath(destination)) or ".")
        self.path: str | None = None
        fd = self._anonymous()
        if fd is None:
            name = "postproc-" if destination == STDOUT else f".{os.path.basename(destination)}.postproc-"
            try:
                fd, self.path = tempfile.mkstemp(prefix=name, suffix=".tmp", dir=self.directory)
            except OSError as exc:
                raise OutputError(f"cannot write output: {_explain(exc)}", Location(destination)) from None
        self.file: BinaryIO = os.fdopen(fd, "w+b")
        self._done = False

    def _anonymous(self) -> int | None:
        if not hasattr(os, "O_TMPFILE"):
            return None
        try:
            return os.open(self.directory, os.O_TMPFILE | os.O_RDWR, 0o600)
        except OSError as exc:
            if exc.errno in (errno.ENOENT, errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC, errno.ENOTDIR):
                raise OutputError(f"cannot write output: {_explain(exc)}", Location(self.destination)) from None
            return None  # a file system without O_TMPFILE: a named temporary file instead

    def write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {_explain(exc)}", Location(self.destination)) from None

    def commit(self) -> None:
        """Make the spool the output: give it the destination's name, or copy it to stdout."""
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            if self.destination == STDOUT:
                self.file.seek(0)
                shutil.copyfileobj(self.file, sys.stdout.buffer)
                sys.stdout.buffer.flush()
                self.discard()
            else:
                if self.path is None:  # name the anonymous file beside the destination, then move it there
                    self._name()
                _keep_mode(self.path, self.destination)
                os.replace(self.path, self.destination)
                self.file.close()
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {_explain(exc)}", Location(self.destination)) from None
        self._done = True

    def _name(self) -> None:
        """Give the anonymous spool a name: a link to it, or (where links to /proc are not allowed,
        as in some sandboxes: EXDEV) a copy made in the last moment of the run.

        A copy has a name while it is written, so a run killed then (SIGKILL) leaves it behind.
        Its name says what it is, ``.part.nc.postproc-PID-XXXX.partial``, and the next run that
        writes the same output removes those whose process is gone: never the output itself,
        which is replaced only by a complete copy."""
        prefix = f".{os.path.basename(self.destination)}.postproc-"
        candidate = os.path.join(self.directory, f"{prefix}{os.getpid()}.tmp")
        try:
            os.link(f"/proc/self/fd/{self.file.fileno()}", candidate, follow_symlinks=True)
            self.path = candidate
            return
        except OSError:
            pass
        _remove_dead_partials(self.directory, prefix)
        fd, self.path = tempfile.mkstemp(prefix=f"{prefix}{os.getpid()}-", suffix=PARTIAL, dir=self.directory)
        with os.fdopen(fd, "wb") as named:
            self.file.seek(0)
            shutil.copyfileobj(self.file, named)
            named.flush()
            os.fsync(named.fileno())

    def discard(self) -> None:
        if self._done:
            return
        self._done = True
        try:
            self.file.close()
        finally:
            if self.path is not None:
                try:
                    os.unlink(self.path)
                except OSError:
                    pass

    def __enter__(self) -> "Spool":
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is not None:
            self.discard()


PARTIAL = ".partial"  #: the suffix of a spool copy while it is written (see Spool._name)


def _remove_dead_partials(directory: str, prefix: str) -> None:
    """Remove the partial copies (``PREFIX<pid>-XXXX.partial``) that runs killed while copying left
    beside this output, those of processes that no longer exist."""
    try:
        names = [entry.name for entry in os.scandir(directory)
                 if entry.name.startswith(prefix) and entry.name.endswith(PARTIAL)]
    except OSError:
        return
    for name in names:
        pid = name[len(prefix):].split("-", 1)[0]
        if not pid.isdigit() or int(pid) == os.getpid() or _alive(int(pid)):
            continue
        try:
            os.unlink(os.path.join(directory, name))
        except OSError:
            pass


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process, say: alive
        return True
    return True


def _keep_mode(spooled: str, destination: str) -> None:
    """A new output gets the usual mode for new files; an existing one keeps its own."""
    try:
        mode = os.stat(destination).st_mode & 0o7777
    except FileNotFoundError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    os.chmod(spooled, mode)


def write_atomically(destination: str, data: bytes) -> None:
    """Write bytes to a file or stdout with the same all-or-nothing guarantee."""
    with Spool(destination) as spool:
        spool.write(data)
        spool.commit()
