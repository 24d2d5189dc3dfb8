"""Stage 7, the files: the HDF5 layout of sweep, stability and forced-response files
(:mod:`.layout`), the tip and state histories (:mod:`.histories`), the study file, format 2
(:mod:`.study_layout`), and what reads them back: :mod:`.info`, the CSV export
(:mod:`.export`), the stored model and contact forces rebuilt (:mod:`.reconstruct`) and the
wheel in motion (:mod:`.wheel_motion`).

May import: runtime, config, segment, rom, forces, transient, analysis. The file layout sits
below the studies that write through it (docs/usage.md, "The code")."""
