"""Stage 0, the runtime every stage may use and that imports no other stage: the error types
users see (:mod:`.errors`), Ctrl-C/SIGTERM handling of long runs (:mod:`.interrupts`), where
PETSc/SLEPc live and one BLAS thread per process (:mod:`.environment`), the numba kernels' disk
cache (:mod:`.kernel_cache`), output-path checks and atomic writes (:mod:`.outputs`) and the
one-job-per-output lock (:mod:`.locks`).

May import: no other wheelrom stage (numpy, h5py, PETSc only)."""
