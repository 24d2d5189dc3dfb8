"""One job at a time writes an output: :func:`output_lock` holds ``dir/.name.lock`` (host, pid,
start time; ``flock``-ed while the job lives) for the whole job; a second job on the same
output is refused naming the holder, and the lock of a killed job is reported as stale with
the command that removes it, never taken over silently."""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shlex
import signal
import socket
import tempfile
import threading
import time

from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import _directory_problem, _partial_pattern, _umask


def lock_name(path: str) -> str:
    """The lock file of output ``path``: ``dir/.name.lock`` beside it."""
    directory, name = os.path.split(os.path.abspath(path))
    return os.path.join(directory, f".{name}.lock")


@contextlib.contextmanager
def output_lock(path: str | None, comm=None, flag: str = "--out"):
    """Hold the output ``path`` for the whole ``with`` block: nobody else (another job on
    this or another host sharing the directory) writes it meanwhile. ``None``: nothing to
    hold.

    The lock is ``dir/.name.lock``, created exclusively with the holder's host, pid and start
    time, and ``flock``-ed for as long as the holder lives. A held lock is an
    :class:`InputError` naming the holder (exit 2, before anything is computed); a lock whose
    holder is gone (killed: its ``flock`` is released, its pid dead on this host) is
    reported as stale with the ``rm`` that removes it, and never taken over. Under MPI
    (``comm``: mpi4py) rank 0 takes the lock and its verdict is broadcast, so every rank
    refuses or goes on together. The lock is removed when the block ends, on an error, on
    Ctrl-C and on SIGTERM (mpirun's Ctrl-C; while held, SIGTERM raises
    ``KeyboardInterrupt`` unless a handler is set)."""
    if not path:
        yield
        return
    held, problem = None, None
    if comm is None or comm.rank == 0:
        try:
            held = _acquire(path, flag)
        except InputError as exc:
            problem = exc
        except Exception as exc:  # rank 0's surprise must not leave the others waiting
            problem = InputError(f"{flag} {path}: cannot take its lock {lock_name(path)} "
                                 f"({type(exc).__name__}: {exc})")
    if comm is not None:
        problem = comm.bcast(problem)
    if problem:
        if held is not None:  # pragma: no cover (rank 0 never holds a refused lock)
            _release(*held)
        raise problem
    previous = _terminate_as_interrupt() if held is not None else None
    try:
        yield
    finally:
        if held is not None:
            _release(*held)
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _terminate_as_interrupt():
    """SIGTERM (mpirun's way of passing on Ctrl-C) as KeyboardInterrupt while a lock is
    held, so that it is removed; returns the handler to restore (None: left as it was)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return None

    def handler(signum, frame):
        raise KeyboardInterrupt

    return signal.signal(signal.SIGTERM, handler)


def _holder() -> dict:
    return {"host": socket.gethostname(), "pid": os.getpid(),
            "started": time.strftime("%Y-%m-%d %H:%M:%S %z")}


def _acquire(path: str, flag: str) -> tuple[int, str]:
    """Create and ``flock`` the lock of ``path``; ``(fd, lock path)``. Raises the
    :class:`InputError` of a held or stale lock, or of a directory that cannot hold one."""
    import fcntl

    directory = os.path.dirname(os.path.abspath(path))
    why = _directory_problem(directory, flag, path)
    if why:
        raise InputError(why)
    lock = lock_name(path)
    # the content is written and flock-ed under a private name, then hard-linked to the lock
    # name (fails if it exists): the lock never appears empty or unlocked
    fd, private = tempfile.mkstemp(prefix=f".{os.path.basename(lock)}.", dir=directory)
    try:
        os.fchmod(fd, 0o644 & ~_umask())  # readable: whoever shares the folder sees the holder
        os.write(fd, (json.dumps(_holder()) + "\n").encode())
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        try:
            os.link(private, lock)
        except FileExistsError:
            raise _lock_problem(path, lock, flag) from None
        except OSError as exc:  # no hard links here (some FUSE/SMB mounts): exclusive create
            if exc.errno not in (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
                raise
            os.close(fd)
            fd = _create_exclusively(path, lock, flag)
    except BaseException:
        os.close(fd)
        raise
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.remove(private)
    _remove_leftovers(path)
    return fd, lock


def _create_exclusively(path: str, lock: str, flag: str) -> int:
    import fcntl

    try:
        fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o644)
    except FileExistsError:
        raise _lock_problem(path, lock, flag) from None
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.write(fd, (json.dumps(_holder()) + "\n").encode())
    return fd


def _release(fd: int, lock: str) -> None:
    """Remove the lock (if it is still this one), then let go of its ``flock``."""
    with contextlib.suppress(OSError):
        mine, there = os.fstat(fd), os.lstat(lock)
        if (mine.st_dev, mine.st_ino) == (there.st_dev, there.st_ino):
            os.remove(lock)
    os.close(fd)


def _remove_leftovers(path: str) -> None:
    """Temporary files of ``path`` left by a killed job (this job holds the lock: nobody
    else builds ``path`` now)."""
    directory = os.path.dirname(os.path.abspath(path))
    pattern = _partial_pattern(path)
    for name in os.listdir(directory):
        if pattern.fullmatch(name):
            with contextlib.suppress(OSError):
                os.remove(os.path.join(directory, name))  # a link: the link, not its target


def _lock_problem(path: str, lock: str, flag: str, tries: int = 5) -> InputError:
    """The error of an existing lock ``lock`` of ``path``: held (naming the holder), or
    stale (naming the command that removes it)."""
    import fcntl

    remove = f"rm {shlex.quote(lock)}"
    for attempt in range(tries):
        try:
            fd = os.open(lock, os.O_RDONLY | os.O_NOFOLLOW)
        except FileNotFoundError:  # released meanwhile: the job just ended
            return InputError(f"{flag} {path}: another job was writing it until just now; "
                              "run again")
        except OSError:
            return InputError(f"{flag} {path}: its lock {lock} is not a lock file wheelrom "
                              f"made; if no job writes {path}, remove it: {remove}")
        try:
            info = _read_holder(fd)
            try:
                fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
                held = False
            except BlockingIOError:
                held = True
            except OSError:  # no flock on this file system: the pid alone decides
                held = None
        finally:
            os.close(fd)
        if info is None and held is not True and attempt < tries - 1:
            time.sleep(0.1)  # an exclusive create (no hard links) still writing its holder
            continue
        break
    who = _describe(info)
    alive = _alive(info)
    if held or (held is None and alive is not False):
        return InputError(f"{flag} {path}: in use by another wheelrom job ({who}); wait for "
                          f"it to finish or choose another {flag}")
    return InputError(f"{flag} {path}: stale lock {lock} of a job that is no longer running "
                      f"({who}); if no job writes {path}, remove it and run again: "
                      f"{remove}")


def _read_holder(fd: int) -> dict | None:
    try:
        info = json.loads(os.read(fd, 4096).decode())
    except (ValueError, OSError):
        return None
    return info if isinstance(info, dict) else None


def _describe(info: dict | None) -> str:
    if info is None:
        return "holder unknown"
    return (f"host {info.get('host', '?')}, pid {info.get('pid', '?')}, started "
            f"{info.get('started', '?')}")


def _alive(info: dict | None) -> bool | None:
    """Whether the holder's process lives (None: cannot tell, another host)."""
    if info is None or info.get("host") != socket.gethostname():
        return None
    try:
        os.kill(int(info.get("pid")), 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # someone else's process: it exists
        return True
    except (TypeError, ValueError, OverflowError):
        return None
    return True
