"""Stage 9, benchmarks: speed and accuracy figures of the transient on this machine
(:mod:`.transient`, ``wheelrom bench``).

May import: runtime .. studies; never plots or cli."""
