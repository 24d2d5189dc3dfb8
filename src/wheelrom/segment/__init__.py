"""Stage 2, the blade segment: its mesh type (:mod:`.mesh`), built in (:mod:`.builtin`) or a
user's file (:mod:`.reader`), the one a configuration names (:mod:`.load`) and its export for
ParaView and CalculiX (:mod:`.export`); the finite-element matrices (:mod:`.assembly`), the
cut-face coupling springs (:mod:`.springs`), centrifugal prestress (:mod:`.prestress`), contact
stiffness (:mod:`.contact_stiffness`) and modes with SLEPc (:mod:`.modes`; PETSc matrices and
direct solves: :mod:`.petsc`). Everything downstream sees the segment only through the
reduced model built from it (:mod:`wheelrom.rom`).

May import: runtime, config."""
