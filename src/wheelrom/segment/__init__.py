"""Stage 2, the blade segment: mesh (built-in or a user's file), finite-element matrices,
centrifugal prestress, contact stiffness and modes (SLEPc). Everything downstream sees the
segment only through the reduced model built from it (:mod:`wheelrom.rom`).

May import: runtime, config."""
