"""Pictures of one case in motion: the tip ring seen along the axis as a GIF (blades
coloured by tip displacement, open contacts marked), a 3D rendering of the wheel surface,
the contact normal forces over time and the friction hysteresis loop of one contact."""

from __future__ import annotations

import math

import numpy as np

from wheelrom.segment.mesh import rotation_z


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def auto_scale(amplitude: float, radius: float) -> float:
    """The displacement scale that draws ``amplitude`` [m] as 4 % of ``radius`` [m]."""
    return 0.04 * radius / amplitude if amplitude > 0 else 1.0


def tip_ring_gif(path: str, times: np.ndarray, tips: np.ndarray, tip_point: np.ndarray,
                 scale: float, contacts: dict | None = None, fps: int = 10) -> None:
    """A GIF of the tip ring seen along the machine axis: blade ``s``'s tip at
    ``R_z(2 pi s / N) (tip_point + scale u_s)`` (``tips`` ``(S, N, 3)`` [m] in the sector
    frames), coloured by ``|u_s|`` [mm]; ``contacts``: kind -> ``(radius [m], open (S, N)
    bool)``, drawn between blades ``s`` and ``s+1`` (open: red cross)."""
    plt = _pyplot()
    from matplotlib.animation import FuncAnimation, PillowWriter

    S, N, _ = tips.shape
    R = np.array([rotation_z(2 * math.pi * s / N) for s in range(N)])
    rest = np.einsum("sab,b->sa", R, tip_point)
    radius = float(np.hypot(*tip_point[:2]))
    moved = rest[None] + scale * np.einsum("sab,ksb->ksa", R, tips)
    size_mm = 1e3 * np.linalg.norm(tips, axis=2)
    fig, (ax, unrolled) = plt.subplots(1, 2, figsize=(12, 5.6),
                                       gridspec_kw={"width_ratios": (1, 1.1)})
    ax.set_aspect("equal")
    update_unrolled = _unrolled(unrolled, tips, contacts or {})
    lim = 1.12 * radius
    ax.set(xlim=(-lim, lim), ylim=(-lim, lim), xlabel="x [m]", ylabel="y [m]")
    ax.plot(rest[:, 0], rest[:, 1], color="0.8", lw=0.8, zorder=1)
    norm = plt.Normalize(0.0, max(float(size_mm.max()), 1e-12))
    dots = ax.scatter(moved[0, :, 0], moved[0, :, 1], c=size_mm[0], cmap="viridis", s=28,
                      norm=norm, zorder=3)
    # the colour bar of a fixed mappable: the animated one would redraw it every frame
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap="viridis"), ax=ax, shrink=0.7,
                 label="tip displacement |u| [mm]")
    fig.subplots_adjust(left=0.06, right=0.9, wspace=0.35)
    marks = {}
    for i, (kind, (r, _)) in enumerate((contacts or {}).items()):
        angle = 2 * math.pi * (np.arange(N) + 0.5) / N
        xy = np.column_stack([r * np.cos(angle), r * np.sin(angle)])
        closed = ax.scatter(*xy.T, s=8, color=f"C{i}", label=f"{kind} closed", zorder=2)
        opened = ax.scatter(*xy.T, s=40, marker="x", color="red", zorder=4,
                            label="open" if i == 0 else None)
        marks[kind] = (xy, closed, opened)
    if marks:
        ax.legend(loc="lower right", fontsize=8)
    title = fig.suptitle("")

    def frame(k):
        dots.set_offsets(moved[k, :, :2])
        dots.set_array(size_mm[k])
        for kind, (xy, closed, opened) in marks.items():
            is_open = contacts[kind][1][k]
            closed.set_offsets(xy[~is_open] if (~is_open).any() else np.zeros((0, 2)))
            opened.set_offsets(xy[is_open] if is_open.any() else np.zeros((0, 2)))
        title.set_text(f"t = {1e3 * times[k]:.2f} ms, displacements x {scale:.3g}")
        update_unrolled(k)
        return [dots, title]

    anim = FuncAnimation(fig, frame, frames=S, blit=False)
    anim.save(path, writer=PillowWriter(fps=fps))
    plt.close(fig)


def _unrolled(ax, tips: np.ndarray, contacts: dict):
    """The right panel of :func:`tip_ring_gif`: tangential and axial tip displacement [mm]
    against the blade, open contacts marked below; returns the frame update."""
    S, N, _ = tips.shape
    blades = np.arange(N)
    top = 1e3 * max(float(np.abs(tips[..., 1:]).max()), 1e-15)
    ax.set(xlim=(-0.5, N - 0.5), ylim=(-1.35 * top, 1.1 * top), xlabel="blade",
           ylabel="tip displacement [mm]")
    tangential, = ax.plot(blades, 1e3 * tips[0, :, 1], "-o", ms=2.5, lw=1, label="y tangential")
    axial, = ax.plot(blades, 1e3 * tips[0, :, 2], "-o", ms=2.5, lw=1, label="z axial")
    rows = {kind: (-1.15 - 0.12 * i) * top for i, kind in enumerate(contacts)}
    opened = {kind: ax.plot([], [], "x", color="red", ms=5)[0] for kind in contacts}
    for kind, y in rows.items():
        ax.text(N - 0.5, y, f" {kind} open", va="center", fontsize=7)
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.legend(loc="upper right", fontsize=8)

    def update(k):
        tangential.set_ydata(1e3 * tips[k, :, 1])
        axial.set_ydata(1e3 * tips[k, :, 2])
        for kind, line in opened.items():
            where = blades[contacts[kind][1][k]] + 0.5
            line.set_data(where, np.full(where.size, rows[kind]))

    return update


def surface_png(path: str, points: np.ndarray, quads: np.ndarray, u: np.ndarray,
                scale: float, time: float) -> None:
    """A 3D rendering of the wheel surface deformed by ``scale u`` (``u`` ``(P, 3)`` [m]),
    faces coloured by their mean displacement magnitude [mm]."""
    plt = _pyplot()
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    xyz = points + scale * u
    faces = xyz[quads]
    size = 1e3 * np.linalg.norm(u, axis=1)[quads].mean(axis=1)
    fig = plt.figure(figsize=(7, 6.4))
    ax = fig.add_subplot(projection="3d")
    cmap = plt.get_cmap("viridis")
    top = max(float(size.max()), 1e-12)
    polys = Poly3DCollection(faces, facecolors=cmap(size / top), edgecolors="none")
    ax.add_collection3d(polys)
    lim = float(np.abs(xyz[:, :2]).max())
    ax.set(xlim=(-lim, lim), ylim=(-lim, lim), zlim=(-0.4 * lim, 0.4 * lim), xlabel="x [m]",
           ylabel="y [m]", zlabel="z [m]")
    ax.set_box_aspect((1, 1, 0.4))
    ax.view_init(elev=32, azim=-60)
    mappable = plt.cm.ScalarMappable(cmap=cmap, norm=plt.Normalize(0.0, top))
    fig.colorbar(mappable, ax=ax, shrink=0.6, pad=0.12, label="displacement [mm]")
    ax.set_title(f"wheel surface at t = {1e3 * time:.2f} ms, displacements x {scale:.3g}")
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def normal_force_png(path: str, histories: dict, blades: list[int]) -> None:
    """Normal force [N] over time of the contacts ``(s, s+1)`` for ``s`` in ``blades``, one
    panel per contact kind (``histories``: kind -> ContactHistory)."""
    plt = _pyplot()
    fig, axes = plt.subplots(len(histories), 1, figsize=(7, 2.6 * len(histories)),
                             sharex=True, squeeze=False)
    for ax, (kind, h) in zip(axes[:, 0], histories.items(), strict=True):
        for s in blades:
            ax.plot(1e3 * h.time, h.normal_force[:, s], lw=1, label=f"blades {s}-{s + 1}")
        ax.set(ylabel=f"{kind} F_N [N]")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.legend(fontsize=8, loc="upper right")
    axes[-1, 0].set_xlabel("t [ms]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def hysteresis_png(path: str, h, blade: int) -> None:
    """The friction hysteresis of contact ``(blade, blade+1)`` of one kind: friction force
    [N] against the relative tangential displacement [um], for both tangential directions
    (xi radial, zeta along the contact surface), plus the normal force over time."""
    plt = _pyplot()
    fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
    closed = h.state[:, blade] != 0
    for ax, (c, name) in zip(axes[:2], ((0, "xi"), (1, "zeta")), strict=True):
        rel = 1e6 * h.relative_displacement[:, blade, 2 * c]
        ax.plot(rel, np.where(closed, h.friction_force[:, blade, c], np.nan), lw=1,
                label="closed")
        ax.plot(rel, np.where(closed, np.nan, 0.0), color="0.7", lw=0.8, label="open")
        ax.set(xlabel=f"relative displacement {name} [um]", ylabel=f"friction force {name} [N]")
        ax.legend(fontsize=8)
    axes[2].plot(1e3 * h.time, h.normal_force[:, blade], lw=1)
    axes[2].set(xlabel="t [ms]", ylabel="normal force [N]")
    fig.suptitle(f"{h.kind} contact between blades {blade} and {blade + 1} "
                 f"(open {100 * (1 - closed.mean()):.0f} % of the samples)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
