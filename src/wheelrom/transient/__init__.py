"""Stage 5, the transient of the reduced wheel on PETSc TS: the problem and result types
(:mod:`.problem`), the compiled right-hand side (:mod:`.layout`, :mod:`.kernel`,
:mod:`.contact_kernel`, :mod:`.fastmath`) and its PETSc bridge (:mod:`.bridge`), the TS and
its time grid (:mod:`.ts`), the exponential integrator (:mod:`.exponential`, its compiled step
:mod:`.exponential_kernel`; the elastic law's stuck springs in its exact propagator:
:mod:`.stuck_shift`), the ``--`` PETSc options checked up front (:mod:`.options`), the
preload (:mod:`.preload`), the window-by-window driver (:mod:`.run`), the serial reference
(:mod:`.reference`) and a fresh process to its first step (:mod:`.startup`).

May import: runtime, config, segment, rom, forces. The linear analyses around the same
equilibrium are the next stage (:mod:`wheelrom.analysis`)."""
