"""Stage 6, analyses of the wheel around its preloaded equilibrium, beside the transient: the
equilibrium Jacobian and the force derivatives (:mod:`.jacobian`), linear stability per nodal
diameter (:mod:`.stability`), the flutter margin (:mod:`.margin`), the linear forced response
(:mod:`.forced`) and its grid-independent peak (:mod:`.forced_peak`), and the limit cycles of
the travelling waves by harmonic balance (:mod:`.harmonic_balance`, :mod:`.continuation`,
:mod:`.hopf`, :mod:`.floquet`, :mod:`.cycle_transient`, :mod:`.limit_cycle`); periodic
solutions by time integration in their own package (:mod:`.periodic`: the exact orbit by
shooting, its monodromy's Floquet multipliers, where the flutter settles).

May import: runtime, config, segment, rom, forces, transient (the preload and the problem)."""
