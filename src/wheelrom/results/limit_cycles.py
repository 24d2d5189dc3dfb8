"""``/limit_cycle`` of a limit-cycle file (``wheelrom limit-cycle --out``; docs/output.md):
per case and travelling wave the branch of periodic solutions and the cycles at the
configured intensity, with blade 0's harmonics so that the motion can be rebuilt."""

from __future__ import annotations

import numpy as np

from wheelrom import config as config_mod
from wheelrom.config import Config
from wheelrom.results.file_checksums import write_file_checksums
from wheelrom.results.layout import write_aero_table, write_model
from wheelrom.rom.model import ReducedModel

FORMAT = "wheelrom-limit-cycle-1"
CYCLE_FIELDS = ("lam", "frequency_hz", "tip_amplitude", "tip_harmonics", "normal_force_range",
                "fractions", "energy_in", "energy_friction", "energy_damping",
                "energy_residual", "energy_residual_fine", "damping_ratio", "residual",
                "harmonics", "shooting_residual", "hb_tip_amplitude",
                "hb_frequency_hz")


def write_limit_cycles(f, cfg: Config, model: ReducedModel, cases: list) -> None:
    """The whole file from
    :class:`~wheelrom.analysis.periodic.limit_cycle.CaseLimitCycles` per case of ``cfg``'s
    grid, with the configuration and ``/model``."""
    f.attrs["format"] = FORMAT
    f.attrs["config"] = config_mod.to_toml(cfg)
    f.attrs["config_source"] = cfg.source
    write_model(f.create_group("model"), model)
    write_aero_table(f, cfg, model)
    lc = cfg.limit_cycle
    g = f.create_group("limit_cycle")
    g.attrs["harmonics"] = lc.harmonics
    g.attrs["samples"] = lc.samples or 8 * (lc.harmonics + 1)
    g.attrs["floquet"] = lc.floquet
    g.attrs["method"] = lc.method
    g.attrs["time_step"] = cfg.time.step
    g.attrs["kinds"] = ", ".join(next((c.kinds for c in cases if c.kinds), ()))
    g["angles_deg"] = np.array([[c.angles_deg.get(k, np.nan) for k in ("tieboss", "shroud")]
                                for c in cases])
    g["angles_deg"].attrs["columns"] = "tieboss, shroud"
    names = list(cases[0].parameters) if cases else []
    if names:
        g["parameters"] = np.array([[study_number(c.parameters[n]) for n in names] for c in cases])
        g["parameters"].attrs["names"] = ", ".join(names)
    g["verdict"] = np.array([c.verdict().encode() for c in cases])
    g["wall_s"] = np.array([c.wall_s for c in cases])
    for i, case in enumerate(cases):
        cg = g.create_group(f"case_{i}")
        cg.attrs["verdict"] = case.verdict()
        k, nd, rate = case.fastest or (-1, -1, np.nan)
        cg.attrs["fastest_wave"], cg.attrs["fastest_nodal_diameter"] = k, nd
        cg.attrs["fastest_growth_rate"] = rate
        if case.equilibrium is not None:
            cg["equilibrium"] = case.equilibrium
        for branch in case.branches:
            _write_branch(cg.create_group(f"wave_{branch.wave}"), branch)
    write_file_checksums(f, {"limit_cycle": len(cases)})


def study_number(value) -> float:
    """A study value as a number (``true``/``false`` as 1/0; a named choice as NaN)."""
    if isinstance(value, bool | int | float):
        return float(value)
    return float("nan")


def _write_branch(g, branch) -> None:
    for name in ("wave", "nodal_diameter", "direction", "critical_lam", "hopf_hz", "end",
                 "note", "wall_s"):
        g.attrs[name] = getattr(branch, name)
    g.attrs["verdict"] = branch.verdict()
    g["folds"] = np.array(branch.folds, dtype=np.int64)
    if branch.points:
        b = g.create_group("branch")
        _write_cycles(b, branch.points)
        b["segment"] = np.array(branch.segments, dtype=np.int64)
    if branch.cycles:
        c = g.create_group("cycles")
        _write_cycles(c, branch.cycles)
        if all(x.stability is not None for x in branch.cycles) and \
                len({len(x.stability.families) for x in branch.cycles}) == 1:
            st = [x.stability for x in branch.cycles]
            c["floquet_families"] = st[0].families
            c["floquet_growth"] = np.array([x.growth for x in st])
            c["floquet_multiplier"] = np.array([x.multiplier for x in st])
            c["floquet_trivial"] = np.array([x.trivial for x in st])
        _write_orbits(c, branch.cycles)


def _write_cycles(g, cycles) -> None:
    for name in CYCLE_FIELDS:
        g[name] = np.array([getattr(c, name) for c in cycles])
    # 1 stable, 0 unstable, -1 not computed
    g["stable"] = np.array([-1 if c.stable is None else int(c.stable) for c in cycles],
                           dtype=np.int8)
    # what decided it, in words (under the elastic law also why a -1: stable inside the
    # orbit's symmetry only, or uncertain there)
    g["floquet_by"] = np.array([(c.stability.by if c.stability is not None else "").encode()
                                for c in cycles])


def _write_orbits(g, cycles) -> None:
    """The exact orbits (method 'shooting') and their monodromy multipliers; rows of cycles
    without one are NaN / -1."""
    g["method"] = np.array([c.method.encode() for c in cycles])
    orbits = [c.orbit for c in cycles]
    if any(o is not None for o in orbits):
        shape = next(o.state.shape for o in orbits if o is not None)
        g["orbit_state"] = np.array([o.state if o is not None and o.state.shape == shape
                                     else np.full(shape, np.nan) for o in orbits])
        g["orbit_state"].attrs["layout"] = "(cycle, q | q', pattern blade, mode): blade s of " \
            "the wheel is pattern blade s mod N' at t = 0"
        sliders = [o.sliders if o is not None else None for o in orbits]
        if any(w is not None for w in sliders):  # the elastic law's, at t = 0
            shape = next(w.shape for w in sliders if w is not None)
            g["orbit_sliders"] = np.array([w if w is not None and w.shape == shape
                                           else np.full(shape, np.nan) for w in sliders])
            g["orbit_sliders"].attrs["layout"] = "(cycle, contact kind, pattern blade, " \
                "xi | zeta) [m]: the elastic law's sliders at t = 0"
        g["orbit_period"] = np.array([o.period if o else np.nan for o in orbits])
        g["orbit_shift"] = np.array([o.shift if o else -1 for o in orbits], dtype=np.int64)
        g["orbit_fraction"] = np.array([o.fraction if o else np.nan for o in orbits])
        g["orbit_steps_per_period"] = np.array([o.steps_per_period if o else -1
                                                for o in orbits], dtype=np.int64)
        g["orbit_iterations"] = np.array([o.iterations if o else -1 for o in orbits],
                                         dtype=np.int64)
    _write_bands(g, [c.band for c in cycles])
    mus = [c.multipliers for c in cycles]
    if any(m is not None for m in mus):
        E = max(len(m.values) for m in mus if m is not None)

        def padded(get, fill, dtype=float):
            out = np.full((len(mus), E), fill, dtype=dtype)
            for i, m in enumerate(mus):
                if m is not None:
                    out[i, : len(m.values)] = get(m)
            return out

        g["multiplier_modulus"] = padded(lambda m: np.abs(m.values), np.nan)
        g["multiplier_phase"] = padded(lambda m: np.angle(m.values), np.nan)
        g["multiplier_nd"] = padded(lambda m: m.nd, -1, np.int64)
        g["multiplier_wave"] = padded(lambda m: m.wave, -1, np.int64)
        g["multiplier_trivial_error"] = np.array([m.trivial_error if m else np.nan
                                                  for m in mus])
        g["multiplier_matvecs"] = np.array([m.matvecs if m else -1 for m in mus], np.int64)
        # SLEPc's ("monodromy", at time.step) or every ND's ("Bloch waves", at their step [s])
        g["multiplier_method"] = np.array([(m.by if m else "").encode() for m in mus])
        g["multiplier_step"] = np.array([m.step if m else np.nan for m in mus])
    refined = [c.refined for c in cycles]
    if any(refined):
        R = max(len(r) for r in refined)
        out = np.full((len(refined), R, 3), np.nan)
        for i, r in enumerate(refined):
            if r:
                out[i, : len(r)] = np.array(r, dtype=float)
        g["refined_multiplier"] = out
        g["refined_multiplier"].attrs["columns"] = "step [s], |mu| (dominant inside the " \
            "cycle's symmetry), ND"


def _write_bands(g, bands: list) -> None:
    """The elastic law's family of friction-limited orbits per cycle
    (:class:`~wheelrom.analysis.periodic.family.Band`; rows without one are NaN / empty)."""
    if all(b is None for b in bands):
        return
    g["band"] = np.array([(b.low.tip, b.high.tip, b.start_tip) if b else (np.nan,) * 3
                          for b in bands])
    g["band"].attrs["columns"] = "smallest, largest tip amplitude [m] of the family, " \
        "this orbit's [m]"
    S = max(b.low.offset.size for b in bands if b is not None)

    def offsets(get):
        out = np.full((len(bands), S), np.nan)
        for i, b in enumerate(bands):
            if b is not None:
                out[i, : b.low.offset.size] = get(b)
        return out

    g["band_low_offset"] = offsets(lambda b: b.low.offset)
    g["band_high_offset"] = offsets(lambda b: b.high.offset)
    g["band_low_offset"].attrs["layout"] = "(cycle, (xi, zeta) per stuck contact kind) " \
        "in stick radii mu F_n / k_t from the orbit's sliders"
    g["band_multiplier"] = np.array([(b.multiplier_low, b.multiplier_high) if b
                                     else (np.nan, np.nan) for b in bands])
    g["band_multiplier"].attrs["columns"] = "the smallest, the largest member's largest " \
        "in-symmetry multiplier but the phase shift's"
    g["band_kinds"] = np.array([", ".join(b.kinds).encode() if b else b"" for b in bands])
    g["band_traces"] = np.array([b.reason.encode() if b else b"" for b in bands])
