"""Mistuning in a design study (issue #22): Monte Carlo realisations are cases.

The cases of a model group differ at most in forces, time and ``[mistuning]``
(:func:`wheelrom.config.study.model_key` leaves ``[mistuning]`` out): the group's reduced
model is built once, tuned, and each case's pattern ``delta_s`` (:func:`blade_mistuning` of
the case's own configuration: a seeded draw, the same on any rank) is put on it where the case
is computed (:func:`case_model`).

``wheelrom study --forced`` adds per case the grid-independent peak of the linear forced
response (:mod:`wheelrom.analysis.forced_peak`) and its amplification factor over the tuned
reference. Cases whose configurations differ only in ``[mistuning]`` share that reference
(the *tuned group*, :func:`wheelrom.config.study.tuned_key`) and its band (automatic: about
the tuned resonance, wide enough for every realisation of the group). Each rank computes the
reference of a tuned group it has cases of itself (on ``COMM_SELF``, so every rank finds the
same numbers), and with contacts the case's equilibrium and Jacobian are shared with its
stability analysis (SNES prefix ``stability_preload_``).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from wheelrom.analysis.forced import operators, tuned_copy
from wheelrom.analysis.forced_peak import PeakResponse, peak_response, tuned_reference
from wheelrom.analysis.stability import analyse, linearise
from wheelrom.config.study import Study, tuned_key
from wheelrom.results import layout as results
from wheelrom.rom.model import ReducedModel, blade_mistuning
from wheelrom.studies.plan import group_by


def case_model(models: list, model_of: list[int], study: Study, i: int) -> ReducedModel:
    """Case ``i``'s reduced model: its group's (tuned) model with the case's mistuning."""
    return dataclasses.replace(models[model_of[i]], mistuning=blade_mistuning(study.configs[i]))


def case_mistuning(study: Study, blades: int) -> np.ndarray:
    """``(C, N)`` every case's ``delta_s`` (zeros: tuned)."""
    out = np.zeros((study.size, blades))
    for i, cfg in enumerate(study.configs):
        delta = blade_mistuning(cfg)
        if delta is not None:
            out[i] = delta
    return out


class ForcedCases:
    """The peak forced response of a rank's cases; the tuned references are computed once
    per tuned group on the rank (module docstring)."""

    def __init__(self, study: Study, models: list, model_of: list[int]):
        self.study, self.models, self.model_of = study, models, model_of
        self.group_of, self.members = group_by([tuned_key(c) for c in study.configs])
        self.references: dict[int, PeakResponse] = {}

    def reference(self, i: int) -> PeakResponse:
        """The tuned reference of case ``i``'s tuned group."""
        g = self.group_of[i]
        if g not in self.references:
            cfg = self.study.configs[i]
            deltas = [blade_mistuning(self.study.configs[j]) for j in self.members[g]]
            tuned = tuned_copy(self.models[self.model_of[i]])
            # the equilibrium as the cases' (SNES prefix stability_preload_): options given
            # for it act on both sides of the factor
            jacobian = linearise(tuned, cfg)[3] if cfg.forced.contacts else None
            self.references[g] = tuned_reference(
                tuned, cfg, deltas, contacts=cfg.forced.contacts,
                operators_kc=operators(tuned, cfg, cfg.forced.contacts, jacobian=jacobian))
        return self.references[g]

    def peak(self, i: int, model: ReducedModel, jacobian=None) -> tuple:
        """``(peak, reference)`` of case ``i`` (``model``: its mistuned model; ``jacobian``:
        its linearisation with contacts, when already computed)."""
        cfg = self.study.configs[i]
        reference = self.reference(i)
        kc = operators(model, cfg, cfg.forced.contacts, jacobian=jacobian)
        return peak_response(model, cfg, reference.band_hz, operators_kc=kc), reference


def analyse_case(study: Study, models: list, model_of: list[int], i: int,
                 forced: ForcedCases | None) -> tuple:
    """``(stability, forced)`` of case ``i``: a StabilityResult or the text of its failure,
    and (``forced`` given) ``(peak, reference, wall_s)`` or the text of its failure (else
    None). With contacts both share one equilibrium and Jacobian."""
    cfg = study.configs[i]
    model = case_model(models, model_of, study, i)
    lin, stability, peak = None, None, None
    try:
        if forced is not None and cfg.forced.contacts:
            lin = linearise(model, cfg)
        stability = analyse(model, cfg, linearised=lin)
    except Exception as exc:  # a failed case is recorded, never a hang of the others
        stability = f"{type(exc).__name__}: {exc}"
    if forced is not None:
        t0 = time.perf_counter()
        try:
            found, reference = forced.peak(i, model, None if lin is None else lin[3])
            peak = (found, reference, time.perf_counter() - t0)
        except Exception as exc:
            peak = f"{type(exc).__name__}: {exc}"
    return stability, peak


def forced_arrays(found: list, study: Study, blades: int) -> dict[str, np.ndarray]:
    """``/forced`` datasets (docs/output.md) from one :func:`analyse_case` forced entry per
    case (case order)."""
    C, N = len(found), blades
    out = {name: np.full(shape, np.nan) for name, shape in (
        ("amplification", (C,)), ("peak_amplitude", (C,)), ("peak_frequency_hz", (C,)),
        ("blade_amplitude", (C, N)), ("tuned_peak_amplitude", (C,)),
        ("tuned_peak_frequency_hz", (C,)), ("tuned_blade_amplitude", (C, N)),
        ("band_hz", (C, 2)), ("wall_s", (C,)))}
    out["solves"] = np.zeros(C, dtype="i8")
    out["reference"] = np.array(group_by([tuned_key(c) for c in study.configs])[0], dtype="i8")
    status = []
    for c, entry in enumerate(found):
        if isinstance(entry, str):
            status.append(f"failed: {entry}"[: results.STATUS_LEN])
            continue
        peak, ref, wall = entry
        status.append("done")
        out["amplification"][c] = peak.amplitude / ref.amplitude
        out["peak_amplitude"][c], out["peak_frequency_hz"][c] = peak.amplitude, peak.frequency_hz
        out["blade_amplitude"][c] = peak.blade_amplitude
        out["tuned_peak_amplitude"][c] = ref.amplitude
        out["tuned_peak_frequency_hz"][c] = ref.frequency_hz
        out["tuned_blade_amplitude"][c] = ref.blade_amplitude
        out["band_hz"][c] = np.asarray(peak.band) / (2 * np.pi)
        out["solves"][c], out["wall_s"][c] = peak.solves, wall
    out["status"] = np.array([s.encode() for s in status], dtype=f"S{results.STATUS_LEN}")
    return out
