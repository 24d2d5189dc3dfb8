"""wheelrom: reduced modal model of a bladed turbine wheel with dry-friction couplings.

Importing the package locates the Debian PETSc/SLEPc builds (``PETSC_DIR``/``SLEPC_DIR``
are set when unset) and pins BLAS to one thread per process, so that MPI ranks do not
oversubscribe the cores and results do not depend on the rank count.
"""

from wheelrom._environment import bootstrap

bootstrap()

__version__ = "0.1.0"
__all__ = ["__version__"]
