"""What the command line prints about forced responses and mistuning: ``wheelrom info`` of a
forced-response file, and the amplification / growth-rate statistics of a Monte Carlo study
(``info`` and ``study``)."""

from __future__ import annotations


def print_forced(info: dict) -> None:
    """``wheelrom info`` of a forced-response file (:func:`wheelrom.results.info._forced_info`)."""
    band, delta = info["frequency_hz"], info["mistuning"]
    print(f"{info['file']}: {info['format']} forced response, engine order "
          f"{info['stator_vanes']} (ND {info['nodal_diameter']}), "
          f"{'mistuned' if info['mistuned'] else 'tuned'} wheel")
    print(f"  config source: {info.get('config_source') or 'not recorded'}"
          f" (wheelrom {info.get('wheelrom_version') or '?'})")
    print(f"  size:          {info['blades']} blades x {info['modes']} modes, "
          f"{info['frequencies']} frequencies; file {info['file_bytes'] / 1e6:.3g} MB")
    print(f"  frequencies:   {band['from']:g} .. {band['to']:g} Hz ({band['count']})")
    angles = ", ".join(f"{k} {v:g} deg" for k, v in (info["contact_angles_deg"] or {}).items())
    print(f"  contacts:      {'linearised' if info['contacts'] else 'off'}"
          + (f" ({angles})" if angles else ""))
    print(f"  mistuning:     delta {delta['min']:+.4g} .. {delta['max']:+.4g} "
          f"(std {delta['std']:.4g})")
    for label, peak in (("peak", info["peak"]), ("tuned peak", info["tuned_peak"])):
        print(f"  {label + ':':14s} {peak['amplitude_m']:.4e} m at {peak['frequency_hz']:g} Hz, "
              f"blade {peak['blade']}")
    factor = info["amplification_factor"]
    print(f"  amplification: {'-' if factor is None else f'{factor:.4f}'} (peak over tuned peak)")
    nl = info.get("nonlinear")
    if nl:
        peak = (f"; peak {nl['peak_amplitude_m']:.4e} m at {nl['peak_frequency_hz']:g} Hz"
                if nl["peak_amplitude_m"] is not None else "")
        print(f"  nonlinear:     harmonic balance, H = {nl['harmonics']}, contacts.law = "
              f"'{nl['law']}', {nl['converged']} of {nl['count']} frequencies solved{peak}")
        ex = nl.get("exact")
        if ex and ex["converged"]:
            print(f"  exact state:   {ex['tip_amplitude_m']:.4e} m at {ex['frequency_hz']:g} Hz "
                  f"(the balance {100 * ex['hb_relative_difference']:+.3f} %), largest "
                  f"multiplier {ex['largest_multiplier']:.6f}: "
                  f"{'stable' if ex['stable'] else 'unstable'}")
        elif ex:
            print(f"  exact state:   shooting did not converge at {ex['frequency_hz']:g} Hz")
    solver = info.get("solver")
    if solver:
        shown = [solver.get(k) for k in ("ksp_type", "pc_type", "pc_factor_mat_solver_type")]
        given = " ".join(f"-{k} {v}" if v is not None else f"-{k}"
                         for k, v in solver.get("options", {}).items())
        print(f"  KSP {solver.get('prefix', '')}: {'/'.join(x for x in shown if x)}"
              + (f"; options {given}" if given else ""))


def print_statistics(stats: dict, indent: str) -> None:
    """The distributions of the amplification factor and the largest growth rate over the
    cases (Monte Carlo mistuning), when the file has the forced response."""
    if "amplification" not in stats:
        return
    for name, label, unit in (("amplification", "amplification:   ", ""),
                              ("max_growth_rate", "max growth rate: ", " /s")):
        d = stats[name]
        print(f"{indent}{label}" + (f"mean {d['mean']:.4g}{unit}, std {d['std']:.3g}, 95 % "
              f"{d['p95']:.4g}, max {d['max']:.4g} (case {d['argmax']}) over {d['count']} "
              "case(s)" if d["count"] else "no case"))
    left = stats.get("amplification_unstable_cases") or 0
    print(f"{indent}Whitehead's bound (1 + sqrt(N)) / 2 = {stats['whitehead_bound']:.4g}" + (
        f"; {left} linearly unstable case(s) left out of the amplification" if left else ""))
