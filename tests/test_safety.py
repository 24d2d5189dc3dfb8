"""Nothing a user computed is lost, bad input is one clear line (issue #18): existing outputs
refused without --force, output paths checked before computing, sweep files readable from
their first byte (a kill during creation included), resume with other TS options refused,
Ctrl-C saves and says how to go on, bad PETSc options named, config check catches what a run
would refuse."""

import json
import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

import handshake
from conftest import HANG_S, SMALL
from wheelrom import config
from wheelrom.cli import main as cli
from wheelrom.results.info import file_info

QUICK = ["--set", "time.end=0.001", "--set", "time.window=0.0005"]
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1", MPLBACKEND="Agg")


def wheelrom(*args, timeout=HANG_S, ranks=None, **kw):
    """The CLI in a subprocess (its own PETSc database), optionally under mpirun."""
    cmd = [sys.executable, "-m", "wheelrom.cli.main", *args]
    if ranks:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=ENV, **kw)


def _one_error_line(res, *words):
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1, res.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# --- existing outputs -----------------------------------------------------------------


@pytest.mark.parametrize(
    "argv",
    [
        ["run", SMALL, *QUICK],
        ["modes", SMALL],
        ["mesh", SMALL],
    ],
)
def test_existing_output_is_refused_without_force(argv, tmp_path, capsys, nothing_computed):
    out = tmp_path / ("seg.vtu" if argv[0] == "mesh" else "x.h5")
    out.write_bytes(b"precious")
    assert cli.main([*argv, "--out", str(out)]) == 2  # refused before anything is computed
    assert out.read_bytes() == b"precious"
    err = capsys.readouterr().err
    assert f"{out} exists: pass --force to overwrite it" in err


def test_force_replaces_and_leaves_no_temporary_file(tmp_path, capsys):
    out = tmp_path / "seg.inp"
    out.write_text("old")
    assert cli.main(["mesh", SMALL, "--out", str(out), "--force"]) == 0
    assert out.read_text().startswith("** wheelrom segment")
    assert sorted(os.listdir(tmp_path)) == ["seg.inp", "seg_cyclic.inp"]  # no .partial left


def test_sweep_resume_and_force_together_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        cli.main(["sweep", SMALL, "--out", str(tmp_path / "s.h5"), "--resume", "--force"])
    assert exc.value.code == 2
    assert "not allowed with argument" in capsys.readouterr().err


# --- output paths checked before any computation --------------------------------------


@pytest.mark.parametrize("command", ["run", "modes", "mesh", "sweep"])
@pytest.mark.parametrize("where", ["missing", "directory"])
def test_bad_output_path_fails_at_once_naming_it(command, where, tmp_path, capsys,
                                                 nothing_computed):
    out = tmp_path / "nowhere" / "x.h5" if where == "missing" else tmp_path
    argv = [command, SMALL, "--out", str(out)] + (QUICK if command in ("run", "sweep") else [])
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(out) in err[0]
    assert ("does not exist" if where == "missing" else "is a directory") in err[0]


def test_read_only_directory_fails_at_once(tmp_path, capsys, monkeypatch, nothing_computed):
    """A directory the user may not write to (mode 0500; as root, which writes anyway, the
    permission answer is what the check asks the OS for: made to say no here)."""
    folder = tmp_path / "ro"
    folder.mkdir(mode=0o500)
    real_access = os.access
    monkeypatch.setattr(os, "access", lambda path, mode: False if os.fspath(path) == str(folder)
                        else real_access(path, mode))
    assert cli.main(["run", SMALL, *QUICK, "--out", str(folder / "r.h5")]) == 2
    err = capsys.readouterr().err
    assert f"directory '{folder}' is not writable" in err and len(err.strip().splitlines()) == 1


def test_outdir_that_is_a_file_fails_at_once(tmp_path, capsys):
    not_a_dir = tmp_path / "figs"
    not_a_dir.write_text("")
    assert cli.main(["campbell", SMALL, "--speeds", "0,50", "--outdir", str(not_a_dir)]) == 2
    assert f"--outdir {not_a_dir}: is a file, not a directory" in capsys.readouterr().err


# --- the sweep file ---------------------------------------------------------------------

KILL_DURING_CREATION = """
import os, signal, sys
from wheelrom.cli import main as cli
from wheelrom.results import layout as results
real = results.create_layout
def dying(f, cfg, model):
    real(f, cfg, model)
    f.flush()
    os.kill(os.getpid(), signal.SIGKILL)  # killed with the layout half on disk
results.create_layout = dying
sys.exit(cli.main(sys.argv[1:]))
"""


def test_sweep_killed_while_creating_its_file_leaves_nothing_to_trip_over(tmp_path):
    out = tmp_path / "s.h5"
    argv = ["sweep", SMALL, "--out", str(out), *QUICK]
    res = subprocess.run([sys.executable, "-c", KILL_DURING_CREATION, *argv],
                         capture_output=True, text=True, timeout=HANG_S, env=ENV)
    assert res.returncode == -signal.SIGKILL
    assert not out.exists()  # the name appears only with a complete layout
    # the killed job's lock is reported stale with the command that removes it, not stolen
    res = wheelrom(*argv, "--resume")
    assert res.returncode == 2
    _one_error_line(res, "stale lock", "rm ")
    os.remove(tmp_path / ".s.h5.lock")
    # then what run/paper does on every run: --resume starts afresh and completes
    res = wheelrom(*argv, "--resume")
    assert res.returncode == 0, res.stderr
    with h5py.File(out, "r") as f:
        assert [s.decode() for s in f["cases/status"][:]] == ["done"] * 3
    assert [p for p in os.listdir(tmp_path) if "partial" in p] == []


@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("sweep") / "s.h5"
    res = wheelrom("sweep", SMALL, "--out", str(out), *QUICK)
    assert res.returncode == 0, res.stderr
    return out


def test_resume_with_other_ts_options_is_refused_naming_them(small_sweep):
    with h5py.File(small_sweep, "r+") as f:  # case 3 still to run
        f["cases/status"][2] = b"pending"
    before = os.path.getmtime(small_sweep)
    res = wheelrom("sweep", SMALL, "--out", str(small_sweep), *QUICK, "--resume",
                   "--", "-wheel_ts_rk_type", "5dp")
    assert res.returncode == 2
    _one_error_line(res, "ts_rk_type=3bs", "ts_rk_type=5dp", "--force")
    assert os.path.getmtime(small_sweep) == before
    res = wheelrom("sweep", SMALL, "--out", str(small_sweep), *QUICK, "--resume")
    assert res.returncode == 0, res.stderr
    with h5py.File(small_sweep, "r") as f:
        assert [json.loads(o)["ts_rk_type"] for o in f["cases/options"][:]] == ["3bs"] * 3


def _interrupt_the_second_round(tmp_path, argv, sig=signal.SIGINT, ranks=None):
    """Run ``wheelrom argv`` (under ``mpirun -n ranks`` when given) with rank 0's second round
    held (:data:`handshake.SWEEP_SECOND_ROUND`), send ``sig`` to every rank once it holds
    there, and return (exit status, stderr). Signalled after the first progress line instead,
    a fast machine could have finished every case before the signal came."""
    cmd = [*handshake.script(tmp_path, handshake.SWEEP_SECOND_ROUND), *argv]
    if ranks:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=ENV)
    every_rank = [f"{handshake.STARTED} rank {r} " for r in range(ranks or 1)]
    seen = handshake.read_until(proc, handshake.HOLDING, *every_rank)
    for pid in handshake.pids(seen).values():  # the ranks themselves, never mpirun
        os.kill(pid, sig)
    seen += proc.stderr.readlines()
    return proc.wait(timeout=HANG_S), "".join(seen)


#: three cases, one a round (one process: three rounds; two ranks: cases 1 and 2, then 3)
ROUNDS = ["--set", "time.end=0.002", "--set", "time.window=0.001", "--batch", "1"]


def test_ctrl_c_saves_finished_cases_and_says_how_to_resume(tmp_path):
    out = tmp_path / "s.h5"
    status, err = _interrupt_the_second_round(tmp_path, ["sweep", SMALL, "--out", str(out),
                                                         *ROUNDS])
    assert status == 130, err
    lines = [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1 and "Traceback" not in err
    assert lines[0].startswith("wheelrom: interrupted: 1 of 3 cases done and saved in "), lines
    assert "rerun the sweep with --resume" in lines[0]
    with h5py.File(out, "r") as f:  # readable, and it says what the message said
        status_of = [s.decode() for s in f["cases/status"][:]]
    assert status_of == ["done", "pending", "pending"]
    assert lines[0].endswith(file_info(str(out))["hint"])  # one hint: the command's and info's


def test_sigterm_under_mpirun_stops_every_rank_with_one_line(tmp_path):
    """mpirun forwards Ctrl-C to the ranks as SIGTERM: here sent to the ranks directly (sent
    to mpirun as well, as a search of the command line did, mpirun aborts the job: SIGKILL a
    second after its SIGTERM, and the ranks had to finish within that second)."""
    out = tmp_path / "s.h5"
    status, err = _interrupt_the_second_round(
        tmp_path, ["sweep", SMALL, "--out", str(out), *ROUNDS], signal.SIGTERM, ranks=2)
    assert status == 130, err  # every rank's (mpirun's status: the first rank's to end)
    lines = [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith("wheelrom: interrupted: 2 of 3 cases done and saved in "), lines
    with h5py.File(out, "r") as f:  # the first round's two cases, the held one pending
        assert [s.decode() for s in f["cases/status"][:]] == ["done", "done", "pending"]


# --- clear errors -----------------------------------------------------------------------


@pytest.mark.parametrize(
    "option, words",
    [
        (["-wheel_ts_type", "nosuchtype"], ["-wheel_ts_type nosuchtype", "unknown type"]),
        (["-wheel_ts_rk_type", "nosuch"], ["-wheel_ts_rk_type nosuch"]),
        (["-wheel_ts_dt", "abc"], ["-wheel_ts_dt abc", "expects a number"]),
        (["-wheel_ts_dt", "-1"], ["-wheel_ts_dt -1", "must be positive"]),
        (["-segment_eps_type", "nosuch"], ["-segment_eps_type nosuch", "EPS"]),
        (["-wheel_ts_rk_type", "5dp", "-wheel_ts_type", "nosuch"], ["-wheel_ts_type nosuch"]),
    ],
)
def test_bad_petsc_option_is_one_line_naming_it(option, words):
    res = wheelrom("run", SMALL, *QUICK, "--", *option)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    _one_error_line(res, *words)


def test_unused_petsc_option_is_a_warning(tmp_path):
    """A typo is never read; a real TS option is read by run's TS, but not by mesh, which
    has no TS (the up-front check's probes do not count as reading)."""
    options = ["--", "-wheel_ts_typo", "3", "-wheel_ts_rk_type", "5dp"]
    res = wheelrom("run", SMALL, *QUICK, *options)
    assert res.returncode == 0, res.stderr
    assert "warning: PETSc option -wheel_ts_typo was not used" in res.stderr
    assert "-wheel_ts_rk_type" not in res.stderr
    res = wheelrom("mesh", SMALL, "--out", str(tmp_path / "s.vtu"), *options)
    assert res.returncode == 0, res.stderr
    assert "warning: PETSc option -wheel_ts_rk_type was not used" in res.stderr


def test_ts_reason_in_words():
    from wheelrom.transient.ts import reason_words

    assert reason_words(-2) == "a step was rejected too often (PETSc TS reason -2)"


@pytest.mark.parametrize(
    "argv, words",
    [
        (["--vtu", "w.vtu", "--vtu-nd", "40"], ["--vtu-nd 40", "0..6"]),
        (["--vtu", "w.vtu", "--vtu-nd", "-3"], ["--vtu-nd -3", "0..6"]),
        (["--vtu", "w.vtu", "--vtu-family", "10"], ["--vtu-family 10", "0..5"]),
        (["--vtu-nd", "3"], ["--vtu-nd needs --vtu"]),
    ],
)
def test_modes_vtu_arguments_are_usage_errors(argv, words, tmp_path, capsys):
    argv = [a if a != "w.vtu" else str(tmp_path / a) for a in argv]
    assert cli.main(["modes", SMALL, *argv]) == 2
    err = capsys.readouterr().err
    assert all(w in err for w in words), err
    assert not (tmp_path / "w.vtu").exists()


def test_compare_with_no_steps_names_the_argument(capsys):
    assert cli.main(["compare", SMALL, "--steps", "0"]) == 2
    assert "compare --steps" in capsys.readouterr().err


# --- config check catches what a run would refuse ----------------------------------------


def _config(tmp_path, text):
    path = tmp_path / "c.toml"
    path.write_text(text)
    return str(path)


def test_config_check_reads_the_user_mesh(tmp_path, capsys):
    missing = _config(tmp_path, '[segment]\nsource = "nope.inp"\n')
    assert cli.main(["config", "check", missing]) == 2
    assert "segment.source: mesh file" in capsys.readouterr().err
    (tmp_path / "bad.vtu").write_text("x")  # meshio's vtu reader calls sys.exit on this
    garbage = _config(tmp_path, '[segment]\nsource = "bad.vtu"\n')
    assert cli.main(["config", "check", garbage]) == 2
    assert "segment.source: cannot read" in capsys.readouterr().err


def test_config_check_needs_the_node_sets(tmp_path, capsys):
    assert cli.main(["mesh", SMALL, "--out", str(tmp_path / "seg.inp")]) == 0
    text = (tmp_path / "seg.inp").read_text()
    (tmp_path / "notip.inp").write_text(text.replace("*NSET, NSET=TIP", "*NSET, NSET=TOP"))
    cfg = _config(tmp_path, '[wheel]\nblades = 12\n[segment]\nsource = "notip.inp"\n')
    capsys.readouterr()
    assert cli.main(["config", "check", cfg]) == 2
    assert "'tip'" in capsys.readouterr().err


def test_config_check_refuses_windows_without_a_sample(capsys):
    assert cli.main(["config", "check", SMALL, "--set", "output.sample_rate_hz=1000"]) == 2
    assert "output.sample_rate_hz: 1000.0 Hz leaves a window" in capsys.readouterr().err


@pytest.mark.parametrize("what", ["directory", "latin-1"])
def test_config_path_that_is_no_toml_text_is_named(what, tmp_path, capsys):
    path = tmp_path
    if what == "latin-1":
        path = tmp_path / "c.toml"
        path.write_bytes("# Schaufelkr\xe4nze\n".encode("latin-1"))
    assert cli.main(["config", "check", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and ("is a directory" in err or "not UTF-8" in err)


def test_window_longer_than_the_run_is_shortened_to_it(capsys):
    assert cli.main(["config", "check", SMALL, "--set", "time.end=0.0002"]) == 0
    from wheelrom import config
    from wheelrom.transient.ts import time_grid

    grid = time_grid(config.load(SMALL, ["time.end=0.0002"]))
    assert grid.window_end == (0.0002,)


def test_ts_options_no_solver_reads_are_not_recorded_but_named(tmp_path):
    """The record holds what took effect: options no TS read are named as unused, not
    written into the file as if they had acted (they had made the record too long)."""
    out = tmp_path / "s.h5"
    many = [token for k in range(12) for token in (f"-wheel_ts_extra_setting_{k}", "1")]
    res = wheelrom("sweep", SMALL, "--out", str(out), *QUICK, "--", *many)
    assert res.returncode == 0, res.stderr
    assert "wheel_ts_extra_setting_11 was not used by any solver" in res.stderr
    with h5py.File(out, "r") as f:
        assert not any("extra_setting" in o.decode() for o in f["cases/options"][:])


def test_a_failed_batch_does_not_block_resume(small_sweep):
    """A batch that failed before its TS existed records the run's settings (older files
    hold {}): resuming with the same options is allowed."""
    from wheelrom.results.layout import options_problem
    from wheelrom.transient.ts import ts_settings

    with h5py.File(small_sweep, "r+") as f:
        f["cases/status"][0] = b"failed: RuntimeError: preload_snes did not converge"
        f["cases/options"][0] = b"{}"
    from wheelrom import config

    assert options_problem(str(small_sweep), ts_settings(config.load(SMALL, QUICK[1::2]))) is None


def test_a_failing_stability_case_under_mpirun_stops_every_rank(tmp_path):
    """One rank's case fails (its equilibrium SNES is starved of iterations: after two, the
    residual of the 0 and 20 deg cases on rank 0 is 5e-9 and 7e-9, below the tolerance, that
    of the 90 deg case on rank 1 1.2e-7): one line, no hang (every rank stops together)."""
    res = wheelrom("stability", SMALL, "--set", "sweep.shroud_angles_deg=[0.0, 90.0, 20.0]",
                   "--", "-stability_preload_snes_rtol", "0", "-stability_preload_snes_atol",
                   "2e-8", "-stability_preload_snes_max_it", "2", ranks=2)
    assert res.returncode != 0
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1 and "linear stability failed for 1 case(s)" in lines[0], res.stderr


# --- a full disk ----------------------------------------------------------------------


def _free(monkeypatch, free_bytes):
    """The disk holding every output reports ``free_bytes`` free."""
    import collections

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr("wheelrom.runtime.outputs.shutil.disk_usage",
                        lambda _: usage(10**12, 10**12 - free_bytes, free_bytes))


def test_an_output_that_cannot_fit_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    from wheelrom.results import layout as results
    from wheelrom.results.histories import case_bytes
    from wheelrom.rom.build import build_model
    from wheelrom.runtime.environment import petsc

    out = tmp_path / "s.h5"
    cfg = config.load(SMALL, ["time.end=5.0"])  # 5 s of tip histories: ~13 MB
    needed = results.layout_bytes(
        lambda f: results.create_layout(f, cfg, build_model(cfg, petsc().COMM_SELF)))
    with h5py.File(tmp_path / "layout.h5", "w") as f:  # the estimate is the layout's size
        results.create_layout(f, cfg, build_model(cfg, petsc().COMM_SELF))
    assert case_bytes(h5py.File(tmp_path / "layout.h5")["cases"])["tip_history"] * 3 < needed
    os.remove(tmp_path / "layout.h5")
    _free(monkeypatch, 8_000_000)
    assert cli.main(["sweep", SMALL, "--set", "time.end=5.0", "--out", str(out)]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("wheelrom:")]
    assert len(err) == 1 and not os.listdir(tmp_path), err  # before any case: no file
    assert err[0] == (f"wheelrom: --out {out}: needs about {(needed * 1.01 + 2**20) / 1e6:.1f} MB, "
                      f"the disk holding '{tmp_path}' has 8.0 MB free")
    _free(monkeypatch, 500_000)  # below what any output needs: refused before the model
    assert cli.main(["run", SMALL, *QUICK, "--out", str(out)]) == 2
    assert "has 500.0 kB free" in capsys.readouterr().err


def test_a_disk_that_fills_keeps_the_finished_rounds_and_resumes(tmp_path, capsys, monkeypatch):
    import errno

    from wheelrom.results import layout as results

    out, reference = tmp_path / "s.h5", tmp_path / "ref.h5"
    assert cli.main(["sweep", SMALL, "--out", str(reference)]) == 0
    real_write, calls = results.write_case, []

    def write_until_full(f, i, res):
        calls.append(i)
        if len(calls) == 2:  # the second case's histories do not fit any more
            f["cases/energy0"][i] = res.energy0
            raise OSError(errno.ENOSPC, "Can't write data (No space left on device)")
        real_write(f, i, res)

    monkeypatch.setattr(results, "write_case", write_until_full)
    assert cli.main(["sweep", SMALL, "--out", str(out), "--batch", "1"]) == 1
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.startswith("wheelrom:")]
    assert err == [f"wheelrom: {out}: the disk is full (errno 28, ENOSPC: No space left on "
                   "device); the cases of every finished round are in the file: free space "
                   "and rerun with --resume"]
    with h5py.File(out, "r") as f:
        assert [s.decode() for s in f["cases/status"][:]] == ["done", "pending", "pending"]
    monkeypatch.setattr(results, "write_case", real_write)  # space freed
    assert cli.main(["sweep", SMALL, "--out", str(out), "--resume"]) == 0
    with h5py.File(out, "r") as a, h5py.File(reference, "r") as b:
        for name in ("max_tip_amplitude", "tip_history", "energy", "status"):
            assert np.array_equal(a[f"cases/{name}"][()], b[f"cases/{name}"][()]), name
