"""Stage 8, many cases at once over MPI ranks: the angle sweep (:mod:`.sweep`) and its rounds of
batches (:mod:`.rounds`), design studies (:mod:`.study`), their planning (model groups,
screening, load balance: :mod:`.plan`), the stability part of a sweep or study
(:mod:`.stability`), per-case mistuning with its forced peak (:mod:`.mistuning`), the nonlinear
forced response of a case and the design curve (:mod:`.forced_nonlinear`), limit cycles over
the cases (:mod:`.limit_cycles`) and where the flutter settles (:mod:`.settle`, its kept cases
written and read back by :mod:`.settle_cases`); cases handed to
the ranks as they become free (:mod:`.queue`) and finished cases kept on disk while a long
command runs (:mod:`.kept_cases`; the design study's curves: :mod:`.design_cases`).

May import: every stage below (runtime .. results)."""
