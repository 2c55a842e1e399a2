"""Writing outputs so that a failed run leaves nothing behind and no file of the user's is lost.

Output goes to a spool file first: an anonymous file in the destination's own directory (so
that the final rename is atomic), or in the temporary directory for standard output. Only
when the whole run has succeeded is the spool renamed over the destination or copied out; on
any error it is dropped. ``-o`` therefore never leaves a half-written or truncated file.

What a destination is decides how it is written (:func:`destination`):

- a regular file, or a name that does not exist yet: replaced atomically by the new file (an
  existing file keeps its permissions; one the user may not write to is refused);
- a symbolic link: the file it points to is replaced, the link stays;
- anything else that can be opened for writing (``/dev/null``, a terminal, a FIFO,
  ``/dev/stdout`` and the other descriptor links): written through, never replaced;
- a directory or a block device: refused.

:func:`refuse_overwrite` refuses, before anything is read, an output that is one of the
run's inputs (compared by file identity, so hard links and symbolic links are seen) or the
same file as another output.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import stat
import sys
import tempfile
from dataclasses import dataclass
from typing import BinaryIO, Iterable

from ..diagnostics import Location, OutputError, UsageError

STDOUT = "-"
KEEP = None  #: a spool whose content the caller reads back (:meth:`Spool.value`) instead of writing it anywhere

_DESCRIPTOR = re.compile(r"^/(?:proc/[^/]+/fd|dev/fd)/\d+$|^/dev/std(?:in|out|err)$")


def explain(exc: OSError, written: bool = False) -> str:
    outcome = "the output is incomplete" if written else "nothing was written"
    if exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG):
        return f"no space left for it (disk full, quota or file size limit); {outcome}"
    if exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        return f"permission denied; {outcome}"
    if exc.errno == errno.ENOENT:
        return f"the directory does not exist; {outcome}"
    if exc.errno == errno.ENOTDIR:
        return f"a part of the path is a file, not a directory; {outcome}"
    return f"{exc.strerror or exc}; {outcome}"


def temporary(location: Location, what: str) -> tuple[str, BinaryIO | None]:
    """The folder for temporary files (TMPDIR, else /tmp...), and with ``what`` an anonymous
    file made there to hold it. Python finds the folder by writing a file in it, which fails on a
    full disk as any write does: that is the disk's error, said as such, not an internal one."""
    held = what or "a temporary file"
    remedy = "free some space there or set TMPDIR to a folder with room"
    try:
        folder = tempfile.gettempdir()
    except OSError:  # "No usable temporary directory found": no folder took its test file
        where = os.environ.get("TMPDIR") or "/tmp"
        raise OutputError(f"cannot keep {held} in {where} (TMPDIR): no space left for it (no folder takes a "
                          f"file: disk full, quota or file size limit); nothing was written; {remedy}",
                          location) from None
    try:
        return folder, tempfile.TemporaryFile(prefix="postproc-") if what else None
    except OSError as exc:
        raise OutputError(f"cannot keep {held} in {folder} (TMPDIR): {explain(exc)}; {remedy}", location) from None


@dataclass(frozen=True)
class Destination:
    """Where an output goes and how: replaced atomically at ``path``, or written through."""

    given: str  #: as the user named it
    path: str  #: the file replaced (links resolved), or the path written through
    through: bool  #: written through (a device, a FIFO, a descriptor link), never replaced


def destination(given: str) -> Destination:
    """What writing to ``given`` means (see the module's docstring); refuses a directory or a disk."""
    where = Location(given)
    path = os.path.abspath(given)
    if given.endswith(os.sep) and not os.path.isdir(path):
        raise OutputError("cannot write output: the name ends with '/', a folder's name; give a file name (or "
                          "--out-dir DIR); nothing was written", where)
    if _descriptor_link(path):
        return Destination(given, path, True)
    try:
        info = os.stat(path)
    except FileNotFoundError:
        return Destination(given, os.path.realpath(path), False)  # a new file, or a dangling link's target
    except OSError as exc:
        raise OutputError(f"cannot write output: {explain(exc)}", where) from None
    if stat.S_ISREG(info.st_mode):
        target = os.path.realpath(path)
        if not info.st_mode & 0o222 or not os.access(target, os.W_OK):  # root may write, but was told not to
            raise OutputError("cannot write output: the file is read-only (its permissions say so); nothing was "
                              "written", where)
        return Destination(given, target, False)
    if stat.S_ISDIR(info.st_mode):
        raise OutputError("cannot write output: this is a directory; give a file name (or --out-dir DIR for "
                          "several programs); nothing was written", where)
    if stat.S_ISBLK(info.st_mode):
        raise OutputError("cannot write output: this is a block device (a disk); postproc does not write onto it; "
                          "nothing was written", where)
    return Destination(given, path, True)


def _descriptor_link(path: str) -> bool:
    """Whether ``path`` names an open descriptor (``/dev/stdout``, ``/dev/fd/3``...), directly or
    through links: it is written through, whatever file the descriptor holds."""
    for _ in range(40):
        if _DESCRIPTOR.match(path):
            return True
        if not os.path.islink(path):
            return False
        path = os.path.normpath(os.path.join(os.path.dirname(path), os.readlink(path)))
    return False


class Spool:
    """A file with no name until :meth:`commit` makes it the output.

    Where the system allows (Linux ``O_TMPFILE``), the spool is an anonymous file in the
    destination's directory: a run killed at any moment, even by SIGKILL, leaves nothing behind
    (unless ``/proc`` cannot name it: see :meth:`_name`). Elsewhere it is a hidden temporary
    file, removed on every error the process survives.
    """

    def __init__(self, given: str | None = STDOUT):
        self.destination = STDOUT if given is KEEP else given  #: as given
        self.where = Location("<stdout>" if self.destination == STDOUT else self.destination)  #: for messages
        self.keep = given is KEEP
        if given is KEEP or given == STDOUT:
            self.target: Destination | None = None
            if given == STDOUT and (sys.stdout is None or getattr(sys.stdout, "buffer", None) is None):
                raise OutputError("cannot write output: standard output is closed; nothing was written",
                                  Location("<stdout>"))
            self.directory = temporary(self.where, "")[0]
        else:
            self.target = destination(given)
            self.directory = temporary(self.where, "")[0] if self.target.through else \
                os.path.dirname(self.target.path)
        self.path: str | None = None
        fd = self._anonymous()
        if fd is None:
            name = "postproc-" if self.target is None or self.target.through else \
                f".{os.path.basename(self.target.path)}.postproc-"
            try:
                fd, self.path = tempfile.mkstemp(prefix=name, suffix=".tmp", dir=self.directory)
            except OSError as exc:
                raise OutputError(f"cannot write output: {explain(exc)}", self.where) from None
        self.file: BinaryIO = os.fdopen(fd, "w+b")
        self._done = False

    def _anonymous(self) -> int | None:
        if not hasattr(os, "O_TMPFILE"):
            return None
        try:
            return os.open(self.directory, os.O_TMPFILE | os.O_RDWR, 0o600)
        except OSError as exc:
            if exc.errno in (errno.ENOENT, errno.EACCES, errno.EPERM, errno.EROFS, errno.ENOSPC, errno.ENOTDIR):
                raise OutputError(f"cannot write output: {explain(exc)}", self.where) from None
            return None  # a file system without O_TMPFILE: a named temporary file instead

    def write(self, data: bytes) -> None:
        try:
            self.file.write(data)
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {explain(exc)}", self.where) from None

    def value(self) -> bytes:
        """Everything written so far (a spool made with :data:`KEEP`)."""
        self.file.flush()
        self.file.seek(0)
        return self.file.read()

    def commit(self, new: bool = False) -> None:
        """Make the spool the output: give it the destination's name, or copy it out. ``new``:
        only as a new file; one standing at the destination, even one made since the run
        began, is never replaced (FileExistsError, the spool discarded)."""
        if self.keep:
            return
        if self.target is None or self.target.through:
            self._copy_out()
            return
        try:
            self.file.flush()
            os.fsync(self.file.fileno())
            if self.path is None:  # name the anonymous file beside the destination, then move it there
                self._name()
            _keep_mode(self.path, self.target.path)
            if new:
                self._make_new()
            else:
                os.replace(self.path, self.target.path)
            self.file.close()
        except FileExistsError:
            self.discard()
            raise
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {explain(exc)}", self.where) from None
        self._done = True

    def _make_new(self) -> None:
        """Give the spool the destination's name only where no file stands: a hard link, which
        fails where any file stands, even one made since the run began. File systems without
        hard links (FAT and exFAT memory sticks, many SMB shares) refuse the link itself
        (:data:`_NO_HARD_LINKS`): there the destination is created exclusively (``O_EXCL``, which
        fails as the link does where a file stands) and the spool copied into it; a copy that
        fails takes away the file it made, so nothing is left behind."""
        try:
            os.link(self.path, self.target.path)
        except OSError as exc:
            if exc.errno not in _NO_HARD_LINKS:
                raise
            self._copy_new()
        os.unlink(self.path)
        self.path = None

    def _copy_new(self) -> None:
        fd = os.open(self.target.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0), 0o666)
        try:
            self.file.seek(0)
            while chunk := self.file.read(1 << 20):
                view = memoryview(chunk)
                while view:
                    view = view[os.write(fd, view):]
            os.fsync(fd)
        except BaseException:
            _close_quietly(fd)
            try:
                os.unlink(self.target.path)  # the file this run made, never one of the user's
            except OSError:
                pass
            raise
        _close_quietly(fd)

    def _copy_out(self) -> None:
        """Copy the spool to stdout or through to a device, a FIFO or a descriptor link.

        A reader that went away (a broken pipe) is no error of the run's: BrokenPipeError goes to
        the caller, which ends quietly."""
        written = False
        try:
            self.file.flush()
            self.file.seek(0)
            if self.target is None:
                sys.stdout.flush()
                out, close = sys.stdout.buffer, False
                out.flush()
                fd = _descriptor(out)
            else:
                fd = os.open(self.target.path, os.O_WRONLY | os.O_APPEND | getattr(os, "O_CLOEXEC", 0))
                out, close = None, True
            try:
                while chunk := self.file.read(1 << 20):
                    if fd is None:  # a stream with no descriptor (a test runner's capture)
                        out.write(chunk)
                        written = True
                        continue
                    view = memoryview(chunk)
                    while view:  # unbuffered, so that "nothing was written" is known, not guessed
                        view = view[os.write(fd, view):]
                        written = True
                if out is not None:
                    out.flush()
            finally:
                if close:
                    os.close(fd)
        except BrokenPipeError:
            self.discard()
            raise
        except OSError as exc:
            self.discard()
            raise OutputError(f"cannot write output: {explain(exc, written)}", self.where) from None
        self.discard()

    def _name(self) -> None:
        """Give the anonymous spool a name: a link to it, or (where links to /proc are not allowed,
        as in some sandboxes: EXDEV) a copy made in the last moment of the run.

        A copy has a name while it is written, so a run killed then (SIGKILL) leaves it behind.
        Its name says what it is, ``.part.nc.postproc-PID-XXXX.partial``, and the next run that
        writes the same output removes those whose process is gone: never the output itself,
        which is replaced only by a complete copy."""
        prefix = f".{os.path.basename(self.target.path)}.postproc-"
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
        """Drop the spool. Never raises: closing flushes what the buffer still holds, which on a
        full disk fails again, and that must not hide the error being reported."""
        if self._done:
            return
        self._done = True
        try:
            self.file.close()  # the descriptor is released even when the flush fails
        except OSError:
            pass
        finally:
            if self.path is not None:
                try:
                    os.unlink(self.path)
                except OSError:
                    pass

    def __enter__(self) -> "Spool":
        return self

    def __exit__(self, kind, value, _traceback) -> None:
        if kind is not None or self.keep:
            self.discard()


def _close_quietly(fd: int) -> None:
    """Close ``fd``: the descriptor is released even when close reports an error, and what was
    written has already been made safe (fsync) or is being taken away."""
    try:
        os.close(fd)
    except OSError:
        pass


def _descriptor(stream) -> int | None:
    try:
        return stream.fileno()
    except (AttributeError, OSError, ValueError):
        return None


#: what link() says on a file system that has no hard links (FAT, exFAT, many SMB shares...)
_NO_HARD_LINKS = frozenset({errno.EPERM, errno.EOPNOTSUPP, getattr(errno, "ENOTSUP", errno.EOPNOTSUPP),
                            errno.EXDEV, errno.ENOSYS, errno.EMLINK})

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


def _keep_mode(spooled: str, target: str) -> None:
    """A new output gets the usual mode for new files; an existing one keeps its own."""
    try:
        mode = os.stat(target).st_mode & 0o7777
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


# ---------------------------------------------------------------------- inputs are never outputs


def _identity(path: str) -> tuple[int, int] | None:
    try:
        info = os.stat(path)
    except OSError:
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISREG(info.st_mode) else None


def refuse_overwrite(inputs: Iterable[tuple[str, str]], outputs: Iterable[tuple[str, str]]) -> None:
    """Refuse (exit 2) an output that is one of the inputs, or the same file as another output.

    ``inputs`` and ``outputs`` are (option, path) pairs, the option naming it in the message
    (``-o``, ``--report``, ``program``...). Files are compared by identity (device and inode:
    hard links and symbolic links are the same file) and, for names that do not exist yet, by
    their resolved path. Standard input and output are compared too when they are files:
    ``>> part.nc`` onto the input would add to it, and ``-o part.nc < part.nc`` replace it.
    """
    read = [(option, path, _identity(path) if path != STDOUT else _descriptor_identity(sys.stdin))
            for option, path in inputs if path]
    seen: list[tuple[str, str, object]] = []
    for option, path in outputs:
        if not path:
            continue
        if path == STDOUT:
            key = _descriptor_identity(sys.stdout) or "standard output"
        else:
            key = _identity(path) or ("new", os.path.realpath(path))
        for other, name, identity in read:
            if identity is not None and identity == key:
                shown = "standard output" if path == STDOUT else f"{option} {path}"
                source = "standard input" if name == STDOUT else f"the input {name}"
                raise UsageError(f"{shown} is {source} ({other}): it would be destroyed; write the output "
                                 "elsewhere (nothing was written)")
        for other, name, identity in seen:
            if identity == key:
                raise UsageError(f"{option} {path} and {other} {name} are the same file: one output would destroy "
                                 "the other; give them different names")
        seen.append((option, path, key))


def _descriptor_identity(stream) -> tuple[int, int] | None:
    """The file behind standard input or output when it is a regular file (a redirection)."""
    try:
        info = os.fstat(stream.fileno())
    except (AttributeError, OSError, ValueError):  # no real descriptor (a test runner's capture, a closed stdout)
        return None
    return (info.st_dev, info.st_ino) if stat.S_ISREG(info.st_mode) else None
