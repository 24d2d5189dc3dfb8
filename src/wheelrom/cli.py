"""Command line: a thin layer over the library (``wheelrom --help``).

Every subcommand takes an optional CONFIG (TOML; none = built-in default case), any number of
``--set section.key=value`` overrides, and after ``--`` options for the PETSc database.
Configuration errors exit with status 2 before anything is computed or written.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence

from wheelrom import cli_args
from wheelrom import config as config_mod
from wheelrom._environment import bootstrap
from wheelrom.errors import InputError, OutputExists

EXIT_CONFIG = 2


def _add_config_args(p: argparse.ArgumentParser, required: bool = False) -> None:
    p.add_argument(
        "config",
        nargs=None if required else "?",
        help="TOML configuration file" + ("" if required else " (default: built-in case)"),
    )
    p.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override one key, e.g. --set time.end=0.2 (repeatable)",
    )


def _load(args: argparse.Namespace) -> config_mod.Config:
    return config_mod.load(args.config, args.overrides)


def _petsc_options(args: argparse.Namespace) -> None:
    """Hand the arguments after ``--`` to PetscInitialize (or, when PETSc is already up,
    insert them into the options database)."""
    if getattr(args, "petsc_args", None):
        from wheelrom._environment import petsc, set_init_args

        if "petsc4py.PETSc" not in sys.modules:
            set_init_args(args.petsc_args)
            petsc()
        else:
            petsc().Options().insertString(" ".join(args.petsc_args))


# --------------------------------------------------------------------------------------
# subcommands
# --------------------------------------------------------------------------------------


def cmd_config_show(args: argparse.Namespace) -> int:
    cfg = _load(args)
    sys.stdout.write(f"# effective configuration from {cfg.source}\n")
    sys.stdout.write(config_mod.to_toml(cfg))
    return 0


def cmd_config_check(args: argparse.Namespace) -> int:
    cfg = _load(args)
    print(f"{cfg.source}: OK")
    return 0


def _log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def _comm_self():
    from wheelrom._environment import petsc

    return petsc().COMM_SELF


def cmd_modes(args: argparse.Namespace) -> int:
    """Segment modes (SLEPc) and wheel frequencies by nodal diameter (cyclic synthesis)."""
    from wheelrom.rom.build import build, quiet
    from wheelrom.rom.model import wheel_modes

    cfg = _load(args)
    say = quiet if args.json else _log
    wheel = build(cfg, _comm_self(), log=say)
    model = wheel.model
    hz, nd, _ = wheel_modes(model)
    if args.vtu:
        from wheelrom.rom.wheelmesh import write_wheel_mode

        f_mode = write_wheel_mode(args.vtu, wheel.segment.mesh, wheel.shapes, model,
                                  args.vtu_nd, args.vtu_family)  # fmt: skip
        say(f"wrote {args.vtu}: ND {args.vtu_nd} mode at {f_mode:.2f} Hz on the whole wheel")
    extra = {"wheel_hz": hz, "wheel_nd": nd}
    if args.full_wheel:
        extra.update(_full_wheel(args, cfg, wheel, say))
    if args.out:
        import h5py

        from wheelrom.results import write_model_file

        with h5py.File(args.out, "w") as f:
            write_model_file(f, cfg, model, extra)
    table = model.frequencies_by_nodal_diameter()
    reference, assembled = extra.get("full_wheel_hz"), extra.get("assembled_wheel_hz")
    if args.json:
        out = {"segment_hz": model.segment_hz.tolist(), "wheel_hz": hz.tolist(),
               "wheel_nd": nd.tolist(), "reduced_hz_by_nd": table.tolist(), "info": model.info}
        if reference is not None:
            out["full_wheel_hz"] = reference.tolist()
            out["relative_error_by_nd"] = (table / reference - 1).tolist()
        if assembled is not None:
            out["assembled_wheel_hz"] = assembled.tolist()
        print_json(out)  # fmt: skip
        return 0
    _print_modes(model, table, reference, assembled)
    return 0


def _full_wheel(args: argparse.Namespace, cfg, wheel, say) -> dict:
    """The full-wheel FE references of ``modes --full-wheel`` on the model's own matrices."""
    from wheelrom.rom import references

    seg, mats = wheel.segment.mesh, wheel.segment.matrices
    c1, m = cfg.wheel.coupling_stiffness, wheel.model.modes
    out = {}
    if args.full_wheel in ("cyclic", "both"):
        out["full_wheel_hz"] = references.cyclic_table(seg, mats, c1, m, _comm_self(), log=say)
    if args.full_wheel in ("assembled", "both"):
        from wheelrom._environment import petsc

        out["assembled_wheel_hz"] = references.assembled_wheel_modes(
            seg, mats, c1, args.full_wheel_modes, petsc().COMM_WORLD)
    return out


def _print_modes(model, table, reference, assembled) -> None:
    print("segment modes [Hz]: " + ", ".join(f"{x:.2f}" for x in model.segment_hz))
    for kind_name, rep in model.info.items():
        if isinstance(rep, dict) and "arm_length" in rep:
            print(
                f"{kind_name}: arm L = {rep['arm_length']:.4g} m, pitch chord "
                f"{rep['pitch_chord']:.4g} m, arm end misses next A by "
                f"{rep['tip_to_next_A'] * 1e3:.2f} mm"
            )
    print("wheel frequencies by nodal diameter [Hz] (first 4 families):")
    for k, row in enumerate(table):
        print(f"  ND {k:3d}: " + "  ".join(f"{x:9.2f}" for x in row[:4]))
    if reference is not None:
        err = 100 * (table / reference - 1)
        print("reduced model vs full-wheel FE (exact cyclic symmetry), error [%] by family:")
        print("  family:  " + "  ".join(f"{j + 1:7d}" for j in range(table.shape[1])))
        print("  max:     " + "  ".join(f"{x:7.2f}" for x in err.max(axis=0)))
        print("  mean:    " + "  ".join(f"{x:7.2f}" for x in err.mean(axis=0)))
    if assembled is not None:
        print("assembled full wheel, lowest [Hz]: " + ", ".join(f"{x:.3f}" for x in assembled))


def cmd_run(args: argparse.Namespace) -> int:
    """One transient case on PETSc TS (options after -- go to the TS, prefix wheel_)."""
    from wheelrom.rom.build import build_model, quiet
    from wheelrom.transient.run import run_case

    cfg = _load(args)
    model = build_model(cfg, _comm_self(), log=quiet if args.json else _log)

    def progress(w, total, t, amp):
        if not args.json:
            _log(f"window {w}/{total}: t = {t:.4f} s, max tip amplitude {amp:.3e} m")

    res = run_case(model, cfg, progress=progress)
    if args.out:
        import h5py

        from wheelrom import results

        with h5py.File(args.out, "w") as f:
            results.create_layout(f, results.single_case(cfg), model)
            results.write_case(f, 0, res)
    _print_result(res.summary(), args.json)
    return 0 if res.status == "done" else 1


def cmd_compare(args: argparse.Namespace) -> int:
    """PETSc TS against the plain-numpy serial reference on the same model."""
    import numpy as np

    from wheelrom.rom.build import build_model, quiet
    from wheelrom.transient.reference import reference_solution
    from wheelrom.transient.run import run_case
    from wheelrom.transient.ts import time_step

    cfg = _load(args)
    steps, step = args.steps, time_step(cfg)  # the TS's step: -wheel_ts_dt overrides
    cfg = cfg.replace(**{"time.end": steps * step, "time.window": steps * step})
    model = build_model(cfg, _comm_self(), log=quiet if args.json else _log)
    res = run_case(model, cfg)
    _, states, ref_wall = reference_solution(model, cfg, steps, step, sample_every=steps)
    n = model.size
    ref_tip = states[-1][:n].reshape(model.blades, model.modes) @ model.tip.T
    ts_tip = res.final_state[:n].reshape(model.blades, model.modes) @ model.tip.T
    diff = float(np.abs(ref_tip - ts_tip).max() / max(np.abs(ref_tip).max(), 1e-300))
    out = {
        "steps": steps,
        "step_s": step,
        "max_relative_difference": diff,
        "petsc_wall_s": res.wall_s,
        "reference_wall_s": ref_wall,
    }
    _print_result(out, args.json)
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """Angle sweep across MPI ranks into one parallel HDF5 file (mpirun -n P wheelrom sweep)."""
    from mpi4py import MPI

    from wheelrom.sweep import run_sweep

    cfg = _load(args)
    try:
        failed = run_sweep(cfg, args.out, MPI.COMM_WORLD, resume=args.resume, force=args.force,
                           log=lambda m: print(m, flush=True), model_comm=args.model_comm,
                           batch=args.batch)  # fmt: skip
    except OutputExists as exc:
        raise InputError(f"{exc.path} exists: pass --resume to complete it or --force to "
                         "overwrite it") from None  # fmt: skip
    return 1 if failed else 0


def cmd_contact_stiffness(args: argparse.Namespace) -> int:
    """Contact stiffness k_c(beta) from the segment FE by static unit loads (paper Fig. 5),
    on the segment matrices the model uses (prestressed when the configuration says so)."""
    from wheelrom.config import CONTACT_KINDS
    from wheelrom.forces.parameters import stiffness_at
    from wheelrom.rom.build import build_segment, contact_stiffness_tables, quiet

    cfg = _load(args)
    segment = build_segment(cfg, _comm_self(), log=quiet if args.json else _log)
    seg = segment.mesh
    kinds = [k for k in CONTACT_KINDS if f"{k}_A" in seg.node_sets]
    out = {}
    for kind, (angles, values, flex) in contact_stiffness_tables(segment, kinds,
                                                                 _comm_self()).items():  # fmt: skip
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
        return 0
    for kind, row in out.items():
        print(f"{kind}: k_c [N/m] from the segment FE ({seg.n_dofs} DOFs), configured value")
        conf = row["configured_n_per_m"] or [None] * len(row["angle_deg"])
        for a, k, c in zip(row["angle_deg"], row["fe_stiffness_n_per_m"], conf, strict=True):
            print(f"  {a:5.1f} deg  {k:11.4g}  " + ("" if c is None else f"{c:11.4g}"))
    return 0


def cmd_accuracy(args: argparse.Namespace) -> int:
    """Reduced-model frequencies against the exact cyclic-symmetry FE: error per family."""
    import numpy as np

    from wheelrom.rom.accuracy import accuracy_table
    from wheelrom.rom.build import quiet

    cfg = _load(args)
    table = accuracy_table(cfg, _comm_self(), tuple(args.modes), args.enriched_modes,
                           args.families, log=quiet if args.json else _log)  # fmt: skip
    if args.json:
        print_json({
            "reference_hz": table["reference_hz"].tolist(),
            "bases": {k: {"vectors": v["vectors"], "relative_error": v["relative_error"].tolist()}
                      for k, v in table["bases"].items()},
        })  # fmt: skip
        return 0
    fam = table["reference_hz"].shape[1]
    print("max over nodal diameters of |reduced / FE - 1| [%], by family")
    print(
        f"{'basis':18s} {'vectors':>7s} "
        + " ".join(f"{'fam ' + str(j + 1):>9s}" for j in range(fam))
    )
    for label, row in table["bases"].items():
        err = 100 * np.abs(row["relative_error"]).max(axis=0)
        print(f"{label:18s} {row['vectors']:7d} " + " ".join(f"{x:9.3f}" for x in err))
    return 0


def cmd_mesh(args: argparse.Namespace) -> int:
    """Write the segment mesh and node sets (.inp with a CalculiX modal step, .vtu, ...)."""
    from wheelrom.segment.export import write_segment
    from wheelrom.segment.load import load_segment

    cfg = _load(args)
    seg = load_segment(cfg)
    write_segment(seg, args.out, cfg)
    sets = ", ".join(f"{k} ({v.size})" for k, v in sorted(seg.node_sets.items()))
    print(f"wrote {args.out}: {seg.nodes.shape[0]} nodes, {seg.n_dofs} DOFs; node sets: {sets}")
    return 0


def cmd_campbell(args: argparse.Namespace) -> int:
    """Segment and wheel frequencies versus speed (prestressed), with engine orders."""
    from wheelrom.plots import plot_campbell
    from wheelrom.rom.build import quiet
    from wheelrom.rom.campbell import campbell

    cfg = _load(args)
    speeds = _parse_speeds(args.speeds)
    data = campbell(cfg, speeds, _comm_self(), log=quiet if args.json else _log)
    written = plot_campbell(data, args.outdir, pdf=args.pdf)
    if args.json:
        print_json({k: (v.tolist() if hasattr(v, "tolist") else v) for k, v in data.items()}
                   | {"figures": written})  # fmt: skip
    else:
        print("\n".join(written))
    return 0


def _parse_speeds(text: str):
    """``--speeds``: ``"start:stop:count"`` [Hz] (inclusive, like numpy.linspace) or
    ``"a,b,c"``."""
    import numpy as np

    try:
        if ":" in text:
            start, stop, count = text.split(":")
            return np.linspace(float(start), float(stop), int(count))
        return np.array([float(x) for x in text.split(",")])
    except ValueError:
        raise InputError(
            f"--speeds: expected start:stop:count or a,b,c in Hz, got {text!r}"
        ) from None


def cmd_bench(args: argparse.Namespace) -> int:
    """Speed of the transient hot path on this machine (one core): RHS, TS steps, ratios."""
    from wheelrom.bench import run
    from wheelrom.rom.build import build_model, quiet

    cfg = _load(args)
    if args.steps < 20000:
        raise InputError(f"bench --steps must be at least 20000 (got {args.steps})")
    if args.batch < 1:
        raise InputError(f"bench --batch must be at least 1 (got {args.batch})")
    say = quiet if args.json else _log
    model = build_model(cfg, _comm_self(), log=say)
    out = run(model, cfg, steps=args.steps, compare_steps=args.reference_steps, log=say,
              batch=args.batch)  # fmt: skip
    _print_result(out, args.json)
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    """Figures (PNG, PDF with --pdf) from a sweep/run/modes HDF5 file."""
    from wheelrom.plots import plot_file

    written = plot_file(args.results, args.outdir, pdf=args.pdf, nd_angles=args.nd_angles)
    for path in written:
        print(path)
    return 0


COMMANDS: dict[
    str, tuple[Callable[[argparse.Namespace], int], str, Callable[[argparse.ArgumentParser], None]]
] = {
    "modes": (cmd_modes, "segment and wheel modal analysis", cli_args.args_modes),
    "run": (cmd_run, "one transient case", cli_args.args_run),
    "compare": (cmd_compare, "PETSc TS against the serial numpy reference",
                cli_args.args_compare),
    "sweep": (cmd_sweep, "contact-angle sweep under mpirun, parallel HDF5",
              cli_args.args_sweep),
    "plot": (cmd_plot, "figures from a results file", cli_args.args_plot),
    "bench": (cmd_bench, "speed of the transient hot path (one core)", cli_args.args_bench),
    "campbell": (cmd_campbell, "frequencies versus rotor speed (prestressed)",
                 cli_args.args_campbell),
    "mesh": (cmd_mesh, "write the segment mesh and node sets", cli_args.args_mesh),
    "accuracy": (cmd_accuracy, "reduced model vs exact cyclic FE, per family",
                 cli_args.args_accuracy),
    "contact-stiffness": (cmd_contact_stiffness,
                          "k_c(beta) from the segment FE (static unit loads)",
                          cli_args.json_out),
}  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wheelrom",
        description=(
            "Reduced modal model of a bladed turbine wheel with dry-friction tie-boss and "
            "shroud contacts, Van der Pol flutter and nozzle excitation (PETSc/SLEPc). "
            "Arguments after '--' go to the PETSc options database."
        ),
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p_cfg = sub.add_parser("config", help="show or check a configuration")
    cfg_sub = p_cfg.add_subparsers(dest="config_command", metavar="ACTION")
    cfg_sub.required = True
    p = cfg_sub.add_parser("show", help="print the effective configuration as TOML")
    _add_config_args(p)
    p.set_defaults(func=cmd_config_show)
    p = cfg_sub.add_parser("check", help="validate a configuration file (exit 2 if invalid)")
    _add_config_args(p, required=True)
    p.set_defaults(func=cmd_config_check)

    for name, (func, help_text, extra) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=func.__doc__)
        if name == "plot":
            p.add_argument("results", help="HDF5 file from sweep, run or modes --out")
        else:
            _add_config_args(p)
        extra(p)
        p.set_defaults(func=func)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    petsc_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, petsc_args = argv[:cut], argv[cut + 1 :]
    parser = build_parser()
    args = parser.parse_args(argv)
    args.petsc_args = petsc_args
    bootstrap()  # PETSc/SLEPc location, one BLAS thread per process (before numpy loads)
    try:
        _petsc_options(args)
        return int(args.func(args) or 0)
    except config_mod.ConfigError as exc:
        print(f"wheelrom: {exc}", file=sys.stderr)
        return EXIT_CONFIG
    except InputError as exc:
        print(f"wheelrom: {exc}", file=sys.stderr)
        return EXIT_CONFIG


def _print_result(out: dict, as_json: bool) -> None:
    """One JSON object on stdout, or ``key: value`` lines."""
    if as_json:
        print_json(out)
    else:
        for key, value in out.items():
            print(f"{key}: {value}")


def print_json(obj: object) -> None:
    json.dump(obj, sys.stdout, indent=1, default=float)
    sys.stdout.write("\n")


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
