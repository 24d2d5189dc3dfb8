"""Stage 10, figures (matplotlib, headless): of a sweep, model, stability or study file
(:mod:`.figures` dispatches), the stability and margin figures (:mod:`.stability`), design maps
(:mod:`.study`), Monte Carlo statistics (:mod:`.montecarlo`), the wheel in motion
(:mod:`.motion`); of a forced-response file (:mod:`.forced`), a design study's forced curves
(:mod:`.design`), a limit-cycle file (:mod:`.limit_cycle`) and a settle file
(:mod:`.settle`); shared helpers (:mod:`.helpers`).

May import: every stage below; never cli."""
