"""The commands that read files or answer one question about the model (``plot``, ``info``,
``export``, ``bench``, ``campbell``, ``mesh``, ``accuracy``, ``contact-stiffness``): each
parses nothing itself, calls the library and formats through :mod:`wheelrom.cli.output`."""

from __future__ import annotations

import argparse
import os
import shlex

from wheelrom.cli import args as cli_args
from wheelrom.cli.args import comm_self, load_config
from wheelrom.cli.output import (
    log,
    print_accuracy,
    print_contact_stiffness,
    print_json,
    print_result,
)
from wheelrom.cli.output_info import changed_text, inconsistent_text, print_info
from wheelrom.runtime.errors import InputError
from wheelrom.runtime.outputs import check_outdir, check_output


def cmd_contact_stiffness(args: argparse.Namespace) -> int:
    """Contact stiffness k_c(beta) from the segment FE by static unit loads (paper Fig. 5),
    on the segment matrices the model uses (prestressed when the configuration says so)."""
    from wheelrom.config import CONTACT_KINDS
    from wheelrom.forces.parameters import stiffness_at
    from wheelrom.rom.build import build_segment, contact_stiffness_tables, quiet

    cfg = load_config(args)
    segment = build_segment(cfg, comm_self(), log=quiet if args.json else log)
    seg = segment.mesh
    kinds = [k for k in CONTACT_KINDS if f"{k}_A" in seg.node_sets]
    out = {}
    for kind, (angles, values, flex) in contact_stiffness_tables(segment, kinds,
                                                                 comm_self()).items():
        configured = cfg.contact(kind).stiffness
        out[kind] = {
            "angle_deg": angles.tolist(),
            "fe_stiffness_n_per_m": values.tolist(),
            "configured_n_per_m": None
            if configured == "fe"
            else [stiffness_at(configured, a) for a in angles],
            "arm_axial_stiffness_n_per_m": cfg.contact(kind).arm_axial_stiffness,
            "flexibility_m_per_n": flex.G.tolist(),
            "load_nodes": list(flex.load_nodes),
            "solve_s": flex.solve_s,
        }
    if args.json:
        print_json(out)
    else:
        print_contact_stiffness(out, seg.n_dofs)
    return 0


def cmd_accuracy(args: argparse.Namespace) -> int:
    """Reduced-model frequencies against the exact cyclic-symmetry FE: error per family."""
    from wheelrom.rom.accuracy import accuracy_table
    from wheelrom.rom.build import quiet

    cfg = load_config(args)
    table = accuracy_table(cfg, comm_self(), tuple(args.modes), args.enriched_modes,
                           args.families, log=quiet if args.json else log)
    if args.json:
        print_json({
            "reference_hz": table["reference_hz"].tolist(),
            "bases": {k: {"vectors": v["vectors"], "relative_error": v["relative_error"].tolist()}
                      for k, v in table["bases"].items()},
        })
    else:
        print_accuracy(table)
    return 0


@cli_args.locked("--out")
def cmd_mesh(args: argparse.Namespace) -> int:
    """Write the segment mesh and node sets (.inp with a CalculiX modal step, .vtu, ...)."""
    from wheelrom.segment.export import cyclic_deck_path, write_segment
    from wheelrom.segment.load import load_segment

    cfg = load_config(args)
    check_output(args.out, args.force)
    if os.path.splitext(args.out)[1].lower() == ".inp":
        check_output(cyclic_deck_path(args.out), args.force)
    seg = load_segment(cfg)
    written = write_segment(seg, args.out, cfg)
    sets = ", ".join(f"{k} ({v.size})" for k, v in sorted(seg.node_sets.items()))
    print(f"wrote {args.out}: {seg.nodes.shape[0]} nodes, {seg.n_dofs} DOFs; node sets: {sets}")
    for deck in written[1:]:
        folder, name = os.path.split(os.path.abspath(deck))
        print(f"wrote {deck}: CalculiX wheel modes per nodal diameter "
              f"(cd {shlex.quote(folder)} && ccx -i {shlex.quote(os.path.splitext(name)[0])})")
    return 0


def cmd_campbell(args: argparse.Namespace) -> int:
    """Segment and wheel frequencies versus speed (prestressed), with engine orders."""
    from wheelrom.plots.figures import plot_campbell
    from wheelrom.rom.build import BeyondPrestress, quiet
    from wheelrom.rom.campbell import campbell

    cfg = load_config(args)
    check_outdir(args.outdir)
    speeds = cli_args.parse_speeds(args.speeds, cfg)
    if os.path.isdir(args.outdir):  # a figure there is refused before computing (or --force)
        for name in ("campbell.png", "campbell.pdf")[: 1 + args.pdf]:
            check_output(os.path.join(args.outdir, name), args.force, flag="--outdir")
    try:
        data = campbell(cfg, speeds, comm_self(), log=quiet if args.json else log)
    except BeyondPrestress as exc:  # the speed is the option's, not wheel.speed_hz
        raise InputError(f"--speeds {args.speeds}: at {exc.speed_hz:g} Hz {exc.why}: a lower "
                         "top speed") from None
    written = plot_campbell(data, args.outdir, pdf=args.pdf, force=args.force)
    if args.json:
        print_json({k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in data.items()}
                   | {"figures": written})
    else:
        print("\n".join(written))
    return 0


def cmd_bench(args: argparse.Namespace) -> int:
    """Speed and accuracy figures on this machine (one core): the transient's hot path (RHS,
    TS steps, batches, the machine's floors, ratios against numpy and scipy), the schemes'
    accuracy, the elastic law's cost against the paper law's, one limit cycle with its exact
    orbit and multipliers, and the nonlinear forced response's curve."""
    from wheelrom.bench.transient import run
    from wheelrom.rom.build import build_model, quiet

    cfg = load_config(args)
    if args.steps < 20000:
        raise InputError(f"bench --steps must be at least 20000 (got {args.steps})")
    if args.batch < 1:
        raise InputError(f"bench --batch must be at least 1 (got {args.batch})")
    say = quiet if args.json else log
    model = build_model(cfg, comm_self(), log=say)
    # the groups' progress goes to stderr even with --json (stdout holds the JSON only)
    out = run(model, cfg, steps=args.steps, compare_steps=args.reference_steps, log=log,
              batch=args.batch)
    print_result(out, args.json)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    """Figures (PNG, PDF with --pdf) from a results file of any wheelrom command: a sweep, run,
    study, stability, limit-cycle, settle, forced-response or modes file."""
    from wheelrom.plots.figures import figures_dir, plot_file
    from wheelrom.results.layout import check_readable

    check_readable(args.results)  # the input first: a directory named is told for what it is
    # the default folder too (beside the results, which may be read-only): one line, not a
    # traceback from the staging folder
    outdir = args.outdir or figures_dir(args.results)
    check_outdir(outdir)
    written = plot_file(args.results, outdir, pdf=args.pdf, nd_angles=args.nd_angles,
                        force=args.force)
    for path in written:
        print(path)
    return 0


def cmd_info(args: argparse.Namespace) -> int:
    """What a results or model file holds: format, configuration source, model size, and
    per case the contact angles, status (failure reasons), windows done and wall time (a
    stability, limit-cycle, settle or forced-response file: its verdicts and amplitudes)."""
    from wheelrom.results.info import file_info

    info = file_info(args.file, verify=args.verify)
    if args.json:
        print_json(info)
    else:
        print_info(info, show_all=args.all)
    checks = info.get("checksums")
    if checks and checks["mismatched"]:  # exit 1: a script checking a copy sees it
        if not args.json:
            changed = changed_text(checks["mismatched"])
            log(f"wheelrom: {args.file}: case(s) {changed} changed since they were written "
                "(checksum mismatch): recompute them" if checks.get("scope") != "file" else
                f"wheelrom: {args.file}: {changed} changed since written (checksum "
                "mismatch): compute the file again")
        return 1
    if checks and checks.get("inconsistent"):  # whole as written, but not of its wheel
        if not args.json:
            log(f"wheelrom: {args.file}: {inconsistent_text(checks['inconsistent'])}: not "
                "what its wheel's cases hold; compute the file again")
        return 1
    if checks and not checks["stored"] and not args.json:  # exit 0: an older file is whole
        log(f"wheelrom: {args.file}: no checksums stored (written before wheelrom kept them): "
            "nothing was verified")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """One case of a results file as CSV: tip histories, per-window statistics and, from a
    modal state history, contact forces."""
    from wheelrom.results.export import export_case

    print("\n".join(export_case(args.file, args.case, args.csv, args.what, args.force)))
    return 0
