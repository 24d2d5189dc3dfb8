"""Every periodic-solution method of the wheel in one room (docs/theory.md, "Limit cycles" and
"Where the flutter settles"):

- in the frequency domain: the harmonic balance of one travelling wave (:mod:`.harmonic_balance`
  on its three-blade :mod:`.window`; under the elastic law its Jacobian through the closed
  hysteresis loop, :mod:`.hysteresis`), its pseudo-arclength continuation
  (:mod:`.continuation`), the Hopf points where a branch is born (:mod:`.hopf`), Hill's
  Floquet exponents (:mod:`.floquet`), the stability of a cycle by a transient started on it
  (:mod:`.cycle_transient`) and the driver over the waves of a case (:mod:`.limit_cycle`);
  the nonlinear forced response to the nozzle (:mod:`.forced_wave`);
- by time integration: the wheel's flow on its own TS (:mod:`.flow`), the exact periodic orbit
  by shooting (:mod:`.shooting`, :mod:`.exact`), its Floquet multipliers from the monodromy
  (:mod:`.monodromy`) and where a flutter transient settles (:mod:`.settle`).
"""
