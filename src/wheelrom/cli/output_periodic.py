"""``wheelrom info`` of a limit-cycle or a settle file: its title line and one block per
case (the values come from :mod:`wheelrom.results.info_periodic`)."""

from __future__ import annotations

from wheelrom.analysis.periodic.cycle import cycle_source

PERIODIC_KINDS = ("limit-cycle", "settle")
#: how a settle case's start begins when it is the preloaded equilibrium
PRELOADED = "the preloaded equilibrium"


def _angles(row: dict) -> str:
    """``tieboss 45 deg, shroud 65 deg`` (a study's other values as ``key=value``)."""
    values = row["parameters"] or {"contacts.tieboss.angle_deg": row["tieboss_deg"],
                                   "contacts.shroud.angle_deg": row["shroud_deg"]}
    words = []
    for key, value in values.items():
        kind = key.removeprefix("contacts.").removesuffix(".angle_deg")
        if value is None:
            continue
        words.append(f"{kind} {value:g} deg" if key.endswith(".angle_deg") else f"{key}={value:g}")
    return ", ".join(words)


def periodic_title(info: dict) -> str:
    n, s = info["counts"], info["settings"]
    if info["kind"] == "limit-cycle":
        how = "exact orbit by shooting" if s.get("method") == "shooting" else "harmonic balance"
        cycles = [c for row in info["cases"] for w in row.get("waves", []) for c in w["cycles"]]
        missed = sum(c.get("shot_missed", False) for c in cycles)
        if missed:  # the title claims only what the cycles are
            how = (f"exact orbit by shooting for {len(cycles) - missed} of {len(cycles)} "
                   f"cycle(s), harmonic balance for {missed} whose shot did not converge")
        return (f"{info['file']}: limit cycles, {n['total']} case(s) ({how}; H = "
                f"{s.get('harmonics')}, {s.get('samples')} samples, time step "
                f"{s.get('time_step', 0) * 1e6:g} us)")
    return (f"{info['file']}: where the flutter settles, {n['total']} case(s): {n['settled']} "
            f"settled, {n['not_settled']} not, {n.get('bounded', 0)} of them bounded (start "
            f"{s.get('start')}{_preloaded(info)}, windows of {s.get('window_periods')} periods, "
            f"tolerance {s.get('tolerance')}, bounded within {s.get('bounded_drift', '-')} over "
            f"{s.get('bounded_span', '-')} s, until the window ending nearest "
            f"{s.get('max_time')} s)")


def _preloaded(info: dict) -> str:
    """``", 1 of 3 case(s) from the preloaded equilibrium (no cycle found)"``: the cases of a
    settle asked to start from a cycle that started from the preload."""
    if info["settings"].get("start") != "cycle":
        return ""
    preloaded = sum(row.get("start", "").startswith(PRELOADED) for row in info["cases"])
    return (f", {preloaded} of {len(info['cases'])} case(s) from the preloaded equilibrium (no "
            "cycle found)" if preloaded else "")


def _start_words(row: dict) -> str:
    """How a settle case started, short: on a cycle of its amplitude, or the preload."""
    if row["start_amplitude_m"] is not None:
        return f"started on a cycle of {row['start_amplitude_m'] * 1e6:.4g} um"
    if row.get("start", "").startswith(PRELOADED):
        return "started from the preloaded equilibrium"
    return "start not recorded"


def _cycle_line(c: dict) -> str:
    um = 1e6
    how = cycle_source(c["method"], c.get("shot_missed", False), c["shooting_residual"])
    text = (f"{how}: tip "
            f"{c['tip_amplitude_m'] * um:.4g} um at {c['frequency_hz']:.5g} Hz")
    if c["method"] == "shooting" and c["hb_tip_amplitude_m"] is not None:
        text += f" (harmonic balance {c['hb_tip_amplitude_m'] * um:.4g} um)"
    if c["stable"] is not None:
        text += ", stable" if c["stable"] else ", unstable"
    if c["largest_multiplier"] is not None:
        text += (f", largest multiplier {c['largest_multiplier']:.4g} (ND "
                 f"{c['largest_multiplier_nd']})")
    return text


def print_periodic_cases(info: dict) -> None:
    """Per case its angles, wall time and verdict; a limit-cycle case adds per wave the Hopf
    point and the cycles, a settle case the final state's amplitude and time."""
    print(f"  cases:         total wall time {info['total_wall_s']:.1f} s (sum over cases), "
          f"file {info['file_bytes'] / 1e6:.3g} MB")
    for row in info["cases"]:
        wall = f"{row['wall_s']:.1f} s" if row["wall_s"] is not None else "-"
        print(f"{row['index']:5d}  {_angles(row)} ({wall}): {row['verdict']}")
        for w in row.get("waves", []):
            where = "forward" if w["direction"] > 0 else "backward"
            hopf = (f"Hopf at {w['hopf_factor']:.4g} x mu, {w['hopf_hz']:.5g} Hz"
                    if w["hopf_factor"] is not None else "no Hopf point")
            print(f"         wave {w['wave']} (ND {w['nodal_diameter']} {where}, {hopf})")
            for c in w["cycles"]:
                print(f"           {_cycle_line(c)}")
        if info["kind"] == "settle" and row["max_amplitude_m"] is not None:
            state = row["kind"] or ("settled" if row["settled"] else
                                    "bounded" if row.get("bounded") else "not settled")
            print(f"         {state} at t = {row['time_s']:.3g} s, largest blade tip "
                  f"{row['max_amplitude_m'] * 1e6:.4g} um in the last window "
                  f"({_start_words(row)})")
