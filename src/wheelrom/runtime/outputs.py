"""Output files that never lose what a user computed.

Every command that writes calls :func:`check_output` (or :func:`check_outdir`) before it
computes anything: a directory given as a file, a missing or read-only directory, or an
existing file without ``--force`` is one line naming the path (exit 2), in under a second.
Files are then written under a temporary name next to their destination and renamed into
place once complete (:func:`replacing`), so an interrupted write never leaves a half file
under the name the user asked for, nor destroys the file that was there before. The
temporary name is random and created exclusively (never followed through a link), and only
a regular file is ever replaced (``--force`` refuses a FIFO, a device, a socket).

One job at a time writes an output: :func:`wheelrom.runtime.locks.output_lock`.
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import shutil
import stat
import tempfile
import threading

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
                          "replaced, choose another name")
    if os.path.exists(path):
        if not force:
            return OutputExists(path)
        if not os.access(path, os.W_OK):
            return InputError(f"{flag} {path}: the existing file is not writable")
    return space_problem(path, 0, flag)  # the least any output needs; sizes: check_space


_KINDS = ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"),
          (stat.S_ISDIR, "a directory"))


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
                          "something other than a regular file; nothing was written")
    what = not_a_regular_file(path)
    if what:
        return InputError(f"{flag} {path}: is now {what}, not a regular file: it is never "
                          f"replaced; nothing was written")
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
                f"--out {out}: cannot be renamed into place ({exc})")
    failure = comm.bcast(failure)
    if failure:
        raise failure


# --------------------------------------------------------------------------------------
# one job per output
# --------------------------------------------------------------------------------------


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
                      f"'{directory}' has {size_text(free)} free")


def check_space(path: str, needed: int, flag: str = "--out") -> None:
    """Raise :func:`space_problem`'s error, if any."""
    problem = space_problem(path, needed, flag)
    if problem:
        raise problem


def memory_problem(needed: int, what: str, advice: str) -> InputError | None:
    """Why an allocation of about ``needed`` bytes, sized by ``what`` (the option or key the
    user gave, and its value), must not start (None: it fits in the memory available,
    :func:`~wheelrom.runtime.environment.available_memory`, or that is unknown): one line
    naming ``what``, the bytes needed and available and ``advice`` (what to give instead).
    Every input that sizes an allocation is checked here before anything is computed: a
    traceback from numpy's allocator (or the kernel's OOM killer) after minutes of work is
    no answer."""
    from wheelrom.runtime.environment import available_memory

    available = available_memory()
    if available is None or needed <= available:
        return None
    return InputError(f"{what} would need about {size_text(needed)} of memory, "
                      f"{size_text(available)} is available: {advice}")


def check_memory(needed: int, what: str, advice: str) -> None:
    """Raise :func:`memory_problem`'s error, if any."""
    problem = memory_problem(needed, what, advice)
    if problem:
        raise problem


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` is the operating system's "no space left" (or quota) error, also as
    HDF5 reports it through h5py (an ``OSError``, or a ``RuntimeError`` of a failed flush),
    or raised while handling one."""
    seen = 0
    while exc is not None and seen < 8:
        if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
            return True
        if isinstance(exc, OSError | RuntimeError) and any(
                text in str(exc) for text in ("No space left on device", "Disk quota exceeded")):
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


def disk_full(path: str, exc: BaseException, kept: str, free: bool = False) -> DiskFull:
    """The one-line error of a write that filled the disk: the file, the errno (``free``:
    and the space left on its disk), what is kept (``kept``)."""
    code = exc.errno if isinstance(exc, OSError) and exc.errno else errno.ENOSPC
    left = ""
    if free:
        directory = os.path.dirname(os.path.abspath(path))
        with contextlib.suppress(OSError):
            left = f"; {size_text(shutil.disk_usage(directory).free)} free in '{directory}'"
    return DiskFull(f"{path}: the disk is full (errno {code}, {errno.errorcode.get(code, '?')}"
                    f": {os.strerror(code)}{left}); {kept}")


# --------------------------------------------------------------------------------------
# a results file that survives a full disk
# --------------------------------------------------------------------------------------


def hdf5_image(fill) -> bytes:
    """The bytes of the HDF5 file ``fill(f)`` writes, built in memory: a full disk then
    fails in one plain ``write`` of them, never inside HDF5 (whose failed flush left file
    objects behind that raised at every garbage collection and crashed the process at
    exit), and the same bytes can be kept elsewhere (:func:`save_image`). For the outputs
    of a few MB (``modes``, ``stability``, ``limit-cycle``, ``settle``, ``study
    --stability-only``) and ``run``'s one case (its histories are in memory already)."""
    import io

    import h5py

    buffer = io.BytesIO()
    with h5py.File(buffer, "w") as f:
        fill(f)
    return buffer.getvalue()


def write_image(path: str, data: bytes) -> None:
    """``data`` into the new file ``path`` (flushed to the disk: a full one fails here)."""
    with open(path, "wb") as fh:
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def save_image(path: str, data: bytes, kept: str) -> DiskFull | None:
    """Write ``data`` (:func:`hdf5_image`) as ``path`` (:func:`replacing`). On a full disk
    the bytes are written to a new file in the temporary directory (``$TMPDIR``) instead,
    and the returned :class:`DiskFull` names ``path``, the free space, where the results
    are kept and ``kept`` (what else is, e.g. the summary printed above); None: written."""
    try:
        with replacing(path) as partial:
            write_image(partial, data)
        return None
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        failure = exc
    stem, ext = os.path.splitext(os.path.basename(path))
    fallback = None
    with contextlib.suppress(OSError):
        fd, fallback = tempfile.mkstemp(prefix=f"wheelrom-{stem}.", suffix=ext)
        os.close(fd)
        try:
            write_image(fallback, data)
        except OSError:
            os.remove(fallback)
            fallback = None
    where = (f"the results are kept in {fallback} (move it there once space is freed)"
             if fallback else "nothing was written (the temporary directory is full too)")
    return disk_full(path, failure, f"{where}; {kept}" if kept else where, free=True)


def save_hdf5(out: str, fill, kept: str) -> BaseException | None:
    """Write the HDF5 file ``out`` (``fill(f)``) from memory (:func:`hdf5_image`,
    :func:`save_image`): a full disk keeps it in the temporary directory. Returns the error,
    if any, for :func:`agree` to tell every rank; a surprise too (one line then, rather
    than the other ranks left waiting)."""
    try:
        return save_image(out, hdf5_image(fill), kept)
    except Exception as exc:
        return InputError(f"{out}: cannot be written ({type(exc).__name__}: {exc})")


def agree(comm, failure: BaseException | None) -> None:
    """Raise rank 0's ``failure`` (None: none) on every rank of the mpi4py ``comm`` (None:
    serial), so that no rank waits in a later collective call for one that stopped."""
    if comm is not None and comm.size > 1:
        failure = comm.bcast(failure, root=0)
    if failure is not None:
        raise failure
