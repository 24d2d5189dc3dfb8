"""Output files that never lose what a user computed.

Every command that writes calls :func:`check_output` (or :func:`check_outdir`) before it
computes anything: a directory given as a file, a missing or read-only directory, or an
existing file without ``--force`` is one line naming the path (exit 2), in under a second.
Files are then written under a temporary name next to their destination and renamed into
place once complete (:func:`replacing`), so an interrupted write never leaves a half file
under the name the user asked for, nor destroys the file that was there before. The
temporary name is random and created exclusively (never followed through a link), and only
a regular file is ever replaced (``--force`` refuses a FIFO, a device, a socket).

One job at a time writes an output: :func:`output_lock` holds ``dir/.name.lock`` (host, pid,
start time; ``flock``-ed while the job lives) for the whole job; a second job on the same
output is refused naming the holder, and the lock of a killed job is reported as stale with
the command that removes it, never taken over silently.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import shlex
import shutil
import signal
import socket
import stat
import tempfile
import threading
import time

from wheelrom.runtime.errors import DiskFull, InputError, OutputExists

# what any output needs at least (a model or stability file is tens of kB to a few MB; an
# HDF5 file that cannot write its metadata is lost)
MIN_FREE_BYTES = 1 << 20


def _directory_problem(directory: str, flag: str, path: str) -> str | None:
    if not os.path.exists(directory):
        return f"{flag} {path}: directory '{directory}' does not exist"
    if not os.path.isdir(directory):
        return f"{flag} {path}: '{directory}' is not a directory"
    if not os.access(directory, os.W_OK | os.X_OK):
        return f"{flag} {path}: directory '{directory}' is not writable"
    return None


def output_problem(path: str, force: bool = False, flag: str = "--out") -> InputError | None:
    """Why ``path`` cannot be written (``None``: it can). An existing file is an
    :class:`OutputExists` unless ``force``; a directory, anything else but a regular file
    (a FIFO, a device, a socket, a link to one: not even with ``force``), or a missing or
    read-only parent directory, an :class:`InputError` naming the path and ``flag``."""
    if os.path.isdir(path):
        return InputError(f"{flag} {path}: is a directory, not a file")
    directory = os.path.dirname(os.path.abspath(path))
    why = _directory_problem(directory, flag, path)
    if why:
        return InputError(why)
    what = not_a_regular_file(path)
    if what:  # not even with --force: the rename would put a file where a device was
        return InputError(f"{flag} {path}: is {what}, not a regular file: it is never "
                          "replaced, choose another name")  # fmt: skip
    if os.path.exists(path):
        if not force:
            return OutputExists(path)
        if not os.access(path, os.W_OK):
            return InputError(f"{flag} {path}: the existing file is not writable")
    return space_problem(path, 0, flag)  # the least any output needs; sizes: check_space


_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a directory"))  # fmt: skip


def not_a_regular_file(path: str) -> str | None:
    """What ``path`` is when something other than a regular file (or a symbolic link to
    one) is there, e.g. ``"a FIFO (named pipe)"``; ``None``: nothing, or a regular file."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return None
    if stat.S_ISLNK(mode):
        try:
            mode = os.stat(path).st_mode
        except OSError:
            return "a symbolic link to nothing"
        if stat.S_ISREG(mode):
            return None
        return "a symbolic link to " + _kind(mode)
    return None if stat.S_ISREG(mode) else _kind(mode)


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "not a regular file")


def check_output(path: str, force: bool = False, flag: str = "--out") -> None:
    """Raise :func:`output_problem`'s error, if any."""
    problem = output_problem(path, force, flag)
    if problem:
        raise problem


def check_outdir(path: str, flag: str = "--outdir") -> None:
    """An output directory: existing and writable, or creatable (its nearest existing
    ancestor is a writable directory). Creates nothing."""
    if os.path.exists(path):
        if not os.path.isdir(path):
            raise InputError(f"{flag} {path}: is a file, not a directory")
        if not os.access(path, os.W_OK | os.X_OK):
            raise InputError(f"{flag} {path}: directory is not writable")
        return
    ancestor = os.path.dirname(os.path.abspath(path))
    while not os.path.exists(ancestor):
        ancestor = os.path.dirname(ancestor)
    why = _directory_problem(ancestor, flag, path)
    if why:
        raise InputError(f"{flag} {path}: cannot be created ({why.split(': ', 1)[1]})")


def partial_name(path: str) -> str:
    """A new temporary file to build ``path`` under, created empty and exclusively (never
    through an existing name or link) with the permissions a new file gets: hidden, random,
    in the destination's directory (so that the final rename is atomic), the extension last
    (writers that choose the format by it, meshio, still work): ``dir/.seg.k3x9q2_a.partial.vtu``
    for ``dir/seg.vtu``. Under MPI rank 0 chooses it and broadcasts it
    (:func:`create_collectively`)."""
    directory, name = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(name)
    fd, partial = tempfile.mkstemp(suffix=f".partial{ext}", prefix=f".{stem}.", dir=directory)
    try:
        os.fchmod(fd, 0o666 & ~_umask())  # mkstemp's 0600: the output is the user's usual file
    finally:
        os.close(fd)
    return partial


def _umask() -> int:
    with _UMASK_LOCK:
        mask = os.umask(0o022)
        os.umask(mask)
    return mask


_UMASK_LOCK = threading.Lock()


def _partial_pattern(path: str) -> re.Pattern:
    """The names :func:`partial_name` gives for ``path`` (leftovers of a killed job)."""
    stem, ext = os.path.splitext(os.path.basename(path))
    return re.compile(rf"\.{re.escape(stem)}\.[A-Za-z0-9_]{{8}}\.partial{re.escape(ext)}")


def rename_problem(partial: str, path: str, flag: str = "--out") -> InputError | None:
    """Why the finished ``partial`` must not be renamed onto ``path`` (None: it may): it is
    no longer the regular file this process created, or ``path`` became something other than
    a regular file."""
    if not stat.S_ISREG(os.lstat(partial).st_mode):
        return InputError(f"{flag} {path}: its temporary file {partial} was replaced by "
                          "something other than a regular file; nothing was written")  # fmt: skip
    what = not_a_regular_file(path)
    if what:
        return InputError(f"{flag} {path}: is now {what}, not a regular file: it is never "
                          f"replaced; nothing was written")  # fmt: skip
    return None


def _finish(partial: str, path: str) -> None:
    problem = rename_problem(partial, path)
    if problem:
        raise problem
    os.replace(partial, path)


@contextlib.contextmanager
def replacing(path: str):
    """Yield a new temporary path to write (:func:`partial_name`); on success it atomically
    replaces ``path`` (a regular file only, :func:`rename_problem`), on any error (or
    Ctrl-C) it is removed and ``path`` is untouched."""
    partial = partial_name(path)
    try:
        yield partial
        _finish(partial, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(partial)
        raise


def create_collectively(out: str, comm, fill) -> None:
    """Create the parallel HDF5 file ``out`` on the mpi4py ``comm``: ``fill(f)`` writes its
    layout into a file opened collectively under the temporary name (chosen and created by
    rank 0, broadcast), and rank 0 renames it into place once every rank is done, so ``out``
    is readable from the moment it exists (an existing ``out``, ``--force``, is replaced
    only then, and only a regular file); a failure leaves no temporary."""
    import h5py

    partial = failure = None
    if comm.rank == 0:
        try:
            partial = partial_name(out)
        except OSError as exc:
            failure = InputError(f"--out {out}: cannot create its temporary file ({exc})")
    partial, failure = comm.bcast((partial, failure))
    if failure:
        raise failure
    try:
        with h5py.File(partial, "w", driver="mpio", comm=comm) as f:
            fill(f)
    except BaseException:
        if comm.rank == 0:
            with contextlib.suppress(FileNotFoundError):
                os.remove(partial)
        raise
    comm.Barrier()
    if comm.rank == 0:
        try:
            _finish(partial, out)
        except Exception as exc:  # told to every rank: none waits for a lost file
            with contextlib.suppress(FileNotFoundError):
                os.remove(partial)
            failure = exc if isinstance(exc, InputError) else InputError(
                f"--out {out}: cannot be renamed into place ({exc})")  # fmt: skip
    failure = comm.bcast(failure)
    if failure:
        raise failure


# --------------------------------------------------------------------------------------
# one job per output
# --------------------------------------------------------------------------------------


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
                                 f"({type(exc).__name__}: {exc})")  # fmt: skip
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
            "started": time.strftime("%Y-%m-%d %H:%M:%S %z")}  # fmt: skip


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
                              "run again")  # fmt: skip
        except OSError:
            return InputError(f"{flag} {path}: its lock {lock} is not a lock file wheelrom "
                              f"made; if no job writes {path}, remove it: {remove}")  # fmt: skip
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
                          f"it to finish or choose another {flag}")  # fmt: skip
    return InputError(f"{flag} {path}: stale lock {lock} of a job that is no longer running "
                      f"({who}); if no job writes {path}, remove it and run again: "
                      f"{remove}")  # fmt: skip


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
            f"{info.get('started', '?')}")  # fmt: skip


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


def size_text(n: float) -> str:
    """``1536`` -> ``"1.5 kB"``: decimal units, as ``df -H`` prints them."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} TB"  # pragma: no cover


def space_problem(path: str, needed: int, flag: str = "--out") -> InputError | None:
    """Why ``needed`` bytes cannot be written at ``path`` (None: they fit, with 1 % and
    :data:`MIN_FREE_BYTES` to spare): one line with the path, the bytes needed and free."""
    directory = os.path.dirname(os.path.abspath(path))
    free = shutil.disk_usage(directory).free
    want = int(needed * 1.01) + MIN_FREE_BYTES
    if free >= want:
        return None
    return InputError(f"{flag} {path}: needs about {size_text(want)}, the disk holding "
                      f"'{directory}' has {size_text(free)} free")  # fmt: skip


def check_space(path: str, needed: int, flag: str = "--out") -> None:
    """Raise :func:`space_problem`'s error, if any."""
    problem = space_problem(path, needed, flag)
    if problem:
        raise problem


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` is the operating system's "no space left" (or quota) error, also as
    HDF5 reports it through h5py."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return True
    return isinstance(exc, OSError) and "No space left on device" in str(exc)


def disk_full(path: str, exc: BaseException, kept: str) -> DiskFull:
    """The one-line error of a write that filled the disk: the file, the errno, what is
    kept (``kept``)."""
    code = exc.errno if isinstance(exc, OSError) and exc.errno else errno.ENOSPC
    return DiskFull(f"{path}: the disk is full (errno {code}, {errno.errorcode.get(code, '?')}"
                    f": {os.strerror(code)}); {kept}")
