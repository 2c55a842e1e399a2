"""No file of the user's is destroyed (postproc.files.output): links, devices, FIFOs, read-only files,
an output that is an input, two outputs in one, two programs of one name in one folder."""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
import threading

import pytest

from support import SAMPLES

HEMISHELL = SAMPLES / "programs" / "hemishell.nc"
CCW, CW = (SAMPLES / "ballbar" / f"v40r-100-{d}.csv" for d in ("ccw", "cw"))
TRACES = ["--plugin", "parametric", "--ballbar", str(CCW), "--ballbar", str(CW)]
COMMAND = [sys.executable, "-c", "from postproc.cli.main import main; main()"]


@pytest.fixture
def part(tmp_path):
    path = tmp_path / "part.nc"
    shutil.copy(HEMISHELL, path)
    return path


def test_a_symbolic_links_target_is_replaced_and_the_link_kept(run, part, tmp_path):
    target = tmp_path / "released" / "part-comp.nc"
    target.parent.mkdir()
    target.write_text("THE OLD OUTPUT\n")
    link = tmp_path / "current.nc"
    link.symlink_to(target)
    result = run("compensate", str(part), *TRACES, "-o", str(link))
    assert result.exit_code == 0, result.stderr
    assert link.is_symlink() and os.readlink(link) == str(target)
    assert "COMPENSATED" in target.read_text()


def test_a_dangling_link_gets_its_target_created(run, part, tmp_path):
    link = tmp_path / "next.nc"
    link.symlink_to(tmp_path / "made.nc")
    assert run("compensate", str(part), "-o", str(link)).exit_code == 0
    assert link.is_symlink() and (tmp_path / "made.nc").read_bytes() == HEMISHELL.read_bytes()


def test_a_character_device_is_written_through_never_replaced(run, part):
    before = os.stat("/dev/null")
    result = run("compensate", str(part), *TRACES, "-o", "/dev/null")
    assert result.exit_code == 0, result.stderr
    after = os.stat("/dev/null")
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


def test_dev_stdout_is_the_standard_output_it_names(part):
    result = subprocess.run(COMMAND + ["compensate", str(part), "-o", "/dev/stdout"], capture_output=True)
    assert result.returncode == 0 and result.stdout == HEMISHELL.read_bytes()


def test_dev_stdout_appended_to_a_file_appends(part, tmp_path):
    log = tmp_path / "programs.txt"
    log.write_bytes(b"EARLIER\n")
    with open(log, "ab") as handle:
        result = subprocess.run(COMMAND + ["compensate", str(part), "-o", "/dev/stdout"], stdout=handle,
                                stderr=subprocess.PIPE)
    assert result.returncode == 0
    assert log.read_bytes() == b"EARLIER\n" + HEMISHELL.read_bytes()


def test_a_fifo_is_written_through(run, part, tmp_path):
    fifo = tmp_path / "to-dnc"
    os.mkfifo(fifo)
    received = []
    reader = threading.Thread(target=lambda: received.append(open(fifo, "rb").read()))
    reader.start()
    result = subprocess.run(COMMAND + ["compensate", str(part), "-o", str(fifo)], capture_output=True, timeout=60)
    reader.join(10)
    assert result.returncode == 0 and received == [HEMISHELL.read_bytes()]
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def test_a_full_device_says_nothing_was_written(run, part):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full here")
    result = run("compensate", str(part), "-o", "/dev/full")
    assert result.exit_code == 3
    assert result.stderr == ("/dev/full: error: cannot write output: no space left for it (disk full, quota or file "
                             "size limit); nothing was written\n")


def test_a_directory_a_disk_and_a_read_only_file_are_refused(run, part, tmp_path):
    result = run("compensate", str(part), "-o", str(tmp_path))
    assert result.exit_code == 3 and "this is a directory; give a file name" in result.stderr
    readonly = tmp_path / "released.nc"
    readonly.write_text("RELEASED\n")
    readonly.chmod(0o444)
    result = run("compensate", str(part), "-o", str(readonly))
    assert result.exit_code == 3 and readonly.read_text() == "RELEASED\n"
    assert result.stderr == f"{readonly}: error: cannot write output: the file is read-only (its permissions say " \
                            "so); nothing was written\n"
    disks = [path for path in ("/dev/loop0", "/dev/sda", "/dev/vda") if os.path.exists(path)
             and stat.S_ISBLK(os.stat(path).st_mode)]
    for disk in disks[:1]:
        result = run("compensate", str(part), "-o", disk)
        assert result.exit_code == 3 and "this is a block device" in result.stderr


def test_an_existing_output_keeps_its_permissions(run, part, tmp_path):
    target = tmp_path / "out.nc"
    target.write_text("OLD\n")
    target.chmod(0o640)
    assert run("compensate", str(part), "-o", str(target)).exit_code == 0
    assert stat.S_IMODE(os.stat(target).st_mode) == 0o640 and target.read_bytes() == HEMISHELL.read_bytes()


# ---------------------------------------------------------------------- an output that is an input


def _same(run, tmp_path, *args):
    """Run; must be refused with exit 2 before anything is written, every file as it was."""
    before = {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()}
    result = run(*args)
    assert (result.exit_code, result.stdout_bytes) == (2, b""), result.stderr
    assert {path: path.read_bytes() for path in tmp_path.rglob("*") if path.is_file()} == before
    return result.stderr


def test_an_output_that_is_an_input_is_refused_in_every_command(run, part, tmp_path):
    trace = tmp_path / "ccw.csv"
    shutil.copy(CCW, trace)
    model = tmp_path / "m.json"
    assert run("fit", "--plugin", "ballbar-inverse", "--ballbar", str(trace), "-o", str(model)).exit_code == 0
    p = str(part)
    cases = [
        ("compensate", p, "-o", p),
        ("compensate", p, "-o", str(tmp_path / "." / "part.nc")),
        ("compensate", p, "--out-dir", str(tmp_path)),
        ("compensate", p, "--report", p),
        ("compensate", p, "--plugin", "ballbar-inverse", "--ballbar", str(trace), "-o", str(trace)),
        ("compensate", p, "--model", str(model), "-o", str(model)),
        ("compensate", p, "--model", str(model), "--report", str(model)),
        ("fit", "--plugin", "ballbar-inverse", "--ballbar", str(trace), "-o", str(trace)),
        ("path", p, "-o", p),
        ("path", p, "--plot", p),
        ("report", p, "-o", p),
        ("probe-program", p, "-o", p),
        ("simulate", "cut", p, "-o", p),
        ("ballbar", str(trace), "--plot", str(trace)),
        ("--log", p, "check", p),
    ]
    for args in cases:
        message = _same(run, tmp_path, *args)
        assert "it would be destroyed; write the output elsewhere" in message, (args, message)
    assert _same(run, tmp_path, "--log", p, "check", p) == (
        f"postproc: error: --log {p} is the input {p} (INPUT): it would be destroyed; write the output elsewhere "
        "(nothing was written)\n")


def test_links_to_the_input_are_the_input(run, part, tmp_path):
    soft, hard = tmp_path / "soft.nc", tmp_path / "hard.nc"
    soft.symlink_to(part)
    os.link(part, hard)
    for output in (soft, hard):
        message = _same(run, tmp_path, "compensate", str(part), "-o", str(output))
        assert message == (f"postproc: error: -o {output} is the input {part} (INPUT): it would be destroyed; write "
                           "the output elsewhere (nothing was written)\n")


def test_two_outputs_in_one_file_are_refused(run, part, tmp_path):
    out = str(tmp_path / "out.nc")
    message = _same(run, tmp_path, "compensate", str(part), *TRACES, "-o", out, "--report", out)
    assert message == (f"postproc: error: --report {out} and -o {out} are the same file: one output would destroy "
                       "the other; give them different names\n")


def test_a_log_that_is_an_output_gets_no_line_of_the_refusal(run, part, tmp_path):
    kept = tmp_path / "kept.nc"
    kept.write_bytes(b"%\nO1\nM30\n%\n")  # the user's program, there before the run
    for args in (("-o", str(kept)), ("--report", str(kept))):
        message = _same(run, tmp_path, "--log", str(kept), "compensate", str(part), *TRACES, *args)
        assert message.endswith(f"--log {kept} are the same file: one output would destroy the other; give them "
                                "different names\n"), message


@pytest.mark.parametrize("args", [
    ("compensate", "{part}", "--machine", ""), ("compensate", "{part}", "-o", ""), ("compensate", "{part}", "--out-dir", ""),
    ("compensate", "{part}", "--report", ""), ("compensate", "{part}", "--calibration", ""), ("check", ""),
    ("path", "{part}", "--machine", ""), ("fit", "--plugin", "ballbar-inverse", "--ballbar", ""),
    ("--log", "", "check", "{part}")])
def test_an_empty_value_is_refused_never_taken_for_the_option_left_out(run, part, tmp_path, args):
    """``--machine "$PROFILE"`` with the variable unset must not run without the profile's limits."""
    message = _same(run, tmp_path, *(arg.format(part=part) for arg in args))
    assert "is empty (a shell variable that is not set?)" in message, message


def test_standard_output_redirected_onto_the_input_is_refused(part, tmp_path):
    copy = tmp_path / "copy.nc"
    shutil.copy(part, copy)
    with open(copy, "ab") as appended:  # '>>' keeps the program: writing it would add to it
        result = subprocess.run(COMMAND + ["compensate", str(copy)], stdout=appended, stderr=subprocess.PIPE,
                                text=True)
    assert result.returncode == 2 and copy.read_bytes() == HEMISHELL.read_bytes()
    assert result.stderr.startswith(f"postproc: error: standard output is the input {copy} (INPUT)")


# ---------------------------------------------------------------------- --out-dir


def test_out_dir_is_created_with_its_parents(run, part, tmp_path):
    folder = tmp_path / "released" / "2026-11"
    result = run("compensate", str(part), *TRACES, "--out-dir", str(folder))
    assert result.exit_code == 0, result.stderr
    assert "COMPENSATED" in (folder / "part.nc").read_text()


def test_out_dir_where_a_file_stands_is_refused(run, part, tmp_path):
    blocker = tmp_path / "out"
    blocker.write_text("A FILE\n")
    result = run("compensate", str(part), "--out-dir", str(blocker))
    assert (result.exit_code, result.stderr) == (2, f"postproc: error: --out-dir {blocker}: exists and is not a "
                                                    "directory; give a folder\n")
    assert blocker.read_text() == "A FILE\n"


def test_out_dir_that_cannot_be_created_is_said(run, part, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("A FILE\n")
    result = run("compensate", str(part), "--out-dir", str(blocker / "sub"))
    assert result.exit_code == 3
    assert result.stderr == (f"{blocker / 'sub'}: error: cannot create the output folder: a part of the path is a "
                             "file, not a directory; nothing was written\n")


def test_out_dir_made_for_a_run_that_fails_is_taken_away(run, tmp_path):
    bad = tmp_path / "bad.nc"
    bad.write_text("G01 X2..\n")
    folder = tmp_path / "new"
    assert run("compensate", str(bad), "--out-dir", str(folder)).exit_code == 3
    assert not folder.exists()
    nested = tmp_path / "released" / "2026-11" / "lathe2"  # its parents made for it go too
    assert run("compensate", str(bad), "--out-dir", str(nested)).exit_code == 3
    assert sorted(path.name for path in tmp_path.iterdir()) == ["bad.nc"]


def test_two_programs_of_one_name_into_one_folder_are_refused(run, part, tmp_path):
    other = tmp_path / "lathe2" / "part.nc"
    other.parent.mkdir()
    other.write_text("G00 X1. Z1.\n")
    out = tmp_path / "out"
    message = _same(run, tmp_path, "compensate", str(part), str(other), "--out-dir", str(out))
    assert message == (f"postproc: error: {part} and {other} have the same name: in --out-dir {out} one would "
                       "overwrite the other; compensate them into different folders\n")
    assert not out.exists()


def test_stdin_has_no_name_for_out_dir(run, tmp_path):
    result = run("compensate", "-", "--out-dir", str(tmp_path / "o"), input=HEMISHELL.read_bytes())
    assert result.exit_code == 2 and "standard input (-) has none: give -o" in result.stderr


def test_the_python_api_refuses_an_output_that_is_its_input(part):
    import postproc
    from postproc.diagnostics import UsageError

    with pytest.raises(UsageError, match="it would be destroyed"):
        postproc.Pipeline().compensate_file(str(part), str(part))
    assert part.read_bytes() == HEMISHELL.read_bytes()


def _size_limited(limit: int):
    """For a child process: files it writes may not grow beyond ``limit`` bytes, as on a disk
    that is full (writes fail with EFBIG; SIGXFSZ ignored, as a shell's ulimit -f leaves it)."""
    import resource
    import signal

    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


#: every command that writes a file with -o (or its FILE): (arguments, the name it writes)
_WRITERS = {
    "compensate": (["compensate", str(HEMISHELL), *TRACES, "-o"], "out.nc"),
    "path": (["path", str(HEMISHELL), "-o"], "path.csv"),
    "fit": (["fit", *TRACES, "-o"], "model.json"),
    "report": (["report", str(HEMISHELL), *TRACES, "-o"], "report.html"),
    "ballbar --plot": (["ballbar", str(CCW), str(CW), "--plot"], "plot.svg"),
    "import-trace": (["import-trace", str(CCW), "--radius", "100", "--direction", "ccw", "--columns", "1,2", "-o"],
                     "trace.csv"),
    "probe-program": (["probe-program", str(HEMISHELL), "-o"], "probe.nc"),
    "simulate ballbar": (["simulate", "ballbar", "--direction", "cw", "-o"], "cw.csv"),
    "profile init": (["profile", "init"], "lathe.toml"),
}


@pytest.mark.parametrize("limit", [0, 100])
@pytest.mark.parametrize("command", sorted(_WRITERS))
def test_a_full_disk_is_a_clear_error_and_leaves_nothing_whatever_the_command(tmp_path, command, limit):
    """A write that fails for want of space was an internal error (exit 5) where the failing
    flush came again when the spool was dropped, or where Python looked for its temporary folder
    (by writing a file there) and the program's copy was flushed; profile init left an empty
    profile: every command says the disk is full (exit 3), with nothing written, and leaves no
    file behind."""
    arguments, name = _WRITERS[command]
    folder = tmp_path / "out"
    folder.mkdir()
    # no bytecode written: Python writes a .pyc cut short at the limit and reads it back broken
    result = subprocess.run([*COMMAND, *arguments, str(folder / name)], capture_output=True, text=True,
                            cwd=tmp_path, preexec_fn=_size_limited(limit), timeout=300,
                            env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1"})
    assert result.returncode == 3, result.stderr
    assert "internal error" not in result.stderr and "Traceback" not in result.stderr
    # a command that reads a program keeps a copy of it in TMPDIR first: on one disk, that fails first
    said = (f"{folder / name}: error: cannot write output: no space left for it",
            f"{HEMISHELL}: error: cannot keep a copy of the program in ")
    assert result.stderr.startswith(said) and "no space left for it" in result.stderr, result.stderr
    assert result.stderr.count("error:") == 1 and list(folder.iterdir()) == []


# ------------------------------------------------ a new file where the file system has no hard links

#: what link() says on FAT and exFAT memory sticks, SMB shares and other file systems without hard links
_NO_HARD_LINKS = ["EPERM", "EOPNOTSUPP", "EXDEV", "ENOSYS", "EMLINK"]


def _links_refused(monkeypatch, name: str) -> None:
    import errno

    def refuse(*_args, **_kwargs):
        raise OSError(getattr(errno, name), os.strerror(getattr(errno, name)))

    monkeypatch.setattr(os, "link", refuse)


def _new_spool(path, data: bytes):
    from postproc.files.output import Spool

    spool = Spool(str(path))
    spool.write(data)
    return spool


@pytest.mark.parametrize("name", _NO_HARD_LINKS)
def test_a_new_file_is_made_where_the_file_system_has_no_hard_links(monkeypatch, tmp_path, name):
    """A new file (profile init) was made by a hard link, which FAT, exFAT and many SMB shares
    refuse: there it is created exclusively and the content copied in, with the usual mode of a
    new file and no spool left beside it."""
    _links_refused(monkeypatch, name)
    target = tmp_path / "lathe.toml"
    data = b"[machine]\n" * 20000  # more than one chunk of the copy
    with _new_spool(target, data) as spool:
        spool.commit(new=True)
    assert target.read_bytes() == data
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o666 & ~umask
    assert list(tmp_path.iterdir()) == [target]


@pytest.mark.parametrize("name", _NO_HARD_LINKS)
def test_a_file_standing_where_a_new_one_goes_is_never_overwritten_without_hard_links(monkeypatch, tmp_path, name):
    """A file made at the destination while the run went on is kept, links or not."""
    _links_refused(monkeypatch, name)
    target = tmp_path / "lathe.toml"
    with _new_spool(target, b"new\n") as spool:
        target.write_bytes(b"the user's own\n")
        with pytest.raises(FileExistsError):
            spool.commit(new=True)
    assert target.read_bytes() == b"the user's own\n" and list(tmp_path.iterdir()) == [target]


def test_a_copy_that_fails_without_hard_links_leaves_nothing(monkeypatch, tmp_path):
    """A disk that fills while the new file is copied: the error says so, and neither the
    half-written file nor the spool is left."""
    import errno

    from postproc.diagnostics import OutputError

    _links_refused(monkeypatch, "EPERM")

    def full(*_args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    target = tmp_path / "lathe.toml"
    with _new_spool(target, b"[machine]\n") as spool:
        monkeypatch.setattr(os, "write", full)
        with pytest.raises(OutputError, match="no space left for it"):
            spool.commit(new=True)
    assert list(tmp_path.iterdir()) == []


def test_a_link_that_fails_for_another_reason_is_an_error_not_a_copy(monkeypatch, tmp_path):
    """Only a file system without hard links is worked around; any other failure of the link is
    said, and nothing is made."""
    from postproc.diagnostics import OutputError

    _links_refused(monkeypatch, "EIO")
    target = tmp_path / "lathe.toml"
    with _new_spool(target, b"[machine]\n") as spool:
        with pytest.raises(OutputError):
            spool.commit(new=True)
    assert list(tmp_path.iterdir()) == []


def test_profile_init_writes_its_profile_without_hard_links(monkeypatch, run, tmp_path):
    _links_refused(monkeypatch, "EPERM")
    target = tmp_path / "lathe.toml"
    result = run("profile", "init", str(target))
    assert result.exit_code == 0, result.stderr
    assert result.stdout == "" and "starter machine profile written" in result.stderr
    assert target.read_text().startswith("#") and list(tmp_path.iterdir()) == [target]
    again = run("profile", "init", str(target))
    assert again.exit_code == 2 and "never overwrites" in again.stderr
