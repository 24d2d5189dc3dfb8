"""Stage 6, analyses of the wheel around its preloaded equilibrium, beside the transient: the
equilibrium Jacobian and the force derivatives (:mod:`.jacobian`), linear stability per nodal
diameter (:mod:`.stability`), the flutter margin (:mod:`.margin`), the linear forced response
(:mod:`.forced`) and its grid-independent peak (:mod:`.forced_peak`); every periodic-solution
method in one package (:mod:`.periodic`: harmonic balance, continuation, Hopf points, Hill's
Floquet exponents, the limit-cycle driver, the exact orbit by shooting, its monodromy's
Floquet multipliers, where the flutter settles).

May import: runtime, config, segment, rom, forces, transient (the preload and the problem)."""
