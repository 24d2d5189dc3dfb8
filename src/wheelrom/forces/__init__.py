"""Stage 4, forces on the reduced wheel: the parameters every implementation consumes
(:mod:`~wheelrom.forces.parameters`) and the reference force model
(:mod:`~wheelrom.forces.reference`). The compiled right-hand side of the transient is a second,
independent implementation (:mod:`wheelrom.transient.kernel`).

May import: runtime, config, segment, rom."""
