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
    if exc.errno == errno.ENOSPC:
        return "no space left on the device; nothing was written"
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return "permission denied; nothing was written"
    if exc.errno == errno.ENOENT:
        return "the directory does not exist; nothing was written"
    return f"{exc.strerror or exc}; nothing was written"


class Spool:
    """A temporary file that becomes the output on :meth:`commit`."""

    def __init__(self, destination: str = STDOUT):
        self.destination = destination
        directory = None if destination == STDOUT else (os.path.dirname(os.path.abspath(destination)) or ".")
        name = "postproc-" if directory is None else f".{os.path.basename(destination)}.postproc-"
        try:
            fd, self.path = tempfile.mkstemp(prefix=name, suffix=".tmp", dir=directory)
        except OSError as exc:
            raise OutputError(f"cannot write output: {_explain(exc)}", Location(destination)) from None
        self.file: BinaryIO = os.fdopen(fd, "wb")
        self._done = False

    def write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {_explain(exc)}", Location(self.destination)) from None

    def commit(self) -> None:
        """Make the spool the output: rename over the destination, or copy to stdout."""
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            self.file.close()
            if self.destination == STDOUT:
                with open(self.path, "rb") as spooled:
                    shutil.copyfileobj(spooled, sys.stdout.buffer)
                sys.stdout.buffer.flush()
                os.unlink(self.path)
            else:
                _keep_mode(self.path, self.destination)
                os.replace(self.path, self.destination)
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {_explain(exc)}", Location(self.destination)) from None
        self._done = True

    def discard(self) -> None:
        if self._done:
            return
        self._done = True
        try:
            self.file.close()
        finally:
            try:
                os.unlink(self.path)
            except OSError:
                pass

    def __enter__(self) -> "Spool":
        return self

    def __exit__(self, kind, value, traceback) -> None:
        if kind is not None:
            self.discard()


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
