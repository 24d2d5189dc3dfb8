"""Stage 9, benchmarks (``wheelrom bench``): speed and accuracy figures on this machine of the
transient (:mod:`.transient`), of the elastic contact law against the paper law
(:mod:`.laws`), of a limit cycle with its branch and Floquet analysis (:mod:`.limit_cycle`)
and of the nonlinear forced response (:mod:`.forced`).

May import: runtime .. studies; never plots or cli."""
