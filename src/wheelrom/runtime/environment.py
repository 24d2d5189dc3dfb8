"""Process environment: PETSc/SLEPc location, BLAS threads, parallel HDF5.

:func:`bootstrap` is called by the command line before numpy, petsc4py or h5py are imported;
it only fills in variables the user did not set. :func:`petsc` locates PETSc by itself, so
library code works without it (but then BLAS may start one thread per core).
"""

from __future__ import annotations

import glob
import importlib.util
import os
import sys

_INSTALL_HINT = (
    "wheelrom needs PETSc/SLEPc for Python: run ./run/setup (Debian 12: apt-get install "
    "python3-petsc4py-real python3-slepc4py-real python3-mpi4py python3-h5py-mpi openmpi-bin)"
)


class MissingPETSc(ImportError):
    """PETSc or SLEPc for Python could not be found."""


def _newest(pattern: str) -> str | None:
    found = sorted(glob.glob(pattern))
    return found[-1] if found else None


def _add_site(prefix: str) -> None:
    site = os.path.join(prefix, "lib", "python3", "dist-packages")
    if os.path.isdir(site) and site not in sys.path:
        sys.path.append(site)


def bootstrap() -> None:
    """Fill in PETSC_DIR, SLEPC_DIR, BLAS thread counts and the h5py MPI switch."""
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(var, "1")
    # Debian's h5py picks its MPI build only under mpirun unless told otherwise; we always
    # want the mpio driver available (also for single-process sweeps).
    os.environ.setdefault("H5PY_ALWAYS_USE_MPI", "1")
    locate_petsc()


def locate_petsc() -> None:
    """Set ``PETSC_DIR``/``SLEPC_DIR`` to Debian's real-valued builds when unset and put their
    Python packages on ``sys.path``."""
    if "PETSC_DIR" not in os.environ:
        petsc_dir = _newest("/usr/lib/petscdir/petsc*/*-real")
        if petsc_dir:
            os.environ["PETSC_DIR"] = petsc_dir
    if "SLEPC_DIR" not in os.environ:
        slepc_dir = _newest("/usr/lib/slepcdir/slepc*/*-real")
        if slepc_dir:
            os.environ["SLEPC_DIR"] = slepc_dir
    for var in ("PETSC_DIR", "SLEPC_DIR"):
        if var in os.environ:
            _add_site(os.environ[var])


_INIT_ARGS: list[str] = []


def set_init_args(args: list[str]) -> None:
    """PETSc command-line options to hand to ``PetscInitialize`` (the CLI's args after
    ``--``), so that initialisation-time options such as ``-log_view`` work."""
    _INIT_ARGS[:] = list(args)


def petsc():
    """Return the initialised ``petsc4py.PETSc`` module (one clear error when missing)."""
    if "petsc4py.PETSc" not in sys.modules:
        locate_petsc()
    if importlib.util.find_spec("petsc4py") is None:
        raise MissingPETSc(_INSTALL_HINT)
    if "petsc4py.PETSc" not in sys.modules:
        import petsc4py

        petsc4py.init([sys.argv[0] if sys.argv else "wheelrom", *_INIT_ARGS])
    from petsc4py import PETSc

    return PETSc


def slepc():
    """Return the initialised ``slepc4py.SLEPc`` module."""
    petsc()
    if importlib.util.find_spec("slepc4py") is None:
        raise MissingPETSc(_INSTALL_HINT)
    if "slepc4py.SLEPc" not in sys.modules:
        import slepc4py

        slepc4py.init()
    from slepc4py import SLEPc

    return SLEPc


def available_memory() -> int | None:
    """The bytes this process can still allocate without swapping: the kernel's
    ``MemAvailable``, or less when a cgroup (a container, a batch job) limits the memory;
    None when neither can be read (not Linux)."""
    found = []
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    found.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        with open("/sys/fs/cgroup/memory.max") as fh:
            limit = fh.read().strip()
        with open("/sys/fs/cgroup/memory.current") as fh:
            used = int(fh.read().strip())
        if limit != "max":
            found.append(max(int(limit) - used, 0))
    except (OSError, ValueError):
        pass
    return min(found) if found else None
