"""Command line: a thin layer over the library (``wheelrom --help``).

Every subcommand takes an optional CONFIG (TOML; none = built-in default case), any number of
``--set section.key=value`` overrides, and after ``--`` options for the PETSc database.
Configuration errors exit with status 2 before anything is computed or written.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Sequence

from wheelrom.runtime.environment import bootstrap

# one BLAS/OpenMP thread per process, set before anything below loads numpy: OpenBLAS reads
# the thread count once, and with one thread per visible core its sums round differently,
# so a plain `wheelrom` (every core visible) and `mpirun -n 2 wheelrom` (bound to one core)
# built different segment bases (docs/theory.md, "Reproducibility")
bootstrap()

from wheelrom import config as config_mod  # noqa: E402
from wheelrom.cli import args as cli_args  # noqa: E402
from wheelrom.cli import forced as cli_forced  # noqa: E402
from wheelrom.cli import limit_cycle as cli_limit_cycle  # noqa: E402
from wheelrom.cli import motion as cli_motion  # noqa: E402
from wheelrom.cli import settle as cli_settle  # noqa: E402
from wheelrom.cli import tools as cli_tools  # noqa: E402
from wheelrom.cli.args import comm_self, load_config, locked  # noqa: E402
from wheelrom.cli.output import (  # noqa: E402
    EXIT_INTERRUPTED,
    fail,
    log,
    numpy_warnings_off,
    print_json,
    print_modes,
    print_result,
    print_stability,
    print_study,
    report_and_save,
    warn_unused,
    world_rank,
)
from wheelrom.runtime import kernel_cache as _kernel_cache  # noqa: E402
from wheelrom.runtime.errors import (  # noqa: E402
    DiskFull,
    InputError,
    Interrupted,
    OutputExists,
)
from wheelrom.runtime.outputs import (  # noqa: E402
    agree,
    check_output,
    check_space,
    disk_full,
    hdf5_image,
    is_disk_full,
    replacing,
    save_image,
)


def _petsc_options(args: argparse.Namespace) -> None:
    """Hand the arguments after ``--`` to PetscInitialize (or, when PETSc is already up,
    insert them into the options database)."""
    if getattr(args, "petsc_args", None):
        from wheelrom.runtime.environment import petsc, set_init_args

        if "petsc4py.PETSc" not in sys.modules:
            set_init_args(args.petsc_args)
            petsc()
        else:
            petsc().Options().insertString(" ".join(args.petsc_args))
        from wheelrom.transient.options import check

        check(args.petsc_args)  # a value a solver refuses: one line naming it, exit 2


# --------------------------------------------------------------------------------------
# subcommands
# --------------------------------------------------------------------------------------


def cmd_config_show(args: argparse.Namespace) -> int:
    cfg = load_config(args)
    sys.stdout.write(f"# effective configuration from {cfg.source}\n")
    sys.stdout.write(config_mod.to_toml(cfg))
    return 0


def cmd_config_check(args: argparse.Namespace) -> int:
    """The keys, and for a user mesh (``segment.source``) the file and its node sets: what
    a run would refuse, found without computing anything."""
    from wheelrom.config.study import expand

    cfg = load_config(args)
    study = expand(cfg)  # every case validated as 'study' will (a [study] section, or none)
    if cfg.segment.source != "builtin":
        from wheelrom.segment.load import load_segment

        seg = load_segment(cfg)
        print(f"{cfg.segment.source}: {seg.nodes.shape[0]} nodes, node sets "
              + ", ".join(sorted(seg.node_sets)))
    if not study.legacy:
        print(f"study: {study.size} case(s) of {', '.join(study.names)}")
    print(f"{cfg.source}: OK")
    return 0


@locked("--out", "--vtu")
def cmd_modes(args: argparse.Namespace) -> int:
    """Segment modes (SLEPc) and wheel frequencies by nodal diameter (cyclic synthesis)."""
    from wheelrom.rom.build import build, quiet
    from wheelrom.rom.model import wheel_modes

    cfg = load_config(args)
    cli_args.check_vtu_arguments(args, cfg)
    if args.out:
        check_output(args.out, args.force)
    say = quiet if args.json else log
    wheel = build(cfg, comm_self(), log=say)
    model = wheel.model
    hz, nd, _ = wheel_modes(model)
    if args.vtu:
        from wheelrom.rom.wheelmesh import write_wheel_mode

        if args.vtu_family >= model.modes:
            raise InputError(f"--vtu-family {args.vtu_family}: the model has families "
                             f"0..{model.modes - 1}")
        with replacing(args.vtu) as partial:
            f_mode = write_wheel_mode(partial, wheel.segment.mesh, wheel.shapes, model,
                                      args.vtu_nd, args.vtu_family)
        say(f"wrote {args.vtu}: ND {args.vtu_nd} mode at {f_mode:.2f} Hz on the whole wheel")
    extra = {"wheel_hz": hz, "wheel_nd": nd}
    if args.full_wheel:
        extra.update(_full_wheel(args, cfg, wheel))
    table = model.frequencies_by_nodal_diameter()
    reference, assembled = extra.get("full_wheel_hz"), extra.get("assembled_wheel_hz")
    if args.json:  # first: a full disk still leaves the numbers
        out = {"segment_hz": model.segment_hz.tolist(), "wheel_hz": hz.tolist(),
               "wheel_nd": nd.tolist(), "reduced_hz_by_nd": table.tolist(), "info": model.info}
        if reference is not None:
            out["full_wheel_hz"] = reference.tolist()
            out["relative_error_by_nd"] = (table / reference - 1).tolist()
        if assembled is not None:
            out["assembled_wheel_hz"] = assembled.tolist()
        print_json(out)
    else:
        print_modes(model, table, reference, assembled)
    if args.out:
        from wheelrom.results.layout import write_model_file

        image = hdf5_image(lambda f: write_model_file(f, cfg, model, extra))
        failure = save_image(args.out, image, "the frequencies are printed above")
        if failure:
            raise failure
    return 0


def _full_wheel(args: argparse.Namespace, cfg, wheel) -> dict:
    """The full-wheel FE references of ``modes --full-wheel`` on the model's own matrices."""
    from wheelrom.rom import references

    seg, mats = wheel.segment.mesh, wheel.segment.matrices
    c1, m = cfg.wheel.coupling_stiffness, wheel.model.modes
    out = {}
    if args.full_wheel in ("cyclic", "both"):
        # minutes on the default wheel: its progress reaches stderr even with --json
        out["full_wheel_hz"] = references.cyclic_table(seg, mats, c1, m, comm_self(), log=log)
    if args.full_wheel in ("assembled", "both"):
        from wheelrom.runtime.environment import petsc

        out["assembled_wheel_hz"] = references.assembled_wheel_modes(
            seg, mats, c1, args.full_wheel_modes, petsc().COMM_WORLD)
    return out


@locked("--out")
def cmd_run(args: argparse.Namespace) -> int:
    """One transient case on PETSc TS (options after -- go to the TS, prefix wheel_)."""
    from wheelrom.rom.build import build_model, quiet
    from wheelrom.studies.stability import attach_linear
    from wheelrom.transient.run import check_run_memory, run_case

    cfg = load_config(args)
    if args.out:
        check_output(args.out, args.force)
    check_run_memory(cfg)
    model = build_model(cfg, comm_self(), log=quiet if args.json else log)

    def progress(w, total, t, amp):
        if not args.json:
            log(f"window {w}/{total}: t = {t:.4f} s, max tip amplitude {amp:.3e} m")

    if args.out:
        from wheelrom.results import layout as results

        def create(f):
            results.create_layout(f, results.single_case(cfg), model)

        check_space(args.out, results.layout_bytes(create))
    res = run_case(model, cfg, progress=progress)
    attach_linear(model, cfg, None, res)
    print_result(res.summary(), args.json)  # first: a full disk still leaves the numbers
    if args.out:  # built in memory: a full disk keeps the whole file in $TMPDIR, as modes'

        def fill(f):
            create(f)
            results.write_case(f, 0, res)

        failure = save_image(args.out, hdf5_image(fill), "its summary is printed above")
        if failure:
            raise failure
    return 0 if res.status == "done" else 1


def cmd_compare(args: argparse.Namespace) -> int:
    """PETSc TS against the plain-numpy serial reference on the same model, with the scheme
    the TS integrates (``time.scheme``, or what ``-wheel_ts_type`` chose): the exponential
    one (ETDRK4) or RK 3bs at fixed steps. A difference that is not finite (either side
    diverged) or a TS that stopped early exits with status 1."""
    import math

    import numpy as np

    from wheelrom.rom.build import build_model, quiet
    from wheelrom.transient.exponential import taken_step
    from wheelrom.transient.reference import reference_solution, tip_difference
    from wheelrom.transient.run import check_run_memory, run_case
    from wheelrom.transient.ts import ts_settings

    cfg = load_config(args)
    if args.steps < 1:
        raise InputError(f"compare --steps: at least 1 step to compare (got {args.steps})")
    settings = ts_settings(cfg)  # the TS's scheme and step: -wheel_ts_* options override
    scheme = _reference_scheme(settings)
    steps = args.steps
    check_run_memory(_compare_config(cfg, steps, float(settings["ts_dt"])),
                     given=f"compare --steps {steps}",
                     advice="compare fewer steps")
    model = build_model(cfg, comm_self(), log=quiet if args.json else log)
    step = float(settings["ts_dt"])
    if scheme == "exponential":  # the step the TS takes (off resonances, stable)
        step = taken_step(model, cfg, step)
    cfg = _compare_config(cfg, steps, step)
    res = run_case(model, cfg)
    with np.errstate(all="ignore"):  # a diverging reference is reported below, in one line
        # the reference's samples (about 200) give the run's largest tip displacement
        _, states, ref_wall = reference_solution(model, cfg, steps, step,
                                                 sample_every=max(1, steps // 200),
                                                 scheme=scheme)
        diff, absolute, scale = tip_difference(model, states, res.final_state)
    out = {
        "steps": steps,
        "step_s": step,
        "scheme": scheme,
        "start": "preload",
        "max_relative_difference": diff,
        "max_difference_m": absolute,
        "largest_tip_displacement_m": scale,
        "petsc_wall_s": res.wall_s,
        "reference_wall_s": ref_wall,
    }
    print_result(out, args.json)
    if res.status != "done":
        return fail(f"compare: the PETSc TS did not finish the {steps} steps ({res.status})", 1)
    if not math.isfinite(diff):
        return fail(f"compare: the difference is not finite ({diff}): the integration "
                    f"diverged at step {step:g} s", 1)
    return 0


def _compare_config(cfg, steps: int, step: float):
    """``cfg`` as ``compare`` runs it: one window over the ``steps`` steps of ``step`` [s],
    with at least one sample in it, from the preloaded equilibrium (from rest the wheel is
    chaotic for its first ~100 ms, where two correct integrators part at the round-off's
    growth: 4e-8 after 20 ms)."""
    span = steps * step
    rate = max(cfg.output.sample_rate_hz, 1.0 / span)
    return config_mod.with_option(
        cfg, f"compare --steps {steps}",
        {"time.end": span, "time.window": span, "output.sample_rate_hz": rate,
         "output.history_rate_hz": rate, "output.state_rate_hz": 0.0, "time.start": "preload"})


def _reference_scheme(settings: dict) -> str:
    """The serial reference's scheme for the TS ``settings`` (:func:`ts_settings`):
    ``"exponential"`` or ``"rk"`` (RK 3bs, fixed steps); any other TS has no reference."""
    from wheelrom.transient.exponential import SCHEME

    if settings.get("ts_scheme") == SCHEME:
        return "exponential"
    if (settings.get("ts_type") == "rk" and settings.get("ts_rk_type") == "3bs"
            and settings.get("ts_adapt_type") == "none"):
        return "rk"
    chosen = ", ".join(f"{k} {settings[k]}" for k in ("ts_type", "ts_rk_type", "ts_adapt_type")
                       if k in settings)
    raise InputError(f"compare: the serial reference integrates time.scheme 'exponential' or "
                     f"RK 3bs at fixed steps, not this TS ({chosen})")


def cmd_sweep(args: argparse.Namespace) -> int:
    """Angle sweep across MPI ranks into one parallel HDF5 file (mpirun -n P wheelrom sweep)."""
    from mpi4py import MPI

    from wheelrom.studies.sweep import run_sweep

    cfg = load_config(args)
    failed = run_sweep(cfg, args.out, MPI.COMM_WORLD, resume=args.resume, force=args.force,
                       log=log, model_comm=args.model_comm,
                       batch=args.batch)
    return 1 if failed else 0


def cmd_study(args: argparse.Namespace) -> int:
    """Design study under mpirun: the [study] keys of CONFIG varied as a grid, zipped lists or
    CSV cases; linear stability of every case (and with --forced its peak forced response,
    with --forced-nonlinear its nonlinear forced response: the friction damper's design
    curve), then transients of all cases, of the boundary cases (--screen) or of none
    (--stability-only), into one HDF5 file."""
    from mpi4py import MPI

    from wheelrom.studies.study import run_study

    cfg = load_config(args)
    mode = cli_args.study_mode(args)
    confirm = cli_args.parse_confirm(args.confirm)
    summary = run_study(cfg, args.out, MPI.COMM_WORLD, mode=mode, confirm=confirm,
                        resume=args.resume, force=args.force, log=log,
                        batch=args.batch, forced=args.forced,
                        nonlinear=args.forced_nonlinear)
    if world_rank() == 0:
        print_json(summary) if args.json else print_study(summary, args.out)
    return 1 if summary["transients"]["failed"] else 0


@locked("--out")
def cmd_stability(args: argparse.Namespace) -> int:
    """Linear stability of every case at its preloaded equilibrium (nozzle off): eigenvalues
    per nodal diameter, the fastest-growing mode and what it does at the contacts. Under
    mpirun the cases are spread over the ranks."""
    from wheelrom.results.layout import write_stability
    from wheelrom.rom.build import quiet
    from wheelrom.studies.stability import run_stability, summary, world_if_parallel

    cfg = load_config(args)
    if args.out:
        check_output(args.out, args.force)
    comm = world_if_parallel()
    model, cases = run_stability(cfg, comm, log=quiet if args.json else log,
                                 margin=args.margin)
    failure = None
    if cases:  # rank 0: every case
        failure = report_and_save([summary(r) for r in cases], args.json, print_stability,
                                  args.out, lambda f: write_stability(f, cfg, model, cases))
    agree(comm, failure)  # every rank stops together, none waits for rank 0's file
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
    "study": (cmd_study, "design study (grid, zip or CSV cases) under mpirun: stability map, "
              "screened transients, forced responses", cli_args.args_study),
    "plot": (cli_tools.cmd_plot, "figures from a results file", cli_args.args_plot),
    "info": (cli_tools.cmd_info, "summary of a results or model file", cli_args.args_info),
    "export": (cli_tools.cmd_export, "one case as CSV (tip histories, window statistics, "
               "contact forces)", cli_args.args_export),
    "animate": (cli_motion.cmd_animate, "one case's wheel in motion: XDMF, GIF, PNG",
                cli_motion.args_animate),
    "contacts": (cli_motion.cmd_contacts, "one case's contact forces and friction hysteresis",
                 cli_motion.args_contacts),
    "bench": (cli_tools.cmd_bench, "speed and accuracy figures on this machine (one core): "
              "transient, contact laws, limit cycle, nonlinear forced response",
              cli_args.args_bench),
    "campbell": (cli_tools.cmd_campbell, "frequencies versus rotor speed (prestressed)",
                 cli_args.args_campbell),
    "mesh": (cli_tools.cmd_mesh, "write the segment mesh and node sets", cli_args.args_mesh),
    "accuracy": (cli_tools.cmd_accuracy, "reduced model vs exact cyclic FE, per family",
                 cli_args.args_accuracy),
    "stability": (cmd_stability, "linear stability per nodal diameter of every case",
                  cli_args.args_stability),
    "limit-cycle": (cli_limit_cycle.cmd_limit_cycle, "how far the flutter grows: per "
                    "travelling wave the exact periodic orbit by shooting (from the harmonic "
                    "balance's cycle; marched under the elastic law) and its Floquet "
                    "stability", cli_limit_cycle.args_limit_cycle),
    "settle": (cli_settle.cmd_settle, "where the flutter settles: the wheel integrated from the "
               "fastest wave's exact orbit (or the seeded equilibrium) until stationary, "
               "classified", cli_settle.args_settle),
    "forced-response": (cli_forced.cmd_forced, "forced response to the nozzle: linear, tuned "
                        "and mistuned (amplification factor); --nonlinear: with friction, by "
                        "harmonic balance", cli_forced.args_forced),
    "contact-stiffness": (cli_tools.cmd_contact_stiffness,
                          "k_c(beta) from the segment FE (static unit loads)",
                          cli_args.json_out),
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="wheelrom",
        description=(
            "Reduced modal model of a bladed turbine wheel with dry-friction tie-boss and "
            "shroud contacts, Van der Pol flutter and nozzle excitation (PETSc/SLEPc). "
            "Arguments after '--' go to the PETSc options database."
        ),
    )
    from wheelrom import __version__

    parser.add_argument("--version", action="version", version=f"wheelrom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p_cfg = sub.add_parser("config", help="show or check a configuration")
    cfg_sub = p_cfg.add_subparsers(dest="config_command", metavar="ACTION")
    cfg_sub.required = True
    p = cfg_sub.add_parser("show", help="print the effective configuration as TOML")
    cli_args.add_config_args(p)
    p.set_defaults(func=cmd_config_show)
    p = cfg_sub.add_parser("check", help="validate a configuration file (exit 2 if invalid)")
    cli_args.add_config_args(p, required=True)
    p.set_defaults(func=cmd_config_check)

    for name, (func, help_text, extra) in COMMANDS.items():
        p = sub.add_parser(name, help=help_text, description=func.__doc__)
        if name == "plot":
            p.add_argument("results", help="HDF5 file of any wheelrom command: "
                           + cli_args.ANY_FILE)
        elif name not in ("info", "export", "animate", "contacts"):  # these read a file
            cli_args.add_config_args(p)
        extra(p)
        p.set_defaults(func=func)
    return parser


def abort_the_job() -> None:
    """Print this rank's traceback and abort every rank, when more than one runs and MPI is
    up (nothing in a serial run: the exception then ends the process as usual). Without it
    the other ranks wait for this one in their next collective for ever (a settle whose rank
    1 failed kept rank 0 computing alone for 40 minutes)."""
    size = os.environ.get("OMPI_COMM_WORLD_SIZE", os.environ.get("PMI_SIZE", "1"))
    if int(size) <= 1 or "mpi4py.MPI" not in sys.modules or "pytest" in sys.modules:
        return  # (under pytest the failing test reports it; an abort would end the session)
    import traceback

    from mpi4py import MPI

    # one write: a prefix written apart reached mpirun as its own chunk, and the abort's
    # banner could land between it and the traceback (seen once in the test under load)
    sys.stderr.write(f"rank {world_rank()}: {traceback.format_exc()}")
    sys.stderr.flush()
    MPI.COMM_WORLD.Abort(1)



def main(argv: Sequence[str] | None = None) -> int:
    """The command line (under mpirun an escaping exception aborts the job: abort_the_job)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    petsc_args: list[str] = []
    if "--" in argv:
        cut = argv.index("--")
        argv, petsc_args = argv[:cut], argv[cut + 1 :]
    parser = build_parser()
    args = parser.parse_args(argv)
    args.petsc_args = petsc_args
    bootstrap()  # PETSc/SLEPc location, one BLAS thread per process (before numpy loads)
    if world_rank() == 0:  # "compiling kernels (first run only)" on a kernel-cache miss
        _kernel_cache.set_log(log)
    try:
        with numpy_warnings_off():
            _petsc_options(args)
            status = int(args.func(args) or 0)
    except config_mod.ConfigError as exc:
        return fail(str(exc))
    except OutputExists as exc:
        again = ("--resume to complete it or --force" if args.command in ("sweep", "study")
                 else "--force")
        return fail(f"{exc.path} exists: pass {again} to overwrite it")
    except InputError as exc:
        return fail(str(exc))
    except Interrupted as exc:  # what was finished is saved; the message says where
        return fail(str(exc), EXIT_INTERRUPTED)
    except DiskFull as exc:  # what was flushed is kept; the message says what
        return fail(str(exc), 1)
    except KeyboardInterrupt:
        return fail("interrupted (nothing was being saved)", EXIT_INTERRUPTED)
    except BrokenPipeError:  # the output was piped into head & co., which stopped reading
        sys.stdout = open(os.devnull, "w")  # noqa: SIM115 -- the interpreter flushes it at exit
        return 0
    except OSError as exc:
        if not is_disk_full(exc):
            abort_the_job()
            raise
        return fail(str(disk_full(getattr(exc, "filename", None) or "output", exc,
                                  "what was written before is kept")), 1)
    except Exception:
        abort_the_job()
        raise
    warn_unused(args.petsc_args)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
