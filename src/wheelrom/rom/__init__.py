"""Stage 3, the reduced wheel: cyclic modal synthesis from a segment basis (:mod:`.model`), the
bases (:mod:`.bases`), full-wheel references (:mod:`.references`), the one build pipeline
(:mod:`.build`), accuracy tables, Campbell data and the whole-wheel mesh.

May import: runtime, config, segment."""
