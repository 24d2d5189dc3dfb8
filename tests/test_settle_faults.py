"""``wheelrom settle`` (and ``run``) when things go wrong (issue #47b): a disk that fills keeps
what was computed in $TMPDIR and names every path, leaving no partial file; Ctrl-C names the
finished cases kept beside the output and the --resume line; a ``[settle]`` whose times
cannot work is one line before anything is integrated; no NaN reaches a progress line or a
figure's warnings.

Small and fast: the small wheel as a Van der Pol wheel (tests/conftest.py), windows of two
periods (17 ms), a few windows per case."""

import builtins
import errno
import io
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import warnings

import h5py
import numpy as np
import pytest

import handshake
from conftest import HANG_S, SMALL, VDP_WHEEL
from wheelrom.cli import main as cli

#: one case, two-period windows, at most 0.05 s simulated
QUICK = [*VDP_WHEEL, "sweep.shroud_angles_deg=[50.0]", "settle.window_periods=2",
         "settle.min_time=0.05", "settle.max_time=0.05"]


def _sets(keys: list[str]) -> list[str]:
    return sum((["--set", k] for k in keys), [])


def _errors(err: str) -> list[str]:
    """The CLI's error lines (its warnings apart)."""
    return [ln for ln in err.splitlines()
            if ln.startswith("wheelrom:") and not ln.startswith("wheelrom: warning:")]


# --- 5: no NaN in a progress line, no warning from a figure ---------------------------


@pytest.fixture(scope="module")
def quick_settle(tmp_path_factory):
    """``(file, stderr)`` of one quick settle with every progress line shown (unthrottled)."""
    from wheelrom.cli import settle as cli_settle
    from wheelrom.cli.output import log

    out = tmp_path_factory.mktemp("quick") / "s.h5"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(cli_settle, "throttled", lambda every_s: log)
        err = io.StringIO()
        patch.setattr(sys, "stderr", err)
        code = cli.main(["settle", SMALL, *_sets(QUICK), "--out", str(out)])
    assert code == 0, err.getvalue()[-2000:]
    return out, err.getvalue()


def test_the_first_window_is_named_not_a_nan_percentage(quick_settle):
    _, err = quick_settle
    windows = [ln for ln in err.splitlines() if "largest blade" in ln and " um, " in ln]
    assert len(windows) >= 2, err
    assert "nan" not in err.lower(), err
    assert windows[0].endswith("first window"), windows[0]
    assert "window change" in windows[1], windows[1]


def test_plot_of_a_settle_file_warns_nothing(quick_settle, tmp_path, capsys):
    out, _ = quick_settle
    # a leaked RuntimeWarning of the plot fails the test (the fixture, which may run first
    # here, builds a model under other libraries' deprecation warnings: not this test's)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        assert cli.main(["plot", str(out), "--outdir", str(tmp_path)]) == 0
    assert "Warning" not in capsys.readouterr().err
    assert (tmp_path / "settle_case0.png").exists()


# --- 4: [settle] times that cannot work: one line before anything is integrated ----------


def test_min_time_above_max_time_is_refused_naming_both(capsys):
    keys = [*QUICK, "settle.min_time=0.5", "settle.max_time=0.3"]
    for command in ("config check", "settle"):  # refused as every configuration error is
        assert cli.main([*command.split(), SMALL, *_sets(keys)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("wheelrom: invalid configuration:\n") and "Traceback" not in err
        (problem,) = err.splitlines()[1:]
        assert problem.endswith(": settle.min_time = 0.5 s is above settle.max_time = 0.3 s: "
                                "no case could ever be called settled"), problem


def test_max_time_shorter_than_one_window_is_refused_before_integrating(capsys, monkeypatch):
    """Two periods of the ND 6 flutter at 125 Hz are 16 ms: a 5 ms maximum holds no window
    (it was reported "not settled after 0 s", exit 0). The start (the preloaded equilibrium)
    gives the frequency; no window is integrated."""
    from wheelrom.transient import run

    def integrated(*_, **__):
        raise AssertionError("a window was integrated: the refusal came too late")

    monkeypatch.setattr(run, "run_case", integrated)
    keys = [*QUICK, 'settle.start="preload"', "settle.min_time=0.0", "settle.max_time=0.005"]
    assert cli.main(["settle", SMALL, *_sets(keys)]) == 2
    (line,) = _errors(capsys.readouterr().err)
    assert line.startswith("wheelrom: settle.max_time = 0.005 s is shorter than one window: "
                           "settle.window_periods = 2 periods"), line


# --- 1, 2: a disk that fills keeps what was computed in $TMPDIR -------------------------


@pytest.fixture
def full_disk(tmp_path, monkeypatch):
    """``(out, spare, fill)``: once ``fill()`` is called, every write into ``tmp_path/out``
    fails with ENOSPC, from Python (``open``: the side files, a results file's bytes) or from
    HDF5 (``h5py.File``), as a disk that filled while the job ran; ``tmp_path/tmp`` is
    $TMPDIR (tests/test_bad_inputs.py's full disk, for every writer)."""
    out, spare = tmp_path / "out", tmp_path / "tmp"
    out.mkdir()
    spare.mkdir()
    full = [False]

    def on_the_full_disk(path) -> bool:
        if isinstance(path, int):  # a descriptor (os.fdopen): the file it is open on
            path = os.readlink(f"/proc/self/fd/{path}")
        return full[0] and isinstance(path, str | os.PathLike) and \
            os.path.dirname(os.path.abspath(path)).startswith(str(out))

    class Filling:
        """An open file whose every write finds the disk full."""

        def __init__(self, fh):
            self._fh = fh

        def write(self, data):
            raise OSError(errno.ENOSPC, "No space left on device")

        def __getattr__(self, name):
            return getattr(self._fh, name)

        def __enter__(self):
            return self

        def __exit__(self, *_):
            self._fh.close()

    real_open = io.open

    def opening(file, mode="r", *args, **kwargs):
        fh = real_open(file, mode, *args, **kwargs)
        writes = any(c in mode for c in "wax+")
        return Filling(fh) if writes and on_the_full_disk(file) else fh

    class FullFile(h5py.File):
        def __init__(self, name, mode="r", *args, **kwargs):
            if mode != "r" and on_the_full_disk(name):
                raise OSError(errno.ENOSPC, f"Unable to create file (name = '{name}', errno = "
                              "28, error message = 'No space left on device')")
            super().__init__(name, mode, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", opening)
    monkeypatch.setattr(io, "open", opening)  # zipfile's (numpy.savez)
    monkeypatch.setattr(h5py, "File", FullFile)
    monkeypatch.setattr(tempfile, "tempdir", str(spare))
    return out, spare, lambda: full.__setitem__(0, True)


def test_a_disk_that_fills_during_settle_keeps_every_case_and_names_the_paths(
        full_disk, capsys, monkeypatch):
    """The first case is saved beside the output, then the disk fills: the second case's
    side file fails (it was an exception that lost the computed case, left
    case_1.partial.npz and said "what was written before is kept", naming no path); now it
    stays in memory, the file of both cases is kept in $TMPDIR, and the one line names it,
    the output and the case kept beside it."""
    from wheelrom.studies import settle_cases

    out_dir, spare, fill = full_disk
    real = settle_cases.save_case

    def saved_then_full(*args, **kwargs):
        real(*args, **kwargs)
        fill()  # while the second case is computed

    monkeypatch.setattr(settle_cases, "save_case", saved_then_full)
    out, beside = out_dir / "s.h5", out_dir / ".s.settle"
    keys = [*QUICK, "sweep.shroud_angles_deg=[50.0, 60.0]"]
    assert cli.main(["settle", SMALL, *_sets(keys), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Exception ignored" not in err, err
    (line,) = _errors(err)
    (kept,) = os.listdir(spare)
    free = line.split("; ")[1].split(" free in")[0]
    assert line == (f"wheelrom: {out}: the disk is full (errno 28, ENOSPC: No space left on "
                    f"device; {free} free in '{out_dir}'); the results are kept in "
                    f"{spare / kept} (move it there once space is freed); the summary is "
                    f"printed above; case 0 of 0..1 also stays in {beside} (--resume reuses "
                    "it)")
    assert f"wheelrom: warning: {beside / 'case_1.npz'}: the disk is full" in err
    assert os.listdir(out_dir) == [".s.settle"]  # no output, no temporary, no lock
    assert sorted(os.listdir(beside)) == ["case_0.json", "case_0.npz"]  # nothing partial
    with h5py.File(spare / kept, "r") as f:  # every case computed
        assert f.attrs["format"] == "wheelrom-settle-1"
        assert f["settle/time"].shape == (2,) and (f["settle/time"][()] > 0.04).all()


def test_run_on_a_full_disk_keeps_its_history_in_tmpdir(full_disk, capsys, monkeypatch):
    """The disk fills while ``run`` integrates: its file, the histories with it, is kept in
    $TMPDIR and named, as the other commands' (it said "nothing was written")."""
    from wheelrom.transient import run

    out_dir, spare, fill = full_disk
    real = run.run_case
    monkeypatch.setattr(run, "run_case", lambda *a, **k: (real(*a, **k), fill())[0])
    out = out_dir / "r.h5"
    argv = ["run", SMALL, "--set", "time.end=0.001", "--set", "time.window=0.0005"]
    assert cli.main([*argv, "--out", str(out), "--json"]) == 1
    captured = capsys.readouterr()
    assert json.loads(captured.out)["status"] == "done"  # the summary first
    (line,) = _errors(captured.err)
    (kept,) = os.listdir(spare)
    assert line.startswith(f"wheelrom: {out}: the disk is full (errno 28, ENOSPC"), line
    assert line.endswith(f"; the results are kept in {spare / kept} (move it there once space "
                         "is freed); its summary is printed above"), line
    assert not os.listdir(out_dir)  # no file, no temporary, no lock
    with h5py.File(spare / kept, "r") as f:  # the whole run, its history too
        assert f["cases/status"][0] == b"done"
        tips = f["cases/tip_history"][0]
        assert tips.size and np.isfinite(tips).all() and np.abs(tips).max() > 0


# --- 3: Ctrl-C names the finished cases kept and the --resume line ----------------------


def test_ctrl_c_during_settle_names_the_kept_cases_and_the_resume_line(tmp_path, capsys):
    """SIGINT while the second of two cases runs (tests/test_safety.py's interrupt, by a
    real signal to the command): the first case is kept beside the output, and the one line
    said "nothing was being saved"; now it names the case, the folder and the line that
    resumes, shell-quoted (a space and a quote in the paths), which then finishes the file
    computing only the second case. The second case holds before its integration until the
    signal comes (tests/handshake.py: sent once the first case's verdict line appeared, a
    fast machine had finished the second too, exit 0)."""
    folder = tmp_path / "my runs"
    folder.mkdir()
    # one case a batch: the first is kept while the second runs
    keys = [*QUICK, "sweep.shroud_angles_deg=[50.0, 60.0]", "settle.batch=1"]
    assert cli.main(["config", "show", SMALL, *_sets(keys)]) == 0
    cfg, out = folder / "it's.toml", folder / "it's.h5"
    cfg.write_text(capsys.readouterr().out)
    held = handshake.script(tmp_path, """
        import wheelrom.studies.settle as study
        integrate = study.settle_cases
        def settle_cases(model, cfg, angles, *args, **kwargs):
            if angles[0]["shroud"] == 60.0:  # the second case
                hold("the second case's integration")  # until SIGINT raises in it
            return integrate(model, cfg, angles, *args, **kwargs)
        study.settle_cases = settle_cases
        """)
    proc = subprocess.Popen([*held, "settle", str(cfg), "--out", str(out)],
                            stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            env=dict(os.environ, MPLBACKEND="Agg"))
    seen = handshake.read_until(proc, handshake.HOLDING)
    proc.send_signal(signal.SIGINT)
    seen += proc.stderr.readlines()
    err = "".join(seen)
    assert proc.wait(timeout=HANG_S) == 130, err
    assert "Traceback" not in err, err
    (line,) = _errors(err)
    beside = folder / ".it's.settle"
    assert line.startswith(f"wheelrom: interrupted: case 0 of 0..1 finished and kept in {beside}; "
                           "to compute only the other 1, rerun the settle with --resume: "
                           "wheelrom settle "), line
    assert sorted(os.listdir(beside)) == ["case_0.json", "case_0.npz"]
    words = shlex.split(line[line.index(": wheelrom ") + 2 :])
    assert words == ["wheelrom", "settle", str(cfg), "--out", str(out), "--resume"], line
    assert cli.main(words[1:]) == 0  # pasted: the file of both cases, the folder gone
    assert "kept from the interrupted run" in capsys.readouterr().err
    with h5py.File(out, "r") as f:
        assert f["settle/time"].shape == (2,)
    assert not beside.exists()


def test_a_killed_rank_leaves_rank_0_saying_what_is_kept(tmp_path, capsys):
    """mpirun -n 2, rank 1 killed (SIGKILL) in its case while rank 0, its cases finished,
    waits for it: mpirun sends the others SIGTERM and, a grace period later, SIGKILL. Rank 0
    waited for rank 1 in a blocking gather, where no signal reaches Python: it died without a
    word (and left its lock); now it waits in a polled barrier and names what is kept and the
    resume line. A handshake (tests/handshake.py) puts each rank there, whatever the speed:
    rank 1 holds in the first case it takes, rank 0 integrates its first case only once rank
    1 holds one (so it cannot take all three) and says when it reaches the barrier; rank 1 is
    killed once both have said so."""
    cfg = tmp_path / "c.toml"
    keys = [*QUICK, "sweep.shroud_angles_deg=[50.0, 60.0, 70.0]", "settle.batch=1"]
    assert cli.main(["config", "show", SMALL, *_sets(keys)]) == 0
    cfg.write_text(capsys.readouterr().out)
    out = tmp_path / "s.h5"
    held = handshake.script(tmp_path, """
        from mpi4py import MPI
        import wheelrom.studies.settle as study
        ours = MPI.COMM_WORLD.Dup()  # the handshake's messages never meet wheelrom's
        integrate, wait_for_all = study.settle_cases, study.wait_for_all
        waited = []
        def settle_cases(*args, **kwargs):
            if rank == 1:
                ours.send("rank 1 has a case", dest=0)
                hold("rank 1's case")  # until SIGKILL
            elif not waited:  # rank 0's first case
                waited.append(ours.recv(source=1))
            return integrate(*args, **kwargs)
        def waiting(comm):
            if rank == 0:
                arrived("rank 0's wait for the other ranks")
            return wait_for_all(comm)
        study.settle_cases, study.wait_for_all = settle_cases, waiting
        """)
    # mpirun's SIGKILL follows its SIGTERM after odls_base_sigkill_timeout (1 s by default):
    # rank 0 then sleeps in its polled barrier and needs milliseconds to say its line; 10 s
    # is a margin for a loaded machine that schedules it late (mpirun sleeps it out twice
    # whatever happens, which is most of this test's 23 s)
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", MPLBACKEND="Agg",
               OMPI_MCA_odls_base_sigkill_timeout="10")
    proc = subprocess.Popen(["mpirun", "-n", "2", *held, "settle", str(cfg), "--out",
                             str(out)], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL,
                            text=True, env=env)
    seen = handshake.read_until(proc, handshake.HOLDING, handshake.ARRIVED)
    os.kill(handshake.held_pid(seen), signal.SIGKILL)
    seen += proc.stderr.readlines()
    proc.wait(timeout=HANG_S)
    err = "".join(seen)
    lines = [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1 and "Traceback" not in err, err
    # rank 0 finished the two cases rank 1 did not take (which ones: the shared counter's)
    # (cases counted from 0, as in the files)
    kept = re.escape(f" of 0..2 finished and kept in {tmp_path / '.s.settle'}; to compute "
                     "only the other 1, ")
    assert re.match(rf"wheelrom: interrupted: cases (0\.\.1|0, 2|1\.\.2){kept}", lines[0]), \
        lines[0]
    assert lines[0].endswith(f": wheelrom settle {cfg} --out {out} --resume"), lines[0]
    assert len(os.listdir(tmp_path / ".s.settle")) == 4  # their .npz and .json
    assert not (tmp_path / ".s.h5.lock").exists()


def test_an_exception_on_one_rank_aborts_the_job(tmp_path):
    """mpirun -n 2, rank 1's case loop raises an unexpected error while rank 0 waits for it
    in a collective: the job ends (rank 1's traceback, exit status not 0) instead of rank 0
    waiting for ever (a settle whose rank 1 failed kept rank 0 running alone for 40 min)."""
    script = tmp_path / "one_rank_fails.py"
    script.write_text(
        "import sys\n"
        "from mpi4py import MPI\n"
        "import wheelrom.studies.settle as settle\n"
        "def run_settle(*args, **kwargs):\n"
        "    if MPI.COMM_WORLD.rank == 1:\n"
        "        raise RuntimeError('rank 1 fails here')\n"
        "    MPI.COMM_WORLD.barrier()  # waits for rank 1\n"
        "settle.run_settle = run_settle\n"
        "from wheelrom.cli.main import main\n"
        f"sys.exit(main(['settle', {SMALL!r}]))\n")
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
               OMPI_MCA_rmaps_base_oversubscribe="1", MPLBACKEND="Agg")
    done = subprocess.run(["mpirun", "-n", "2", sys.executable, str(script)], env=env,
                          capture_output=True, text=True, timeout=HANG_S)
    assert done.returncode != 0
    assert "rank 1: Traceback" in done.stderr and "rank 1 fails here" in done.stderr
