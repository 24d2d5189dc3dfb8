"""Figures from a results file (matplotlib, headless): the paper's Figs. 5, 8, 10, 11, 12.

``plot_file(path)`` draws whatever the file holds: modal figures from ``/model``, sweep
figures from ``/cases``. A figure whose quantity is missing is not drawn silently wrong: the
call raises :class:`InputError` naming the dataset.
"""

from __future__ import annotations

import os

import numpy as np

from wheelrom.config import CONTACT_KINDS
from wheelrom.forces.parameters import stiffness_at
from wheelrom.plots.helpers import cell_edges as _cell_edges
from wheelrom.plots.helpers import need as _need
from wheelrom.plots.helpers import save as _save
from wheelrom.plots.helpers import staged
from wheelrom.results.layout import (
    FORCED_FORMAT,
    check_readable,
    read_config,
    read_error,
    statuses,
)
from wheelrom.results.study_layout import FORMAT as STUDY_FORMAT
from wheelrom.results.study_layout import read_parameters
from wheelrom.runtime.errors import InputError

FONT = {"font.size": 11, "axes.titlesize": 12, "axes.labelsize": 11, "figure.dpi": 110}


def figures_dir(path: str) -> str:
    """The default folder of a results file's figures: ``<results>_figures`` beside it."""
    return os.path.splitext(path)[0] + "_figures"


def plot_file(path: str, outdir: str | None = None, pdf: bool = False,
              nd_angles: tuple[float, float] | None = None, force: bool = False) -> list[str]:
    """Write every figure the file supports into ``outdir``; returns the paths written. An
    existing figure is replaced only with ``force`` (:func:`~wheelrom.plots.helpers.staged`);
    a file with nothing to draw is an :class:`InputError` (and leaves no empty folder)."""
    import h5py
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    check_readable(path)
    outdir = outdir or figures_dir(path)
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise read_error(path, exc, "not a readable HDF5 file") from None
    with f, plt.rc_context(FONT), staged(outdir, force) as (stage, written):
        cfg = read_config(f, path)
        _draw(f, cfg, path, stage, pdf, written, plt, nd_angles)
        if not written:
            raise InputError(f"{path}: nothing to draw (format {f.attrs.get('format')!r}); "
                             "plot draws the files of sweep, run, study, stability, "
                             "limit-cycle, settle, forced-response and modes")
    return written


def _draw(f, cfg, path, outdir, pdf, written, plt, nd_angles) -> None:
    """Every figure the file holds the data of, into ``outdir``."""
    if "model" in f:
        _modal_figures(f, cfg, path, outdir, pdf, written, plt)
    study = f.attrs.get("format") == STUDY_FORMAT
    if "cases" in f and (not study or _angle_sweep(f, everything_run=True)):
        _sweep_figures(f, cfg, path, outdir, pdf, written, plt, nd_angles)
    if "stability" in f and (not study or _angle_sweep(f)):
        from wheelrom.plots.stability import stability_figures

        stability_figures(f, path, outdir, pdf, written, plt)
    if "limit_cycle" in f:
        from wheelrom.plots.limit_cycle import limit_cycle_figures

        limit_cycle_figures(f, path, outdir, pdf, written, plt)
    if "settle" in f:
        from wheelrom.plots.settle import settle_figures

        settle_figures(f, path, outdir, pdf, written, plt)
    if f.attrs.get("format") == FORCED_FORMAT:
        from wheelrom.plots.forced import forced_figures

        forced_figures(f, path, outdir, pdf, written, plt)
    if study:
        from wheelrom.plots.study import study_figures

        study_figures(f, path, outdir, pdf, written, plt)
        from wheelrom.plots.montecarlo import montecarlo_figures

        montecarlo_figures(f, path, outdir, pdf, written, plt)


def _angle_sweep(f, everything_run: bool = False) -> bool:
    """Whether a study file is a contact-angle sweep the format-1 figures draw: it varies only
    the contact angles (and, ``everything_run``, every case has its transient)."""
    params = read_parameters(f)
    if not set(params["names"]) <= {"contacts.tieboss.angle_deg", "contacts.shroud.angle_deg"}:
        return False
    return not everything_run or all(s == "done" for s in statuses(f))


def _modal_figures(f, cfg, path, outdir, pdf, written, plt) -> None:
    """Figs. 8 and 5 and the interference diagram, from ``/model``."""
    table = _need(f, "model/frequencies_by_nd", path)  # (ND, m) [Hz]
    reference = f["model/full_wheel_hz"][()] if "model/full_wheel_hz" in f else None
    for name, fig in (
        ("fig08_frequencies", _fig08_frequencies(table, reference, plt)),
        ("interference", _interference_figure(table, cfg, plt)),
        ("fig05_contact_stiffness", _fig05_contact_stiffness(f, cfg, plt)),
    ):
        _save(fig, outdir, name, pdf, written)
        plt.close(fig)


def _fig08_frequencies(table: np.ndarray, reference: np.ndarray | None, plt):
    """Fig. 8: frequency [Hz] vs nodal diameter and vs mode order; ``table`` is ``(ND, m)``,
    ``reference`` the full-wheel FE frequencies of the same shape (or None)."""
    nd = np.arange(table.shape[0])
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    families = min(table.shape[1], 6)
    for j in range(families):
        axes[0].plot(nd, table[:, j], "o-", ms=3, label=f"family {j + 1}")
    if reference is not None:  # exact cyclic-symmetry FE of the same wheel
        for j in range(min(families, reference.shape[1])):
            axes[0].plot(nd, reference[:, j], "k--", lw=0.8,
                         label="full-wheel FE" if j == 0 else None)
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
                     label="full-wheel FE")
        axes[1].legend(fontsize=8)
    axes[1].set(
        xlabel="mode order [-]",
        ylabel="frequency [Hz]",
        title="Frequency vs mode order (each ND once)",
    )
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


def _interference_figure(table: np.ndarray, cfg, plt):
    """Interference diagram: frequencies ``(ND, m)`` [Hz] and the nozzle engine order ``n_s``
    aliased onto ND ``|N - n_s|``."""
    N = cfg.wheel.blades
    nd = np.arange(table.shape[0])
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
    return fig


def _fig05_contact_stiffness(f, cfg, plt):
    """Fig. 5: normal contact stiffness k_c [N/m] vs contact surface angle [deg] per kind."""
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
    return fig


class _Sweep:
    """The ``/cases`` data the sweep figures share: ``angles`` ``(C, 2)`` [deg] (shroud in
    column 1), ``t`` window ends ``(W,)`` [s], ``amp`` max tip amplitude ``(C, W)`` [m],
    ``final`` the last finite window amplitude ``(C,)`` [m], ``status`` ``C`` strings."""

    def __init__(self, f, path: str):
        from matplotlib import colors

        self.f, self.path = f, path
        self.angles = _need(f, "cases/angles_deg", path)
        self.t = _need(f, "cases/window_end", path)
        self.amp = _need(f, "cases/max_tip_amplitude", path)
        self.status = [s.decode() for s in _need(f, "cases/status", path)]
        self.shroud = self.angles[:, 1]
        self.order = np.argsort(self.shroud)
        self.norm = colors.Normalize(vmin=0, vmax=90)
        self.final = np.array(
            [a[np.isfinite(a)][-1] if np.isfinite(a).any() else np.inf for a in self.amp]
        )

    def t_edges_ms(self) -> np.ndarray:
        """Map cell edges in time [ms] (one window: a cell of its end time's width)."""
        t_ms = self.t * 1e3
        return _cell_edges(t_ms, 0.5 * t_ms[0] if t_ms[0] > 0 else 0.5)

    def shroud_edges(self) -> np.ndarray:
        """Map cell edges in shroud angle [deg] (one case: +-2.5 deg)."""
        return _cell_edges(self.shroud[self.order], 2.5)


def _sweep_figures(f, cfg, path, outdir, pdf, written, plt, nd_angles=None) -> None:
    """Figs. 10, 11, 12 and the summary, from ``/cases``."""
    d = _Sweep(f, path)
    drawers = (
        ("fig10_amplitude", lambda: _fig10_amplitude(d, plt)),
        ("fig11_normal_force", lambda: _fig11_normal_force(d, plt)),
        ("fig12_nd_spectrum", lambda: _fig12_nd_spectrum(d, plt, nd_angles)),
        ("summary", lambda: _summary_figure(d, plt)),
    )
    for name, draw in drawers:  # one at a time: a missing dataset stops at its figure
        fig = draw()
        _save(fig, outdir, name, pdf, written)
        plt.close(fig)


def _fig10_amplitude(d: _Sweep, plt):
    """Fig. 10: max tip amplitude [mm] vs time [ms], one line per angle (markers: one window
    shows as a point), and a shroud angle x time map."""
    from matplotlib import colors

    cmap = plt.get_cmap("viridis")
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
    for i in range(len(d.angles)):
        axes[0].semilogy(d.t * 1e3, d.amp[i] * 1e3, "o-", ms=3,
                         color=cmap(d.norm(d.shroud[i])), lw=1.2)
    sm = plt.cm.ScalarMappable(norm=d.norm, cmap=cmap)
    fig.colorbar(sm, ax=axes[0], label="shroud angle [deg]")
    axes[0].set(
        xlabel="time [ms]", ylabel="max tip amplitude [mm]", title="Blade-tip amplitude per window"
    )
    positive = d.amp[np.isfinite(d.amp) & (d.amp > 0)]
    lo = positive.min() * 1e3 if positive.size else 1e-6
    mesh = axes[1].pcolormesh(
        d.t_edges_ms(),
        d.shroud_edges(),
        d.amp[d.order] * 1e3,
        shading="flat",
        norm=colors.LogNorm(vmin=lo, vmax=max(lo * 10, np.nanmax(d.amp) * 1e3)),
        cmap="magma",
    )
    fig.colorbar(mesh, ax=axes[1], label="max tip amplitude [mm]")
    axes[1].set(xlabel="time [ms]", ylabel="shroud angle [deg]", title="Amplitude map")
    for ax in axes:
        ax.grid(alpha=0.3)
    return fig


def _fig11_normal_force(d: _Sweep, plt):
    """Fig. 11: minimum normal force [N] per contact kind vs time [ms] (open periods show as
    zero) and the fraction of open contacts [-] as a shroud angle x time map."""
    f, path = d.f, d.path
    kinds = [k for k in CONTACT_KINDS if f"cases/min_normal_force/{k}" in f]
    if not kinds:
        raise InputError(f"{path}: dataset 'cases/min_normal_force' is missing")
    cmap = plt.get_cmap("viridis")
    fig, axes = plt.subplots(
        len(kinds), 2, figsize=(12, 3.8 * len(kinds)), squeeze=False, layout="constrained"
    )
    for r, kind in enumerate(kinds):
        fn = f[f"cases/min_normal_force/{kind}"][()]
        opened = f[f"cases/open_fraction/{kind}"][()]
        for i in range(len(d.angles)):
            axes[r, 0].plot(d.t * 1e3, fn[i], "o-", ms=3,
                            color=cmap(d.norm(d.shroud[i])), lw=1.2)
        axes[r, 0].set(
            xlabel="time [ms]",
            ylabel="min normal force [N]",
            title=f"{kind}: minimum normal force (0 = contact open)",
        )
        m2 = axes[r, 1].pcolormesh(d.t_edges_ms(), d.shroud_edges(), opened[d.order],
                                   shading="flat", vmin=0, vmax=1, cmap="Reds")
        fig.colorbar(m2, ax=axes[r, 1], label="fraction of contacts open [-]")
        axes[r, 1].set(
            xlabel="time [ms]", ylabel="shroud angle [deg]", title=f"{kind}: open contacts"
        )
        axes[r, 0].grid(alpha=0.3)
    return fig


def _fig12_nd_spectrum(d: _Sweep, plt, nd_angles=None):
    """Fig. 12: tip y amplitude [mm] per nodal diameter vs time [ms] (``cases/nd_spectrum``,
    ``(C, W, ND)``) for the least and most suppressed cases, or the two chosen shroud angles;
    a single case gets one panel."""
    from matplotlib import colors

    spec = _need(d.f, "cases/nd_spectrum", d.path)
    best = int(np.argmin(d.final))
    worst = int(np.argmax(np.where(np.isfinite(d.final), d.final, -1)))
    picks = [(best, "most suppressed"), (worst, "least")]
    if len(d.angles) == 1:
        picks = [(0, "only case")]
    if nd_angles is not None:  # the user's two shroud angles: nearest cases
        picks = []
        for a in nd_angles:
            i = int(np.argmin(np.abs(d.shroud - a)))
            if abs(d.shroud[i] - a) > 1e-6:
                raise InputError(
                    f"ND-spectrum figure: shroud angle {a:g} deg is not in {d.path} "
                    f"(has {', '.join(f'{x:g}' for x in np.unique(d.shroud))})"
                )
            picks.append((i, "chosen"))
    fig, axes = plt.subplots(len(picks), 1, figsize=(9, 0.5 + 3.25 * len(picks)), sharex=True,
                             squeeze=False, layout="constrained")
    axes = axes[:, 0]
    vmax = np.nanmax(spec[[i for i, _ in picks]]) * 1e3
    vmin = max(vmax * 1e-4, 1e-12)
    for ax, (i, label) in zip(axes, picks, strict=True):
        m3 = ax.pcolormesh(
            d.t_edges_ms(),
            _cell_edges(np.arange(spec.shape[2]), 0.5),
            spec[i].T * 1e3,
            shading="flat",
            cmap="inferno",
            norm=colors.LogNorm(vmin=vmin, vmax=vmax),
        )
        fig.colorbar(m3, ax=ax, label="tip y amplitude [mm]")
        ax.set(
            ylabel="nodal diameter [-]", title=f"shroud {d.shroud[i]:g} deg ({label}): ND spectrum"
        )
    axes[-1].set_xlabel("time [ms]")
    return fig


def _summary_figure(d: _Sweep, plt):
    """Summary: final max tip amplitude [mm] vs shroud angle [deg], the not-growing interval
    (final < 3x first window) shaded."""
    shroud, final, amp = d.shroud, d.final, d.amp
    fig, ax = plt.subplots(figsize=(7, 4.2), layout="constrained")
    ok = np.array([s == "done" for s in d.status])
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
    return fig


def plot_campbell(data: dict, outdir: str, pdf: bool = False, force: bool = False) -> list[str]:
    """Campbell diagram: wheel families (band over nodal diameters), segment modes and
    engine-order lines, the nozzle order ``n_s`` marked. An existing ``campbell.png`` is
    replaced only with ``force``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with staged(outdir, force) as (stage, written):
        _campbell(data, stage, pdf, written, plt)
    return written


def _campbell(data: dict, outdir: str, pdf: bool, written: list[str], plt) -> None:
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
           title="Campbell diagram (dotted: free-interface segment modes)")
    ax.legend(fontsize=8, loc="upper left")
    ax.grid(alpha=0.3)
    _save(fig, outdir, "campbell", pdf, written)
    plt.close(fig)
