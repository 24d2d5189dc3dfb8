"""Stage 7, the files: the HDF5 layout of sweep, stability and forced-response files
(:mod:`.layout`), the tip and state histories (:mod:`.histories`), the study file, format 2
(:mod:`.study_layout`), the periodic solutions of a limit-cycle file (:mod:`.limit_cycles`) and
the settled states of a settle file (:mod:`.settle`), the checksums ``info --verify`` checks
(per case of a sweep, run or study file: :mod:`.checksums`; per dataset of a file written in
one piece: :mod:`.file_checksums`); and what reads them back: :mod:`.info` (the limit-cycle and
settle files: :mod:`.info_periodic`), the CSV export (:mod:`.export`), the stored model and
contact forces rebuilt (:mod:`.reconstruct`) and the wheel in motion (:mod:`.wheel_motion`).

May import: runtime, config, segment, rom, forces, transient, analysis. The file layout sits
below the studies that write through it (docs/usage.md, "The code")."""
