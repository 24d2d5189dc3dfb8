"""The blade segment: mesh (built-in or a user's file), finite-element matrices, centrifugal
prestress, contact stiffness and modes (SLEPc). Everything downstream sees the segment only
through the reduced model built from it (:mod:`wheelrom.rom`)."""
