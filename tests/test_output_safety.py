"""One job per output, no writing through links, --force replaces regular files only (issue
#40): a second job on the same --out is refused naming the first (whose file comes out
complete), a killed job's lock is reported as stale with the command that removes it (never
taken over), a planted link at the temporary name is not followed, and a FIFO or a device is
never replaced."""

import json
import os
import shlex
import socket
import stat
import subprocess
import sys

import h5py
import pytest

from conftest import HANG_S, SMALL
from wheelrom.cli import main as cli
from wheelrom.runtime.locks import lock_name, output_lock

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", MPLBACKEND="Agg")


def wheelrom(*args, timeout=HANG_S):
    """The CLI in a subprocess: another job."""
    return subprocess.run([sys.executable, "-m", "wheelrom.cli.main", *args],
                          capture_output=True, text=True, timeout=timeout, env=ENV)


def _error_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]


def _stability_cases(path) -> int:
    with h5py.File(path, "r") as f:
        return int(f["stability/verdict"].shape[0])


# --- one job per output -----------------------------------------------------------------


def test_second_job_on_the_same_out_is_refused_naming_the_first(tmp_path, monkeypatch, capsys):
    out = tmp_path / "s.h5"
    from wheelrom.studies import stability

    real, second = stability.run_stability, []

    def meanwhile(*args, **kw):  # the first job is computing: a second one starts
        second.append(wheelrom("stability", SMALL, "--out", str(out), "--force"))
        return real(*args, **kw)

    monkeypatch.setattr(stability, "run_stability", meanwhile)
    assert cli.main(["stability", SMALL, "--out", str(out)]) == 0
    res = second[0]
    assert res.returncode == 2, res.stderr
    [line] = _error_lines(res.stderr)
    assert f"--out {out}: in use by another wheelrom job" in line
    assert f"pid {os.getpid()}" in line and f"host {socket.gethostname()}" in line
    assert "started " in line
    assert "segment" not in res.stderr  # refused before building anything
    assert _stability_cases(out) == 3  # the first job's file, complete
    assert sorted(os.listdir(tmp_path)) == ["s.h5"]  # lock released, no temporary left
    capsys.readouterr()


def test_lock_is_released_on_errors_and_ctrl_c(tmp_path, monkeypatch, capsys):
    out = tmp_path / "s.h5"
    out.write_bytes(b"precious")
    assert cli.main(["stability", SMALL, "--out", str(out)]) == 2  # exists, no --force
    assert not os.path.exists(lock_name(out))

    held = []

    def interrupted(*_, **__):  # Ctrl-C while computing, the lock held
        held.append(os.path.exists(lock_name(out)))
        raise KeyboardInterrupt

    monkeypatch.setattr("wheelrom.studies.stability.run_stability", interrupted)
    assert cli.main(["stability", SMALL, "--out", str(out), "--force"]) == 130
    assert held == [True]
    assert out.read_bytes() == b"precious"
    assert sorted(os.listdir(tmp_path)) == ["s.h5"]
    capsys.readouterr()


def test_stale_lock_of_a_killed_job_is_reported_not_taken(tmp_path, capsys, nothing_computed):
    folder = tmp_path / "my results"  # a space: the rm command must be quoted
    folder.mkdir()
    out = folder / "s.h5"
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()  # its pid: no longer a process
    lock = lock_name(out)
    holder = {"host": socket.gethostname(), "pid": dead.pid, "started": "2024-01-02 03:04:05"}
    with open(lock, "w") as f:
        json.dump(holder, f)
    before = os.stat(lock)
    assert cli.main(["stability", SMALL, "--out", str(out)]) == 2
    [line] = _error_lines(capsys.readouterr().err)
    assert "stale lock" in line and f"pid {dead.pid}" in line and "2024-01-02 03:04:05" in line
    assert line.endswith(f"rm {shlex.quote(lock)}")
    after = os.stat(lock)  # still there, untouched
    assert (after.st_ino, after.st_mtime_ns) == (before.st_ino, before.st_mtime_ns)
    assert not out.exists()


def test_lock_held_in_this_process_blocks_a_library_sweep(tmp_path, nothing_computed):
    from mpi4py import MPI

    from wheelrom import config
    from wheelrom.runtime.errors import InputError
    from wheelrom.studies.sweep import run_sweep

    out = str(tmp_path / "s.h5")
    with output_lock(out), pytest.raises(InputError, match=f"pid {os.getpid()}"):
        run_sweep(config.load(SMALL), out, MPI.COMM_SELF)
    assert os.listdir(tmp_path) == []


# --- the temporary file ------------------------------------------------------------------


def test_a_link_at_the_old_temporary_name_is_not_followed(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("not yours")
    (tmp_path / ".sym.partial.h5").symlink_to(victim)
    out = tmp_path / "sym.h5"
    assert cli.main(["stability", SMALL, "--out", str(out)]) == 0
    assert victim.read_text() == "not yours"
    mode = os.lstat(out).st_mode
    assert stat.S_ISREG(mode) and _stability_cases(out) == 3
    umask = os.umask(0o022)
    os.umask(umask)
    assert stat.S_IMODE(mode) == 0o666 & ~umask  # the usual permissions, not mkstemp's 0600
    assert sorted(os.listdir(tmp_path)) == [".sym.partial.h5", "sym.h5", "victim.txt"]
    capsys.readouterr()


# --- --force replaces regular files only -----------------------------------------------


def test_force_refuses_a_fifo(tmp_path, capsys, nothing_computed):
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    assert cli.main(["stability", SMALL, "--out", str(fifo), "--force"]) == 2
    [line] = _error_lines(capsys.readouterr().err)
    assert line == (f"wheelrom: --out {fifo}: is a FIFO (named pipe), not a regular file: it "
                    "is never replaced, choose another name")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert sorted(os.listdir(tmp_path)) == ["pipe.h5"]


def test_force_refuses_a_link_to_a_device(tmp_path, capsys, nothing_computed):
    link = tmp_path / "null.h5"
    link.symlink_to(os.devnull)
    assert cli.main(["stability", SMALL, "--out", str(link), "--force"]) == 2
    [line] = _error_lines(capsys.readouterr().err)
    assert f"--out {link}: is a symbolic link to a character device" in line
    assert os.path.islink(link) and os.readlink(link) == os.devnull
