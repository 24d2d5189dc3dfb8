#!/usr/bin/env python
"""Validation (not a test): CalculiX against wheelrom's exact cyclic FE on the whole coarse
wheel, every nodal diameter 0..33, 10 families (about 8 minutes: three ccx runs).

    .venv/bin/python run/validate_calculix.py [--workdir DIR]

1. standstill; 2. prestressed, CalculiX's own static + perturbation step (the deck of
``wheelrom mesh --out seg.inp``); 3. prestressed with our static stress given to CalculiX as
``*INITIAL CONDITIONS, TYPE=STRESS`` (no previous static step, so CalculiX has no initial
displacement: only stress stiffening and spin softening remain). ccx runs are cached in the
work directory (rerun only when the deck changes). Writes results.json there and
docs/figures/calculix_prestress_difference.png. The stresses at CalculiX's integration points
come from a second, hand-written 20-node shape-function routine below: an independent check of
the displacement field, not a part of wheelrom.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys

from wheelrom.runtime.environment import bootstrap

bootstrap()

import numpy as np  # noqa: E402

from wheelrom import config  # noqa: E402
from wheelrom.rom.build import build_segment  # noqa: E402
from wheelrom.rom.references import cyclic_table  # noqa: E402
from wheelrom.runtime.environment import petsc  # noqa: E402
from wheelrom.segment.assembly import assemble  # noqa: E402
from wheelrom.segment.export import _real, calculix_deck, mesh_text  # noqa: E402
from wheelrom.segment.prestress import prestress  # noqa: E402
from wheelrom.segment.springs import phase_stiffness, spring_parts  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FIGURE = os.path.join(ROOT, "docs", "figures", "calculix_prestress_difference.png")
COARSE = 'segment.preset="coarse"'


def run_ccx(workdir: str, name: str, text: str) -> str:
    """Run ``ccx`` on ``text`` in ``workdir`` (cached); returns the .dat text."""
    RUN = workdir
    inp, dat = os.path.join(RUN, name + ".inp"), os.path.join(RUN, name + ".dat")
    if not (os.path.exists(dat) and os.path.exists(inp) and open(inp).read() == text):
        with open(inp, "w") as f:
            f.write(text)
        env = dict(os.environ, OMP_NUM_THREADS="1")
        with open(os.path.join(RUN, name + ".log"), "w") as log:
            subprocess.run(["ccx", "-i", name], cwd=RUN, env=env, stdout=log, check=True)
    return open(dat).read()


def parse_dat(text: str, families: int):
    """``(ND, families)`` frequencies [Hz] from the eigenvalue tables of a .dat file.

    CalculiX solves the real 2n form of each nodal diameter's complex problem: every
    eigenvalue comes twice (also at ND 0 and N/2). Rows of one ND are taken in mode order,
    in pairs; returns the pair means and the largest relative spread within a pair."""
    rows: dict[int, list[tuple[int, float]]] = {}
    for block in text.split("E I G E N V A L U E   O U T P U T")[1:]:
        body = block.split("P A R T I C I P A T I O N")[0]
        for m in re.finditer(r"^\s+(\d+)\s+(\d+)\s+(\S+)\s+\S+\s+\S+\s+\S+\s*$", body, re.M):
            rows.setdefault(int(m[1]), []).append((int(m[2]), float(m[3])))
    nds = sorted(rows)
    assert nds == list(range(len(nds))), f"nodal diameters in .dat: {nds}"
    lam = np.array([[v for _, v in sorted(rows[k])][: 2 * families] for k in nds])
    a, b = lam[:, 0::2], lam[:, 1::2]
    spread = float(np.max(np.abs(a - b) / np.abs(a)))
    return np.sqrt(np.maximum(0.5 * (a + b), 0)) / (2 * np.pi), spread


# --- initial-stress variant (3) -------------------------------------------------------

# C3D20 reference nodes (Abaqus/CalculiX order) and CalculiX's 27 Gauss points (gauss3d3:
# xi fastest, then eta, then zeta)
_XI = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1], [-1, -1, 1], [1, -1, 1],
                [1, 1, 1], [-1, 1, 1], [0, -1, -1], [1, 0, -1], [0, 1, -1], [-1, 0, -1],
                [0, -1, 1], [1, 0, 1], [0, 1, 1], [-1, 0, 1], [-1, -1, 0], [1, -1, 0],
                [1, 1, 0], [-1, 1, 0]], float)
_G = np.sqrt(0.6) * np.array([-1.0, 0.0, 1.0])
GAUSS27 = np.array([(a, b, c) for c in _G for b in _G for a in _G])


def hex20_gradients(p):
    """``(20, 3)`` derivatives of the 20-node serendipity shape functions at ``p`` (3,)."""
    dN = np.zeros((20, 3))
    for a, (xa, ya, za) in enumerate(_XI):
        t = 1 + np.array([xa, ya, za]) * p  # (1 + xi_a xi) etc.
        if a < 8:  # corners: 1/8 t0 t1 t2 (xa x + ya y + za z - 2)
            s = xa * p[0] + ya * p[1] + za * p[2] - 2
            for d, c in enumerate((xa, ya, za)):
                o = [i for i in range(3) if i != d]
                dN[a, d] = c * t[o[0]] * t[o[1]] * (s + t[d]) / 8
        else:  # mid-sides: 1/4 (1 - xi_k^2) t_i t_j, k the zero coordinate
            k = int(np.flatnonzero(np.array([xa, ya, za]) == 0)[0])
            i, j = [d for d in range(3) if d != k]
            dN[a, k] = -2 * p[k] * t[i] * t[j] / 4
            dN[a, i] = (1 - p[k] ** 2) * _XI[a, i] * t[j] / 4
            dN[a, j] = (1 - p[k] ** 2) * _XI[a, j] * t[i] / 4
    return dN


def ip_stress(seg, u, young, poisson):
    """``(nel, 27, 6)`` linear stress (xx, yy, zz, xy, xz, yz) of displacement ``u``
    ``(n_dofs,)`` at CalculiX's integration points."""
    lam = young * poisson / ((1 + poisson) * (1 - 2 * poisson))
    mu = young / (2 * (1 + poisson))
    cells = seg.quadratic_cells()
    X, U = seg.nodes[cells], u.reshape(-1, 3)[cells]  # (nel, 20, 3)
    out = np.empty((len(cells), 27, 6))
    for q, p in enumerate(GAUSS27):
        dN = hex20_gradients(p)
        J = np.einsum("eai,ak->eik", X, dN)  # dx_i/dxi_k
        dNdx = np.einsum("ak,eki->eai", dN, np.linalg.inv(J))
        G = np.einsum("eai,eak->eik", U, dNdx)  # du_i/dx_k
        eps = 0.5 * (G + G.transpose(0, 2, 1))
        S = 2 * mu * eps + lam * np.trace(eps, axis1=1, axis2=2)[:, None, None] * np.eye(3)
        out[:, q] = S[:, [0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]
    return out


def initial_stress_deck(seg, cfg, stress, cload) -> str:
    """The standstill deck with ``stress`` as initial stress, then (1) a linear static step
    with the centrifugal load plus ``cload`` ``(n_dofs,)``, the cut-face spring forces of our
    static state (CalculiX's springs start unloaded), so that this step finds equilibrium at
    zero displacement and keeps ``stress``; (2) the perturbation frequency step. (A first
    ``*STEP, PERTURBATION`` would drop the initial stress: ccx 2.20 zeroes it on that card.)"""
    from dataclasses import replace

    still = replace(cfg, segment=replace(cfg.segment, prestress=False))
    head, step = calculix_deck(seg, still, "seg.inp").split("*STEP\n")
    lines = ["*INITIAL CONDITIONS, TYPE=STRESS"]
    for e, ips in enumerate(stress):
        lines += [f"{e + 1}, {q + 1}, " + ", ".join(map(_real, s)) for q, s in enumerate(ips)]
    omega2 = _real((2 * np.pi * cfg.wheel.speed_hz) ** 2)
    centrif = f"*DLOAD\nSEGMENT, CENTRIF, {omega2}, 0., 0., 0., 0., 0., 1."
    lines += ["*STEP", "*STATIC", centrif, "*CLOAD"]
    lines += [f"{d // 3 + 1}, {d % 3 + 1}, {_real(cload[d])}" for d in np.flatnonzero(cload)]
    lines += ["*END STEP", "*STEP, PERTURBATION"]
    return head + "\n".join(lines) + "\n" + step.replace("*END STEP", centrif + "\n*END STEP")


def static_state(seg, cfg, comm=None):
    """Our static displacement ``u`` and the cut-face spring forces on the segment ``S u``
    (full DOFs) at ``wheel.speed_hz``."""
    s, c1 = cfg.segment, cfg.wheel.coupling_stiffness
    mats0 = assemble(seg, s.young, s.poisson, s.density)
    ps = prestress(seg, mats0, s.young, s.poisson, s.density, 2 * np.pi * cfg.wheel.speed_hz,
                   c1, comm)
    A, _ = phase_stiffness(mats0, spring_parts(seg, mats0, c1), 0.0)
    u = ps.displacement[mats0.free]
    return ps.displacement, mats0.expand(A @ u - mats0.K @ u)


def write_deck(workdir: str, name: str, seg, text: str) -> str:
    """The mesh as ``seg.inp`` next to the deck ``name``.inp (which includes it)."""
    with open(os.path.join(workdir, "seg.inp"), "w") as f:
        f.write(mesh_text(seg))
    return text


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--workdir", default=os.path.join(ROOT, "run", "calculix"))
    args = parser.parse_args()
    if shutil.which("ccx") is None:
        sys.exit("ccx not found: apt-get install calculix-ccx (./run/setup does)")
    os.makedirs(args.workdir, exist_ok=True)
    comm = petsc().COMM_SELF
    res, tables = {}, {}
    cases = {"standstill": [COARSE, "segment.prestress=false"], "prestressed": [COARSE]}
    for name, overrides in cases.items():
        cfg = config.load(overrides=overrides)
        segment = build_segment(cfg, comm)
        seg = segment.mesh
        m, c1 = cfg.wheel.modes_per_segment, cfg.wheel.coupling_stiffness
        ours = cyclic_table(seg, segment.matrices, c1, m, comm)
        deck = write_deck(args.workdir, name, seg, calculix_deck(seg, cfg, "seg.inp"))
        ccx, spread = parse_dat(run_ccx(args.workdir, name, deck), m)
        rel = ccx / ours - 1
        tables[name] = rel
        res[name] = {
            "max_abs_rel_ccx_vs_ours": float(np.abs(rel).max()),
            "pair_spread_ccx": spread,
            "ours_hz": ours.tolist(),
            "ccx_hz": ccx.tolist(),
        }
        print(f"{name}: max |ccx/ours - 1| = {np.abs(rel).max():.2e}, "
              f"pair spread {spread:.1e}", flush=True)
        if name == "prestressed":
            per_nd = np.abs(rel).max(axis=1)
            k, j = np.unravel_index(np.abs(rel).argmax(), rel.shape)
            res[name]["max_abs_rel_per_nd"] = per_nd.tolist()
            res[name]["peak"] = {"nd": int(k), "family": int(j) + 1, "rel": float(rel[k, j])}
            print("  per ND max |rel| [%]: " + " ".join(f"{x * 100:.3f}" for x in per_nd))
            print(f"  peak {rel[k, j] * 100:+.3f} % at ND {k}, family {j + 1}")
            # 3. our static stress as initial stress
            u, spring_force = static_state(seg, cfg, comm)
            stress = ip_stress(seg, u, cfg.segment.young, cfg.segment.poisson)
            text = initial_stress_deck(seg, cfg, stress, -spring_force)
            ccx3, spread3 = parse_dat(run_ccx(args.workdir, "initial_stress", text), m)
            rel3 = ccx3 / ours - 1
            res["initial_stress"] = {
                "max_abs_rel_ccx_vs_ours": float(np.abs(rel3).max()),
                "pair_spread_ccx": spread3,
                "ccx_hz": ccx3.tolist(),
            }
            print(f"initial stress: max |ccx/ours - 1| = {np.abs(rel3).max():.2e}, "
                  f"pair spread {spread3:.1e}")
    with open(os.path.join(args.workdir, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    plot(tables["prestressed"], FIGURE)
    print(f"wrote {FIGURE}")


def plot(rel, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.8))
    nd = np.arange(rel.shape[0])
    for j in range(rel.shape[1]):
        ax.plot(nd, 100 * rel[:, j], marker=".", label=f"family {j + 1}")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xlabel("nodal diameter")
    ax.set_ylabel("CalculiX / wheelrom - 1  [%]")
    ax.set_title("Prestressed wheel (coarse, 50 Hz): CalculiX static + perturbation step\n"
                 "vs wheelrom exact cyclic FE (K + K_sigma - Omega^2 M_s)")
    ax.grid(alpha=0.3)
    ax.legend(ncol=2, fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)


if __name__ == "__main__":
    main()
