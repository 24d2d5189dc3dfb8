"""Every bad input one line, one rule per kind (issue #72): what sizes an allocation is
checked against the memory (or a cap) before anything is computed; every numeric key and
option has a physical range and the configuration's caps apply to the options that set a
key; ``--set`` of a whole table is merged into its section; no numpy ``RuntimeWarning``
reaches the user; a message names the key or option the user gave."""

import contextlib
import io
import json
import os
import subprocess
import sys
import tempfile

import h5py
import pytest

from conftest import SMALL
from wheelrom.cli import main as cli


@pytest.fixture
def eight_gb(monkeypatch):
    """8 GB of memory available, whatever the machine has."""
    monkeypatch.setattr("wheelrom.runtime.environment.available_memory", lambda: 8 * 10**9)


def _refused(capsys, argv, words, absent=()):
    """``argv`` exits 2 with the words in its message (one ``wheelrom:`` line, or a
    configuration's problem lines), no traceback, no warning, none of ``absent``."""
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "Warning" not in err, err[:3000]
    assert err.startswith("wheelrom: ") and len(err) < 1000, err[:3000]
    for word in words:
        assert word in err, err
    for word in absent:
        assert word not in err, err
    return err


# --- rule 1: what sizes an allocation is checked against the memory, or capped --------


@pytest.mark.parametrize("argv, words", [
    # item 3: 64 GiB of window samples was numpy's traceback
    (["run", SMALL, "--set", "time.window=10000", "--set", "time.end=10000"],
     ["time.window 10000 s at output.sample_rate_hz 20000 Hz", "would need about",
      "8.0 GB is available", "shorten time.window"]),
    (["run", SMALL, "--set", "time.window=0.5", "--set", "time.end=10000", "--set",
      "output.history_rate_hz=20000"], ["time.end 10000 s at output.history_rate_hz 20000 Hz",
                                        "shorten time.end"]),
    # item 6: the dense K_R of 1000 blades x 200 vectors, (2e5)^2 doubles three times
    (["run", SMALL, "--set", "wheel.blades=1000", "--set", "wheel.modes_per_segment=200"],
     ["wheel.blades 1000 with 200 basis vectors each", "960.0 GB"]),
    (["sweep", SMALL, "--out", "OUT", "--set", "time.window=100", "--set", "time.end=10000"],
     ["time.end 10000 s", "for 3 cases at once"]),
    (["study", SMALL, "--out", "OUT", "--set", "time.window=10000", "--set", "time.end=10000"],
     ["time.window 10000 s"]),
    (["compare", SMALL, "--steps", "1000000000"], ["compare --steps 1000000000 would need"]),
    # second pass: the nonlinear curve's harmonics and Jacobians, (129 x 200)^2 doubles
    (["forced-response", SMALL, "--nonlinear", "--harmonics", "64", "--frequencies",
      "100:200:100000", "--set", "wheel.modes_per_segment=200"],
     ["--nonlinear at H = 64 over 100000 frequencies of 200 basis vectors would need"]),
    (["study", SMALL, "--out", "OUT", "--stability-only", "--forced-nonlinear", "--set",
      "forced.harmonics=64", "--set", "wheel.modes_per_segment=200"],
     ["study --forced-nonlinear at forced.harmonics 64 over forced.points 41 would need"]),
])
def test_what_sizes_the_memory_is_refused_up_front(argv, words, capsys, tmp_path,
                                                   nothing_computed, eight_gb):
    argv = [str(tmp_path / "x.h5") if a == "OUT" else a for a in argv]
    _refused(capsys, argv, words)
    assert not (tmp_path / "x.h5").exists()


def test_a_batch_is_sized_by_the_cases_it_can_hold(tmp_path, capsys, nothing_computed,
                                                   eight_gb):
    """Second pass: ``study --batch 1000000000`` was refused as "1000000000 cases at once"
    though the study has 3: the check passes and the study starts computing (its model
    build is where this test stops it)."""
    argv = ["study", SMALL, "--out", str(tmp_path / "x.h5"), "--batch", "1000000000"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "a segment was built" in err and "memory" not in err, err


@pytest.mark.parametrize("argv, words", [
    # item 4: H = 1000 allocated 717 GiB; forced.harmonics' cap is the option's
    (["forced-response", SMALL, "--nonlinear", "--harmonics", "1000"],
     ["--harmonics 1000: must be <= 64", "forced.harmonics"]),
    # item 8: 1e8 speeds ran for hours
    (["campbell", SMALL, "--speeds", "0:60:100000000"],
     ["--speeds 0:60:100000000: 100000000 values", "at most 1000"]),
    (["campbell", SMALL, "--speeds", ",".join(map(str, range(1001)))], ["at most 1000"]),
    # item 6: 1e23 blades passed config check
    (["config", "check", SMALL, "--set", "wheel.blades=100000000000000000000000"],
     ["wheel.blades: must be <= 1000"]),
    (["run", SMALL, "--set", "wheel.blades=1000000"], ["wheel.blades: must be <= 1000"]),
    (["config", "check", SMALL, "--set", "time.end=10", "--set", "time.window=1e-6",
      "--set", "time.step=1e-7", "--set", "output.sample_rate_hz=1e7"],
     ["time.window", "1e+07 windows; at most 1000000"]),
])
def test_a_count_beyond_its_cap_is_refused(argv, words, capsys, tmp_path, nothing_computed):
    _refused(capsys, [*argv, "--outdir", str(tmp_path)] if argv[0] == "campbell" else argv,
             words)


# --- rule 2: physical ranges, and the configuration's caps on the options -------------


@pytest.mark.parametrize("argv, words, absent", [
    # item 12
    (["config", "check", SMALL, "--set", "excitation.force=1e30"],
     ["excitation.force: must be <= 1e+06 N"], []),
    (["config", "check", SMALL, "--set", "wheel.speed_hz=1e9"],
     ["wheel.speed_hz: must be <= 1000.0 Hz"], []),
    (["config", "check", SMALL, "--set", "contacts.law=elastic", "--set",
      "contacts.shroud.tangential_stiffness=1e30"],
     ["contacts.shroud.tangential_stiffness: must be <= 1e+10 N/m"], []),
    (["config", "check", SMALL, "--set", "contacts.tieboss.stiffness=[[0.0, 1e8], [90.0, 1e12]]"],
     ["contacts.tieboss.stiffness[1][1]: must be <= 1e+10 N/m"], []),
    # item 13
    (["config", "check", SMALL, "--set", "time.perturbation_waves=[12]"],
     ["time.perturbation_waves: [12] not below wheel.blades = 12"], []),
    (["config", "check", SMALL, "--set", "time.perturbation_waves=[3, 3]"],
     ["time.perturbation_waves: [3] listed more than once"], []),
    # item 5: zero-size array
    (["forced-response", SMALL, "--nonlinear", "--set", "forced.points=0"],
     ["forced.points = 0 leaves no grid frequency"], []),
    # item 7: IndexError after computing
    (["campbell", SMALL, "--speeds", "0:60:0"], ["--speeds 0:60:0: N must be >= 1"], []),
    (["campbell", SMALL, "--speeds", "0:60:1"], ["1 exactly when A = B"], []),
    # item 8: reversed
    (["campbell", SMALL, "--speeds", "60:0:3"], ["--speeds 60:0:3: expected 0 <= A <= B"], []),
    (["campbell", SMALL, "--speeds", "0,60,30"], ["increasing order"], []),
    # item 19: the option named, not time.end or wheel.speed_hz
    (["campbell", SMALL, "--speeds=-10:60:3"], ["--speeds -10:60:3"],
     ["wheel.speed_hz", "time.end"]),
    (["compare", SMALL, "--steps", str(10**21)],
     [f"compare --steps {10**21}: must be <= 10000.0 s",
      "(the range of time.end and time.window, which it sets)"],
     ["invalid configuration"]),
    (["campbell", SMALL, "--speeds", "0:2000:3"],
     ["--speeds 0:2000:3: must be <= 1000.0 Hz", "wheel.speed_hz, which it sets"], []),
    (["forced-response", SMALL, "--speeds", "0:2000:3"],
     ["--speeds 0:2000:3: must be <= 1000.0 Hz"], []),
    (["forced-response", SMALL, "--frequencies", "0:2e6:3"],
     ["--frequencies 0:2e6:3: must be <= 1e+06 Hz", "forced.band_hz[1]"], []),
    # item 23: an option silently unused
    (["forced-response", SMALL, "--set", "contacts.shroud.enabled=false", "--angle", "shroud",
      "30"], ["--angle shroud 30: contacts.shroud.enabled is false"], []),
    (["forced-response", SMALL, "--angle", "shroud", "30", "--angle", "shroud", "40"],
     ["--angle shroud given twice"], []),
    (["forced-response", SMALL, "--harmonics", "3"], ["give --nonlinear too"], []),
    # item 11: stored as every case's failure, exit 0
    (["study", SMALL, "--forced-nonlinear", "--stability-only", "--out", "OUT", "--set",
      "excitation.force=0"],
     ["study --forced-nonlinear, every case: excitation.force = 0"], []),
    (["study", SMALL, "--forced-nonlinear", "--stability-only", "--out", "OUT", "--set",
      "mistuning.std=0.01"], ["needs a tuned wheel"], []),
    # second pass: "amplification: no case", exit 0
    (["study", SMALL, "--forced", "--stability-only", "--out", "OUT", "--set",
      "excitation.force=0"], ["study --forced, every case: excitation.force = 0"], []),
    (["study", SMALL, "--forced", "--stability-only", "--out", "OUT", "--set",
      'study.grid={"excitation.force"=[100.0, 0.0]}'],
     ["study --forced, case 1 (excitation.force=0): excitation.force = 0"], []),
    # second pass: "study batch must be >= 0", an option named as no option is
    (["study", SMALL, "--stability-only", "--out", "OUT", "--batch", "-1"],
     ["--batch -1: must be >= 0"], ["study batch"]),
    (["sweep", SMALL, "--out", "OUT", "--batch", "-1"], ["--batch -1: must be >= 0"],
     ["sweep batch"]),
    # second pass: the nonlinear response computed with the contacts --no-contacts left out
    (["forced-response", SMALL, "--nonlinear", "--no-contacts"],
     ["--no-contacts leaves the contacts out of the linear response only"], []),
])
def test_out_of_range_is_one_line_before_computing(argv, words, absent, capsys, tmp_path,
                                                   nothing_computed):
    argv = [str(tmp_path / "x.h5") if a == "OUT" else a for a in argv]
    if argv[0] == "campbell":
        argv += ["--outdir", str(tmp_path)]
    _refused(capsys, argv, words, absent)
    assert not (tmp_path / "x.h5").exists()


def test_a_speed_beyond_small_strain_is_refused(capsys, tmp_path, monkeypatch):
    """Item 12: at 1e9 Hz the prestress "moved" 1.2e15 mm and every frequency was 0 Hz. A
    speed whose centrifugal displacement exceeds 1 % of the radius (steel yields below) is
    refused naming the key; campbell names --speeds and computes no speed before."""
    assert cli.main(["modes", SMALL, "--json", "--set", "wheel.speed_hz=300"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("wheelrom: wheel.speed_hz 300 Hz: the centrifugal displacement "), err
    assert "% of the wheel's 2.2 m radius, beyond small-strain elasticity" in err, err
    from wheelrom.rom import campbell

    built = []
    real = campbell.build_model
    monkeypatch.setattr(campbell, "build_model", lambda cfg, *a, **k: (
        built.append(cfg.wheel.speed_hz), real(cfg, *a, **k))[1])
    assert cli.main(["campbell", SMALL, "--json", "--speeds", "0:300:4", "--outdir",
                     str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("wheelrom: --speeds 0:300:4: at 300 Hz the centrifugal "), err
    assert built == [300.0] and not os.listdir(tmp_path)


def test_a_one_point_grid_keeps_its_band(capsys):
    """Item 15: ``--frequencies 110:130:1`` searched 110..110 Hz. The band is A..B whatever
    the grid; its refined peak (grid-independent) is the one of a 5-point grid, at the
    slipping resonance (120.02 Hz) inside the band."""
    common = ["forced-response", SMALL, "--no-contacts", "--json"]
    peaks = []
    for grid in ("110:130:1", "110:130:5"):
        assert cli.main([*common, "--frequencies", grid]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["band_hz"] == [110.0, 130.0]
        peaks.append(out["peak_frequency_hz"])
    assert 110.0 < peaks[0] < 130.0
    assert peaks[0] == pytest.approx(peaks[1], rel=1e-9)


# --- rule 3: --set of a whole table is merged ------------------------------------------


def test_set_of_a_table_merges_into_its_section(tmp_path):
    """Item 14: ``--set 'time={end=1.0}'`` replaced [time]: scheme, step and window went
    back to their defaults. A table merges key by key, nested tables too."""
    from wheelrom import config

    cfg = config.load(SMALL, ["time={end=1.0}"])
    assert (cfg.time.end, cfg.time.scheme, cfg.time.step, cfg.time.window) == \
        (1.0, "rk", 5e-6, 5e-4)
    toml = tmp_path / "c.toml"
    toml.write_text(open(SMALL).read() + "\n[contacts.shroud]\nnormal_preload = 300.0\n"
                    '[study.grid]\n"contacts.shroud.angle_deg" = [20.0, 50.0]\n')
    cfg = config.load(toml, ["contacts={shroud={angle_deg=30.0}}",
                             'study.grid={"contacts.tieboss.angle_deg"=[40.0]}'])
    assert (cfg.contacts.shroud.angle_deg, cfg.contacts.shroud.normal_preload) == (30.0, 300.0)
    assert cfg.contacts.shroud.height == 2.18  # the shroud's own default, not the tie-boss's
    assert dict(cfg.study.grid) == {"contacts.shroud.angle_deg": (20.0, 50.0),
                                    "contacts.tieboss.angle_deg": (40.0,)}
    # a value replaced by a later --set of its table, in order
    assert config.load(SMALL, ["time.end=0.5", "time={end=0.25}"]).time.end == 0.25


# --- rule 4: no numpy RuntimeWarning reaches the user ------------------------------------

#: forced-response --nonlinear with the nozzle force of issue #72 (1e30 N) put past the range
#: check: the balance overflows in numpy ("invalid value encountered in subtract")
HUGE_FORCE = """
import dataclasses, sys
from wheelrom.cli import main as cli
from wheelrom.studies import forced_nonlinear
real = forced_nonlinear.forced_inputs
def huge(*args, **kwargs):
    params, q = real(*args, **kwargs)
    return dataclasses.replace(params, nozzle_force=1e30), q
forced_nonlinear.forced_inputs = huge
sys.exit(cli.main(["forced-response", sys.argv[1], "--nonlinear", "--frequencies",
                   "118:120:3"]))
"""


def test_numpy_runtime_warnings_never_reach_stderr():
    """Item 12: raw ``RuntimeWarning`` lines with numpy's source lines were printed; the
    command's own line says what failed ("no solution")."""
    done = subprocess.run([sys.executable, "-c", HUGE_FORCE, SMALL], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "Warning" not in done.stderr, done.stderr[-3000:]
    unsolved = [line.split()[0] for line in done.stdout.splitlines()
                if line.split()[2:] == ["no", "solution"]]
    assert unsolved == ["118.0000", "119.0000", "120.0000"], done.stdout


# --- rule 5: the message names what the user gave ----------------------------------------


@pytest.mark.parametrize("key, extra", [
    ("segment.source", ""), ("mistuning.file", ""), ("study.cases", ""),
    ("flutter.table", 'model = "table"\n'),
])
def test_a_huge_path_value_is_not_quoted_back(key, extra, tmp_path, capsys, nothing_computed):
    """Item 21: a 1 MB "path" came back whole on stderr (segment.source) or as 1000
    characters with the problem line's doubled length (the others). No file name is longer
    than 4096 characters: refused with the configuration, quoted cut."""
    section, name = key.split(".")
    toml = tmp_path / "c.toml"
    toml.write_text(f'[{section}]\n{name} = "{"a" * 1_000_000}"\n{extra}')
    err = _refused(capsys, ["config", "check", str(toml)],
                   [f"{key}: 'aaaa", "... (1000000 characters) is no file name (a path has "
                    "at most 4096 characters)"])
    assert len(err) < 400, err


@pytest.mark.parametrize("fmt, kind", [
    ("wheelrom-stability-1", "stability"), ("wheelrom-forced-1", "forced-response"),
    ("wheelrom-settle-1", "settle"), ("wheelrom-limit-cycle-1", "limit-cycle"),
])
@pytest.mark.parametrize("command", ["export", "animate", "contacts"])
def test_a_file_of_another_kind_is_named_for_what_it_is(fmt, kind, command, tmp_path, capsys):
    """Item 24: "not a wheelrom results file" for a stability, forced, settle or limit-cycle
    file: it is one, just not one of cases with transients."""
    from wheelrom.results.info import KIND_OF_FORMAT

    assert KIND_OF_FORMAT[fmt] == kind  # the formats as the writers name them
    path = tmp_path / "f.h5"
    with h5py.File(path, "w") as f:
        f.attrs["format"] = fmt
        f.create_group(kind.replace("-", "_"))
    argv = [command, str(path)] + (["--csv", str(tmp_path / "x")] if command == "export"
                                   else [])
    _refused(capsys, argv, [f"{path} is a {kind} file (format {fmt!r}): {command} reads the "
                            "cases of a sweep or run results ('wheelrom-sweep-1')"],
             ["not a wheelrom results file"])


def _as_another_user(argv: list[str]) -> tuple[int, str]:
    """``(status, stderr)`` of ``cli.main(argv)`` run by a user other than the files' owner:
    as root, in a forked child that became ``nobody`` (root reads every file)."""
    if os.geteuid() != 0:
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            return cli.main(argv), err.getvalue()
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        status = 99
        try:
            os.close(read)
            os.setgid(65534)
            os.setuid(65534)
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                status = cli.main(argv)
            os.write(write, err.getvalue().encode())
        except BaseException as exc:  # noqa: BLE001 -- reported to the parent, then exit
            os.write(write, f"child failed: {exc!r}".encode())
        finally:
            os._exit(status)
    os.close(write)
    with os.fdopen(read) as fh:
        text = fh.read()
    _, code = os.waitpid(pid, 0)
    return os.waitstatus_to_exitcode(code), text


@pytest.mark.parametrize("command", [["info"], ["export", "--csv", "X"], ["plot", "--outdir",
                                                                          "X"], ["animate"]])
def test_a_file_this_user_may_not_read_is_said_so(command):
    """Item 25: another user's mode-0600 file was "cannot be read as HDF5, not a wheelrom
    ... file" (its content was never seen)."""
    folder = tempfile.mkdtemp()  # /tmp, which every user may enter
    try:
        os.chmod(folder, 0o755)
        path = os.path.join(folder, "r.h5")
        with h5py.File(path, "w") as f:
            f.attrs["format"] = "wheelrom-stability-1"
        os.chmod(path, 0o000 if os.geteuid() else 0o600)
        argv = [command[0], path] + [os.path.join(folder, a) if a == "X" else a
                                     for a in command[1:]]
        status, err = _as_another_user(argv)
        assert (status, err) == (2, f"wheelrom: {path}: not readable by this user "
                                    "(permission denied)\n")
    finally:
        os.chmod(path, 0o600)
        os.remove(path)
        os.rmdir(folder)
