"""Figures from a results file (matplotlib, headless): the paper's Figs. 5, 8, 10, 11, 12.

``plot_file(path)`` draws whatever the file holds: modal figures from ``/model``, sweep
figures from ``/cases``. A figure whose quantity is missing is not drawn silently wrong: the
call raises :class:`InputError` naming the dataset.
"""

from __future__ import annotations

import os

import numpy as np

from wheelrom.config import CONTACT_KINDS
from wheelrom.errors import InputError
from wheelrom.forces.parameters import stiffness_at
from wheelrom.results import read_config

FONT = {"font.size": 11, "axes.titlesize": 12, "axes.labelsize": 11, "figure.dpi": 110}


def _need(f, name: str, path: str):
    if name not in f:
        raise InputError(f"{path}: dataset '{name}' is missing; cannot draw this figure")
    return f[name][()]


def _save(fig, outdir: str, name: str, pdf: bool, written: list[str]) -> None:
    png = os.path.join(outdir, f"{name}.png")
    fig.savefig(png, bbox_inches="tight")
    written.append(png)
    if pdf:
        fig.savefig(os.path.join(outdir, f"{name}.pdf"), bbox_inches="tight")
        written.append(os.path.join(outdir, f"{name}.pdf"))


def plot_file(path: str, outdir: str | None = None, pdf: bool = False,
              nd_angles: tuple[float, float] | None = None) -> list[str]:  # fmt: skip
    """Write every figure the file supports into ``outdir``; returns the paths written."""
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not os.path.exists(path):
        raise InputError(f"{path}: no such results file")
    outdir = outdir or os.path.splitext(path)[0] + "_figures"
    os.makedirs(outdir, exist_ok=True)
    written: list[str] = []
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise InputError(f"{path}: not a readable HDF5 file ({exc})") from None
    with f, plt.rc_context(FONT):
        cfg = read_config(f, path)
        if "model" in f:
            _modal_figures(f, cfg, path, outdir, pdf, written, plt)
        if "cases" in f:
            _sweep_figures(f, cfg, path, outdir, pdf, written, plt, nd_angles)
    return written


def _modal_figures(f, cfg, path, outdir, pdf, written, plt) -> None:
    table = _need(f, "model/frequencies_by_nd", path)  # (ND, m)
    N = cfg.wheel.blades
    nd = np.arange(table.shape[0])
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    families = min(table.shape[1], 6)
    for j in range(families):
        axes[0].plot(nd, table[:, j], "o-", ms=3, label=f"family {j + 1}")
    reference = f["model/full_wheel_hz"][()] if "model/full_wheel_hz" in f else None
    if reference is not None:  # exact cyclic-symmetry FE of the same wheel
        for j in range(min(families, reference.shape[1])):
            axes[0].plot(nd, reference[:, j], "k--", lw=0.8,
                         label="full-wheel FE" if j == 0 else None)  # fmt: skip
    axes[0].set(
        xlabel="nodal diameter [-]",
        ylabel="frequency [Hz]",
        title="Reduced wheel: frequency vs nodal diameter",
    )
    axes[0].legend(fontsize=8)
    order = np.sort(table[:, :families].ravel())
    axes[1].plot(np.arange(1, order.size + 1), order, ".-", label="reduced model")
    if reference is not None:
        ref_order = np.sort(reference[:, :families].ravel())
        axes[1].plot(np.arange(1, ref_order.size + 1), ref_order, "k--", lw=0.8,
                     label="full-wheel FE")  # fmt: skip
        axes[1].legend(fontsize=8)
    axes[1].set(
        xlabel="mode order [-]",
        ylabel="frequency [Hz]",
        title="Frequency vs mode order (each ND once)",
    )
    for ax in axes:
        ax.grid(alpha=0.3)
    _save(fig, outdir, "fig08_frequencies", pdf, written)
    plt.close(fig)

    # interference view: nozzle engine order n_s aliased onto ND |N - n_s|
    n_s, f_rev = cfg.wheel.stator_vanes, cfg.wheel.speed_hz
    nd_exc = abs(N - n_s) % N
    nd_exc = min(nd_exc, N - nd_exc)
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    for j in range(table.shape[1]):
        ax.plot(nd, table[:, j], "k.-", lw=0.6, ms=2)
    ax.plot(
        [nd_exc],
        [n_s * f_rev],
        "r*",
        ms=14,
        label=f"nozzle: EO {n_s} = {n_s * f_rev:g} Hz on ND {nd_exc}",
    )
    ax.axvline(nd_exc, color="r", lw=0.8, ls=":")
    ax.set(
        xlabel="nodal diameter [-]", ylabel="frequency [Hz]", title="Interference diagram (ZZENF)"
    )
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3)
    _save(fig, outdir, "interference", pdf, written)
    plt.close(fig)

    # contact stiffness vs surface angle (Fig. 5)
    fig, ax = plt.subplots(figsize=(6, 4), layout="constrained")
    angles = np.linspace(0, 90, 91)
    for kind in CONTACT_KINDS:
        stiff = cfg.contact(kind).stiffness
        label = kind
        if isinstance(stiff, str):  # "fe": the table computed with the model
            key = f"model/contacts/{kind}/stiffness"
            if key not in f:
                continue
            stiff = [tuple(row) for row in f[key][()]]
            label = f"{kind} (segment FE)"
        ax.semilogy(angles, [stiffness_at(stiff, a) for a in angles], label=label)
    ax.set(
        xlabel="contact surface angle beta [deg]",
        ylabel="k_c [N/m]",
        title="Normal contact stiffness",
    )
    ax.legend()
    ax.grid(alpha=0.3, which="both")
    _save(fig, outdir, "fig05_contact_stiffness", pdf, written)
    plt.close(fig)


def _sweep_figures(f, cfg, path, outdir, pdf, written, plt, nd_angles=None) -> None:
    from matplotlib import colors

    angles = _need(f, "cases/angles_deg", path)
    t = _need(f, "cases/window_end", path)
    amp = _need(f, "cases/max_tip_amplitude", path)
    status = [s.decode() for s in _need(f, "cases/status", path)]
    shroud = angles[:, 1]
    cmap = plt.get_cmap("viridis")
    norm = colors.Normalize(vmin=0, vmax=90)

    # Fig. 10: amplitude vs time, one line per angle, and an angle x time map
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
    for i in range(len(angles)):
        axes[0].semilogy(t * 1e3, amp[i] * 1e3, color=cmap(norm(shroud[i])), lw=1.2)
    sm = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    fig.colorbar(sm, ax=axes[0], label="shroud angle [deg]")
    axes[0].set(
        xlabel="time [ms]", ylabel="max tip amplitude [mm]", title="Blade-tip amplitude per window"
    )
    order = np.argsort(shroud)
    positive = amp[np.isfinite(amp) & (amp > 0)]
    lo = positive.min() * 1e3 if positive.size else 1e-6
    mesh = axes[1].pcolormesh(
        t * 1e3,
        shroud[order],
        amp[order] * 1e3,
        shading="nearest",
        norm=colors.LogNorm(vmin=lo, vmax=max(lo * 10, np.nanmax(amp) * 1e3)),
        cmap="magma",
    )
    fig.colorbar(mesh, ax=axes[1], label="max tip amplitude [mm]")
    axes[1].set(xlabel="time [ms]", ylabel="shroud angle [deg]", title="Amplitude map")
    for ax in axes:
        ax.grid(alpha=0.3)
    _save(fig, outdir, "fig10_amplitude", pdf, written)
    plt.close(fig)

    # Fig. 11: minimum normal force per kind; open periods show as zero
    kinds = [k for k in CONTACT_KINDS if f"cases/min_normal_force/{k}" in f]
    if not kinds:
        raise InputError(f"{path}: dataset 'cases/min_normal_force' is missing")
    fig, axes = plt.subplots(
        len(kinds), 2, figsize=(12, 3.8 * len(kinds)), squeeze=False, layout="constrained"
    )
    for r, kind in enumerate(kinds):
        fn = f[f"cases/min_normal_force/{kind}"][()]
        opened = f[f"cases/open_fraction/{kind}"][()]
        for i in range(len(angles)):
            axes[r, 0].plot(t * 1e3, fn[i], color=cmap(norm(shroud[i])), lw=1.2)
        axes[r, 0].set(
            xlabel="time [ms]",
            ylabel="min normal force [N]",
            title=f"{kind}: minimum normal force (0 = contact open)",
        )
        m2 = axes[r, 1].pcolormesh(
            t * 1e3, shroud[order], opened[order], shading="nearest", vmin=0, vmax=1, cmap="Reds"
        )
        fig.colorbar(m2, ax=axes[r, 1], label="fraction of contacts open [-]")
        axes[r, 1].set(
            xlabel="time [ms]", ylabel="shroud angle [deg]", title=f"{kind}: open contacts"
        )
        axes[r, 0].grid(alpha=0.3)
    _save(fig, outdir, "fig11_normal_force", pdf, written)
    plt.close(fig)

    # Fig. 12: ND spectrum vs time for the least and most suppressed cases
    spec = _need(f, "cases/nd_spectrum", path)
    final = np.array([a[np.isfinite(a)][-1] if np.isfinite(a).any() else np.inf for a in amp])
    best, worst = int(np.argmin(final)), int(np.argmax(np.where(np.isfinite(final), final, -1)))
    picks = [(best, "most suppressed"), (worst, "least")]
    if nd_angles is not None:  # the user's two shroud angles: nearest cases
        picks = []
        for a in nd_angles:
            i = int(np.argmin(np.abs(shroud - a)))
            if abs(shroud[i] - a) > 1e-6:
                raise InputError(
                    f"ND-spectrum figure: shroud angle {a:g} deg is not in {path} "
                    f"(has {', '.join(f'{x:g}' for x in np.unique(shroud))})"
                )
            picks.append((i, "chosen"))
    fig, axes = plt.subplots(2, 1, figsize=(9, 7), sharex=True, layout="constrained")
    vmax = np.nanmax(spec[[i for i, _ in picks]]) * 1e3
    vmin = max(vmax * 1e-4, 1e-12)
    for ax, (i, label) in zip(axes, picks, strict=True):
        m3 = ax.pcolormesh(
            t * 1e3,
            np.arange(spec.shape[2]),
            spec[i].T * 1e3,
            shading="nearest",
            cmap="inferno",
            norm=colors.LogNorm(vmin=vmin, vmax=vmax),
        )
        fig.colorbar(m3, ax=ax, label="tip y amplitude [mm]")
        ax.set(
            ylabel="nodal diameter [-]", title=f"shroud {shroud[i]:g} deg ({label}): ND spectrum"
        )
    axes[1].set_xlabel("time [ms]")
    _save(fig, outdir, "fig12_nd_spectrum", pdf, written)
    plt.close(fig)

    # summary: final amplitude vs shroud angle, suppression interval marked
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    ok = np.array([s == "done" for s in status])
    ax.semilogy(shroud[ok], final[ok] * 1e3, "o-", label="done")
    if (~ok).any():
        ax.semilogy(
            shroud[~ok],
            np.full((~ok).sum(), np.nanmax(final[ok]) * 1e3 if ok.any() else 1.0),
            "rx",
            ms=10,
            label="failed",
        )
    if ok.any():
        # suppressed = not growing: final amplitude below 3x the first window's
        first = np.array([a[np.isfinite(a)][0] if np.isfinite(a).any() else np.inf for a in amp])
        quiet = ok & (final <= 3 * first)
        angles = np.sort(shroud[quiet])
        runs, label = [], None
        for a in angles:  # contiguous runs of sweep angles
            if runs and a - runs[-1][1] <= np.min(np.diff(np.unique(shroud)), initial=5) + 1e-9:
                runs[-1][1] = a
            else:
                runs.append([a, a])
        text = ", ".join(f"{lo:g}-{hi:g}" if hi > lo else f"{lo:g}" for lo, hi in runs)
        for k, (lo, hi) in enumerate(runs):
            label = f"not growing (final < 3x first window): {text} deg" if k == 0 else None
            ax.axvspan(lo - 2.5, hi + 2.5, color="g", alpha=0.15, label=label)
    ax.set(
        xlabel="shroud contact angle [deg]",
        ylabel="final max tip amplitude [mm]",
        title="Suppression of self-excitation by shroud angle",
    )
    ax.legend(fontsize=9)
    ax.grid(alpha=0.3, which="both")
    _save(fig, outdir, "summary", pdf, written)
    plt.close(fig)


def plot_campbell(data: dict, outdir: str, pdf: bool = False) -> list[str]:
    """Campbell diagram: wheel families (band over nodal diameters), segment modes and
    engine-order lines, the nozzle order ``n_s`` marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(outdir, exist_ok=True)
    written: list[str] = []
    speeds = data["speeds_hz"]
    wheel = data["wheel_hz_by_nd"]  # (S, ND, m)
    top = float(wheel[..., : min(6, wheel.shape[2])].max()) * 1.1
    fig, ax = plt.subplots(figsize=(7.5, 5), layout="constrained")
    rpm = speeds * 60
    for j in range(min(6, wheel.shape[2])):
        low, high = wheel[:, :, j].min(axis=1), wheel[:, :, j].max(axis=1)
        label = f"family {j + 1} (ND 0..{wheel.shape[1] - 1})"
        ax.fill_between(rpm, low, high, alpha=0.25, label=label)
        ax.plot(rpm, data["segment_hz"][:, j], "k:", lw=0.8)
    for eo in range(1, 13):
        ax.plot(rpm, eo * speeds, color="0.6", lw=0.6)
        if eo * speeds[-1] < top:
            ax.annotate(f"EO {eo}", (rpm[-1], eo * speeds[-1]), fontsize=7, color="0.4")
    n_s = data["stator_vanes"]
    ax.plot(
        rpm,
        n_s * speeds,
        "r--",
        lw=1.0,
        label=f"nozzle EO {n_s} (on ND {abs(data['blades'] - n_s)})",
    )
    ax.set(xlabel="rotor speed [rpm]", ylabel="frequency [Hz]", ylim=(0, top),
           title="Campbell diagram (dotted: free-interface segment modes)")  # fmt: skip
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    _save(fig, outdir, "campbell", pdf, written)
    plt.close(fig)
    return written
