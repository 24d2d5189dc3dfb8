"""The paper study's verdict in one table (run/paper writes it to out/paper-verdict.txt): per
shroud angle the linear verdict and flutter margin (out/paper-stability.h5), the fastest
wave's exact single-wave orbit with its largest Floquet multiplier (out/paper-limit-cycle.h5)
and where the flutter settles, with all NDs free (out/paper-settle.h5). The amplitude a
designer signs off is the settled one (largest blade), the single-wave orbit beside it.
Given the elastic law's files too, a second table: the stuck wheel's verdict and margin
(out/paper-elastic-stability.h5), the friction-limited exact orbit of its fastest wave
with the contacts' slip shares (out/paper-elastic-limit-cycle.h5) and, when given, the
whole wheel's settled state (out/paper-elastic-settle.h5, from ./run/paper_elastic).

Usage: .venv/bin/python run/verdict.py STABILITY.h5 [LIMIT_CYCLE.h5] [SETTLE.h5]
       [ELASTIC_STABILITY.h5 ELASTIC_LIMIT_CYCLE.h5 [ELASTIC_SETTLE.h5]]
"""

from __future__ import annotations

import sys

import h5py
import numpy as np


def _by_shroud(path: str | None, group: str):
    if not path:
        return {}
    try:
        f = h5py.File(path, "r")
    except OSError:
        return {}
    with f:
        g = f[group]
        return {round(float(a[1]), 6): i for i, a in enumerate(g["angles_deg"][()])}, path


def _cycle(path, i):
    """The exact orbit (else the harmonic balance's cycle) with its multipliers in words."""
    with h5py.File(path, "r") as f:
        case = f[f"limit_cycle/case_{i}"]
        for name in case:
            if not (name.startswith("wave_") and "cycles" in case[name]):
                continue
            c = case[name]["cycles"]
            methods = [m.decode() for m in c["method"][()]] if "method" in c else ["hb"]
            j = methods.index("shooting") if "shooting" in methods else 0
            text = f"{c['tip_amplitude'][j] * 1e6:.2f} um, {c['frequency_hz'][j]:.2f} Hz"
            if methods[j] != "shooting":
                return text + " (harmonic balance; shooting did not converge)"
            if np.isfinite(c["hb_tip_amplitude"][j]):
                text += f" (HB {c['hb_tip_amplitude'][j] * 1e6:.2f} um)"
            if "orbit_sliders" in c:  # the elastic law: who slips on the orbit
                kinds = str(f["limit_cycle"].attrs["kinds"]).split(", ")
                shares = c["fractions"][j]
                text += "; " + ", ".join(f"{kind} slips {100 * shares[k][2]:.0f} %"
                                         for k, kind in enumerate(kinds))
            if "band" in c and np.isfinite(c["band"][j, 0]):  # its family's friction band
                low, high, _ = c["band"][j] * 1e6
                text += (f"; **band {low:.2f}-{high:.2f} um** over the stuck "
                         f"{c['band_kinds'][j].decode()}'s offsets")
            rows = c["refined_multiplier"][j] if "refined_multiplier" in c else []
            rows = [r for r in rows if np.isfinite(r[1])]  # (NaN rows pad shorter cycles)
            if rows:
                step, value, nd = rows[-1]
                text += f"; in symmetry |mu| {value:.5g} (ND {int(nd)}) at {step * 1e6:.2g} us"
            if "multiplier_modulus" in c and np.isfinite(c["multiplier_modulus"][j]).any():
                k = int(np.nanargmax(c["multiplier_modulus"][j]))
                text += (f"; whole wheel {c['multiplier_modulus'][j][k]:.4g} "
                         f"(ND {c['multiplier_nd'][j][k]})")
            if rows:
                # the cycle's verdict; -1: not decided (stable inside the orbit's symmetry
                # with the whole wheel's not computed, or uncertain)
                by = c["floquet_by"][j].decode() if "floquet_by" in c else ""
                undecided = "stable in symmetry, whole wheel not decided" \
                    if by.startswith("stable inside") else "uncertain"
                text += " (" + {1: "stable", 0: "unstable"}.get(int(c["stable"][j]),
                                                                undecided) + ")"
            return text
    return "-"


def _settled(path, i):
    with h5py.File(path, "r") as f:
        g = f[f"settle/case_{i}"]
        a = g["amplitude"][()]
        if not g.attrs["settled"]:
            nd = int(np.argmax(g["nd_energy"][()]))
            if "band" in f["settle"]:  # the range and trend over the last bounded_span
                low, high, span = f["settle/band"][i]
                rate, error = f["settle/trend"][i, :2]
                bounded = bool(f["settle/bounded"][i])
                state = ("bounded" if bounded else "still growing"
                         if f["settle/still_growing"][i] else "not bounded")
                trend = f", trend {rate:+.1%}/s +- {error:.1%}" if np.isfinite(rate) else ""
                when = f"{state} from {g.attrs['time'] - span:.3g} s"
                return (f"{when}: largest blade {low * 1e6:.3g}..{high * 1e6:.3g} um over "
                        f"{g.attrs['time'] - span:.3g}-{g.attrs['time']:.3g} s{trend} (ND {nd} "
                        f"{g['nd_energy'][nd]:.0%})")
            top = g["window_amplitude"][()].max(axis=1)
            half = top[top.size // 2 :] * 1e6
            return (f"not settled in {g.attrs['time']:.3g} s: largest blade "
                    f"{half.min():.3g}..{half.max():.3g} um over the second half (ND "
                    f"{nd} {g['nd_energy'][nd]:.0%})")
        nd = int(np.argmax(g["nd_energy"][()]))
        return (f"{a.max() * 1e6:.2f} um ({g.attrs['kind']}; blades {a.min() * 1e6:.2f}.."
                f"{a.max() * 1e6:.2f}; ND {nd} {g['nd_energy'][nd]:.0%})")


def _linear(stability: str):
    with h5py.File(stability, "r") as f:
        g = f["stability"]
        shroud = g["angles_deg"][:, 1]
        growth = g["max_growth_rate"][()]
        ratio = g["margin_ratio"][()] if "margin_ratio" in g else np.full(shroud.size, np.nan)
        return shroud, growth, ratio, g["nodal_diameter"][:, 0]


def table(stability: str, limit_cycle: str | None, settle: str | None, linear: str,
          orbit: str) -> None:
    """One verdict table: per shroud angle the linear verdict (column ``linear``), growth and
    margin, the settled state and the exact orbit (column ``orbit``) where their files hold
    the angle."""
    cycles = _by_shroud(limit_cycle, "limit_cycle")
    settled = _by_shroud(settle, "settle")
    shroud, growth, ratio, nd = _linear(stability)
    print(f"| shroud [deg] | {linear} | growth [1/s] | margin (x mu) | settled (largest blade) "
          f"| {orbit} |")
    print("|---|---|---|---|---|---|")
    for k, a in enumerate(shroud):
        key = round(float(a), 6)
        verdict = "flutters" if growth[k] > 1e-6 else "stable"
        lc = _cycle(cycles[1], cycles[0][key]) if cycles and key in cycles[0] else "-"
        st = _settled(settled[1], settled[0][key]) if settled and key in settled[0] else "-"
        print(f"| {a:g} | {verdict} (ND {nd[k]}) | {growth[k]:+.3f} | {ratio[k]:.3g} | {st} "
              f"| {lc} |")


def main(argv: list[str]) -> None:
    files = argv + [None] * (6 - len(argv))
    table(files[0], files[1], files[2], "linear", "single-wave exact orbit")
    if files[4]:  # the elastic law's: the stuck wheel and the friction-limited orbit
        print("\nUnder the elastic Coulomb contact (contacts.law = \"elastic\"):\n")
        table(files[3], files[4], files[5], "stuck wheel",
              "friction-limited exact orbit (fastest wave)")


if __name__ == "__main__":
    main(sys.argv[1:])
