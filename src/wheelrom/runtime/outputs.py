"""Output files that never lose what a user computed.

Every command that writes calls :func:`check_output` (or :func:`check_outdir`) before it
computes anything: a directory given as a file, a missing or read-only directory, or an
existing file without ``--force`` is one line naming the path (exit 2), in under a second.
Files are then written under a temporary name next to their destination and renamed into
place once complete (:func:`replacing`), so an interrupted write never leaves a half file
under the name the user asked for, nor destroys the file that was there before.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil

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
    :class:`OutputExists` unless ``force``; a directory, or a missing or read-only parent
    directory, an :class:`InputError` naming the path and ``flag``."""
    if os.path.isdir(path):
        return InputError(f"{flag} {path}: is a directory, not a file")
    directory = os.path.dirname(os.path.abspath(path))
    why = _directory_problem(directory, flag, path)
    if why:
        return InputError(why)
    if os.path.exists(path):
        if not force:
            return OutputExists(path)
        if not os.access(path, os.W_OK):
            return InputError(f"{flag} {path}: the existing file is not writable")
    return space_problem(path, 0, flag)  # the least any output needs; sizes: check_space


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
    """The temporary name a file is built under: hidden, in the destination's directory (so
    that the final rename is atomic), the same for every MPI rank: ``dir/.seg.partial.vtu``
    for ``dir/seg.vtu``."""
    directory, name = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(name)
    # the extension stays last: writers that choose the format by it (meshio) still work
    return os.path.join(directory, f".{stem}.partial{ext}")


@contextlib.contextmanager
def replacing(path: str):
    """Yield a temporary path to write; on success it atomically replaces ``path``, on any
    error (or Ctrl-C) it is removed and ``path`` is untouched."""
    partial = partial_name(path)
    try:
        yield partial
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.remove(partial)
        raise
    os.replace(partial, path)


def create_collectively(out: str, comm, fill) -> None:
    """Create the parallel HDF5 file ``out`` on the mpi4py ``comm``: ``fill(f)`` writes its
    layout into a file opened collectively under the temporary name, and rank 0 renames it
    into place once every rank is done, so ``out`` is readable from the moment it exists (an
    existing ``out``, ``--force``, is replaced only then); a failure leaves no temporary."""
    import h5py

    partial = partial_name(out)
    try:
        with h5py.File(partial, "w", driver="mpio", comm=comm) as f:
            fill(f)
    except BaseException:
        if comm.rank == 0 and os.path.exists(partial):
            os.remove(partial)
        raise
    comm.Barrier()
    if comm.rank == 0:
        os.replace(partial, out)
    comm.Barrier()


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
