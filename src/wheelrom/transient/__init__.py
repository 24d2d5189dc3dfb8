"""The transient of the reduced wheel on PETSc TS: the problem and result types
(:mod:`.problem`), the compiled right-hand side (:mod:`.layout`, :mod:`.kernel`,
:mod:`.contact_kernel`, :mod:`.fastmath`) and its PETSc bridge (:mod:`.bridge`), the TS and
its time grid (:mod:`.ts`), the preload (:mod:`.preload`), the window-by-window driver
(:mod:`.run`) and the serial reference (:mod:`.reference`)."""
