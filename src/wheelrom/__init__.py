"""wheelrom: reduced modal model of a bladed turbine wheel with dry-friction couplings.

Importing the package has no side effects. The command line calls
:func:`wheelrom.runtime.environment.bootstrap` first (PETSc/SLEPc location, one BLAS thread per
process, parallel HDF5); a script using the library should do the same before numpy loads.
"""

__version__ = "0.1.0"
__all__ = ["__version__"]
