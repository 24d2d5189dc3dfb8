"""Periodic solutions by time integration: the wheel's flow on its own TS (:mod:`.flow`), the
exact periodic orbit by shooting (:mod:`.shooting`), its Floquet multipliers from the
monodromy (:mod:`.monodromy`) and where a flutter transient settles (:mod:`.settle`);
docs/theory.md, "Limit cycles" and "Where the flutter settles".
"""
