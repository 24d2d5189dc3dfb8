"""Every periodic-solution method of the wheel in one room (docs/theory.md, "Limit cycles" and
"Where the flutter settles"):

- in the frequency domain: the harmonic balance of one travelling wave (:mod:`.harmonic_balance`
  on its three-blade :mod:`.window`; under the elastic law its Jacobian through the closed
  hysteresis loop, :mod:`.hysteresis`), its pseudo-arclength continuation
  (:mod:`.continuation`), the Hopf points where a branch is born (:mod:`.hopf`), Hill's
  Floquet exponents (:mod:`.floquet`), the stability of a cycle by a transient started on it
  (:mod:`.cycle_transient`) and the driver over the waves of a case (:mod:`.limit_cycle`);
  the nonlinear forced response to the nozzle (:mod:`.forced_wave`), traced through its
  folds by continuation in the frequency (:mod:`.forced_branch`), its frequency grid dealt to
  the MPI ranks in segments (:mod:`.forced_segments`);
- by time integration: the wheel's flow on its own TS (:mod:`.flow`), the exact periodic orbit
  by shooting (:mod:`.shooting`, a balance's cycle made exact by :mod:`.exact`; under the
  elastic law with the sliders in the state, :mod:`.slider_shooting`, and the family of
  friction-limited orbits its stuck contacts' offsets span, :mod:`.family`), the least-squares
  Newton of the shots whose Jacobian can be singular (:mod:`.newton`), the orbit's Floquet
  multipliers from the monodromy (:mod:`.monodromy`) and the whole wheel's from the wave's
  pattern by Bloch waves (:mod:`.bloch`), both on a step schedule that ends a piece at each of
  the orbit's contact switches (:mod:`.events`), the forced response's exact state at the known
  period (:mod:`.forced_shooting`), that state perturbed on the whole wheel (a seeded wave's
  growth, where an unstable one goes: :mod:`.forced_perturbed`) and where a flutter transient
  settles (:mod:`.settle`);
- what a periodic solution reports, whichever method found it (:mod:`.cycle`; an exact
  orbit's from its samples, :mod:`.report`).
"""
