"""wheelrom: reduced modal model of a bladed turbine wheel with dry-friction couplings.

The stages, each a package that imports only the earlier ones (docs/usage.md, "The code"):
:mod:`.runtime`, :mod:`.config`, :mod:`.segment`, :mod:`.rom`, :mod:`.forces`,
:mod:`.transient`, :mod:`.analysis`, :mod:`.results`, :mod:`.studies`, :mod:`.bench`,
:mod:`.plots`, :mod:`.cli`; above them ``python -m wheelrom`` (:mod:`.__main__`), and the
shim of the old environment module (:mod:`._environment`).

Importing the package has no side effects. The command line calls
:func:`wheelrom.runtime.environment.bootstrap` first (PETSc/SLEPc location, one BLAS thread per
process, parallel HDF5); a script using the library should do the same before numpy loads.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
