"""Stage 3, the reduced wheel: cyclic modal synthesis from a segment basis (:mod:`.model`), the
bases (:mod:`.bases`), full-wheel references (:mod:`.references`), the one build pipeline
(:mod:`.build`) and the models it keeps on disk between commands (:mod:`.cache`), the bases'
accuracy tables (:mod:`.accuracy`), Campbell data (:mod:`.campbell`) and the whole-wheel mesh
and mode shapes (:mod:`.wheelmesh`).

May import: runtime, config, segment."""
