"""Stage 4, forces on the reduced wheel: the parameters every implementation consumes
(:mod:`.parameters`), the contact laws as the one record every consumer reads
(:mod:`.contact_law`, compiled with the helpers of :mod:`.fastmath`), the aerodynamic damping
table as a linear operator (:mod:`.aero`) and the reference force model (:mod:`.reference`).
The compiled right-hand side of the transient is a second, independent implementation
(:mod:`wheelrom.transient.kernel`).

May import: runtime, config, segment, rom."""
