"""Stage 8, many cases at once over MPI ranks: the angle sweep (:mod:`.sweep`), design studies
(:mod:`.study`), their planning (model groups, screening, load balance: :mod:`.plan`), the
stability part of a sweep or study (:mod:`.stability`) and per-case mistuning with its forced
peak (:mod:`.mistuning`).

May import: every stage below (runtime .. results)."""
