"""Accuracy of reduced bases against the exact cyclic-symmetry FE (``wheelrom accuracy``,
docs/accuracy.md): frequency error per basis, family and nodal diameter."""

from __future__ import annotations

import time

import numpy as np

from wheelrom.rom.bases import (
    ENRICH_FAMILIES,
    attachment_vectors,
    enriched_basis,
    enrichment_phases,
    ritz_basis,
)
from wheelrom.rom.build import build_segment, quiet
from wheelrom.rom.model import reduce
from wheelrom.rom.references import cyclic_table, phase_weight, time_left
from wheelrom.segment.modes import segment_modes


def accuracy_table(cfg, comm, modes=(10, 20, 40), enriched_modes=10, families=4, log=quiet):
    """Reduced-model error against the exact cyclic FE, per basis, family and nodal diameter.

    Returns ``{"reference_hz": (ND, families), "bases": {label: {"vectors": r,
    "relative_error": (ND, families)}}}`` for the free-interface basis at each ``m`` in
    ``modes`` and the enriched basis built on ``enriched_modes``. ``log``: progress lines
    (every ND of the cyclic FE with the time left, then the bases).
    """
    segment = build_segment(cfg, comm, log=log)
    seg, mats = segment.mesh, segment.matrices
    c1 = cfg.wheel.coupling_stiffness
    eig = segment_modes(mats, max(max(modes), enriched_modes), comm)
    log(f"segment: {seg.n_dofs} DOFs, {eig.eigenvalues.size} modes in {eig.solve_s:.1f} s")
    phases = enrichment_phases(seg.sectors)
    log(f"exact cyclic FE: {seg.sectors // 2 + 1} nodal diameters x {families} families, then "
        f"{len(modes)} free bases and the enriched one ({len(phases)} sector phases)")
    t0 = time.perf_counter()
    reference = cyclic_table(seg, mats, c1, families, comm, log=log)
    per_phase_s = (time.perf_counter() - t0) / sum(phase_weight(k, seg.sectors)
                                                   for k in range(reference.shape[0]))
    bases = {}
    for m in modes:
        model = reduce(seg, eig.vectors[:, :m], np.diag(eig.eigenvalues[:m]), cfg)
        rom = _families(model, families)
        bases[f"free m={m}"] = {"vectors": m, "relative_error": rom / reference - 1}
        log(f"free basis m={m} done")
    log(f"enriched basis: {len(phases)} sector phase solves, "
        f"{time_left(per_phase_s * sum(phase_weight(k, seg.sectors) for k in phases))} "
        "(at the cyclic FE's rate per phase)")
    t0 = time.perf_counter()
    X, lam = enriched_basis(seg, mats, c1, eig.vectors[mats.free, :enriched_modes],
                            ENRICH_FAMILIES, comm, phases)
    log(f"enriched basis: {X.shape[1]} vectors ({time.perf_counter() - t0:.1f} s)")
    model = reduce(seg, mats.expand(X), np.diag(lam), cfg)
    rom = _families(model, families)
    bases[f"enriched m={enriched_modes}"] = {
        "vectors": int(X.shape[1]),
        "relative_error": rom / reference - 1,
    }
    kinds = [k for k in cfg.contacts.enabled_kinds() if f"{k}_A" in seg.node_sets]
    if kinds:
        attach = attachment_vectors(seg, mats, kinds, comm)
        for m in modes:
            X, lam = ritz_basis(mats, [eig.vectors[mats.free, :m], attach])
            model = reduce(seg, mats.expand(X), np.diag(lam), cfg)
            rom = _families(model, families)
            bases[f"attachment m={m}"] = {"vectors": int(X.shape[1]),
                                          "relative_error": rom / reference - 1}
            log(f"attachment basis m={m} done")
    return {"reference_hz": reference, "bases": bases}


def _families(model, families: int) -> np.ndarray:
    """``(ND, families)`` reduced frequencies [Hz]; NaN where the basis has fewer families
    (a basis of r vectors has r per nodal diameter)."""
    table = model.frequencies_by_nodal_diameter()[:, :families]
    out = np.full((table.shape[0], families), np.nan)
    out[:, : table.shape[1]] = table
    return out
