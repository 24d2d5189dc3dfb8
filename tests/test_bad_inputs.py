"""Bad input is one line before anything is computed, and a full disk loses nothing (issue
#40, defects 4, 7 and 8): limitcycle_ PETSc options checked up front, out-of-range times,
preloads, angles and frequency counts, a NaN mesh node, a device as an input file, stray
tokens after --, and stability / modes on a full disk."""

import errno
import json
import os

import h5py
import pytest

from conftest import SMALL
from wheelrom.cli import main as cli

QUICK = ["--set", "time.end=0.001", "--set", "time.window=0.0005"]


def _error_lines(capsys):
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    return [ln for ln in err.splitlines() if ln.startswith("wheelrom:")]


def _refused(capsys, argv, *words):
    assert cli.main(argv) == 2
    lines = _error_lines(capsys)
    assert len(lines) == 1, lines
    for word in words:
        assert word in lines[0], lines[0]


# --- defect 7: limitcycle_ options --------------------------------------------------


@pytest.mark.parametrize("option, words", [
    (["-limitcycle_snes_max_it", "-3"], ["-limitcycle_snes_max_it -3", "SNES 'limitcycle_'",
                                         "out of range"]),
    (["-limitcycle_snes_type", "nosuch"], ["-limitcycle_snes_type nosuch", "unknown type"]),
    (["-limitcycle_shooting_snes_rtol", "-1"], ["-limitcycle_shooting_snes_rtol -1",
                                                "'limitcycle_shooting_'"]),
    (["-limitcycle_floquet_eps_type", "nosuch"], ["-limitcycle_floquet_eps_type nosuch",
                                                  "EPS 'limitcycle_floquet_'"]),
])
def test_bad_limitcycle_option_is_refused_before_computing(option, words, capsys,
                                                           nothing_computed):
    from wheelrom.runtime.environment import petsc

    db = petsc().Options()
    try:
        _refused(capsys, ["limit-cycle", SMALL, "--", *option], *words)
    finally:
        db.delValue(option[0].lstrip("-"))


# --- defect 8: one line instead of a traceback -------------------------------------


@pytest.mark.parametrize("value, words", [
    ("0", ["time.end", "must be > 0"]),
    ("1e300", ["time.end", "must be <="]),
])
def test_time_end_out_of_range_is_one_line(value, words, capsys, nothing_computed):
    assert cli.main(["run", SMALL, "--set", f"time.end={value}"]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and all(w in err for w in words), err


def test_huge_normal_preload_is_refused(capsys, nothing_computed):
    assert cli.main(["stability", SMALL, "--set", "contacts.shroud.normal_preload=1e308"]) == 2
    err = capsys.readouterr().err
    assert "contacts.shroud.normal_preload: must be <=" in err and "Warning" not in err, err


def test_mesh_node_with_nan_coordinate_is_named(tmp_path, capsys):
    assert cli.main(["mesh", SMALL, "--out", str(tmp_path / "seg.inp")]) == 0
    lines = (tmp_path / "seg.inp").read_text().splitlines()
    at = lines.index("*NODE") + 3  # the third node
    node, _, y, z = lines[at].split(",")
    lines[at] = f"{node}, nan,{y},{z}"
    (tmp_path / "nan.inp").write_text("\n".join(lines) + "\n")
    cfg = tmp_path / "c.toml"
    cfg.write_text('[wheel]\nblades = 12\n[segment]\nsource = "nan.inp"\n')
    capsys.readouterr()
    _refused(capsys, ["config", "check", str(cfg)], "nan.inp", "node 3", "not a finite number")


def test_a_device_as_mistuning_file_is_refused(capsys, nothing_computed):
    assert cli.main(["run", SMALL, "--set", 'mistuning.file="/dev/zero"']) == 2
    err = capsys.readouterr().err
    assert "mistuning.file: /dev/zero: is not a regular file" in err, err


@pytest.mark.parametrize("angle", ["nan", "120", "-30"])
def test_forced_angle_outside_0_90_is_refused(angle, capsys, nothing_computed):
    _refused(capsys, ["forced-response", SMALL, "--angle", "shroud", angle],
             f"--angle shroud {angle}", "contacts.shroud.angle_deg")


def test_forced_frequency_count_is_bounded(capsys, nothing_computed):
    _refused(capsys, ["forced-response", SMALL, "--frequencies", "100:120:100000000"],
             "100000000 values", "at most 100000")


@pytest.mark.parametrize("tokens, words", [
    (["garbage"], ["'garbage' is neither an option"]),
    (["-wheel_ts_dt"], ["-wheel_ts_dt: needs a value"]),
])
def test_stray_petsc_tokens_are_refused(tokens, words, capsys, nothing_computed):
    from wheelrom.runtime.environment import petsc

    try:
        _refused(capsys, ["run", SMALL, *QUICK, "--", *tokens], *words)
    finally:
        for t in tokens:
            if t.startswith("-"):
                petsc().Options().delValue(t.lstrip("-"))


# --- defect 4: a full disk keeps what was computed ---------------------------------


@pytest.fixture
def full_disk(tmp_path, monkeypatch):
    """Every write into ``tmp_path/out`` fails with ENOSPC; ``tmp_path/tmp`` is $TMPDIR."""
    import tempfile

    from wheelrom.runtime import outputs

    out, spare = tmp_path / "out", tmp_path / "tmp"
    out.mkdir()
    spare.mkdir()
    real = outputs.write_image

    def write(path, data):
        if os.path.dirname(os.path.abspath(path)) == str(out):
            with open(path, "wb") as fh:  # a part of it, as a disk that fills
                fh.write(data[:100])
            raise OSError(errno.ENOSPC, "No space left on device")
        real(path, data)

    monkeypatch.setattr(outputs, "write_image", write)
    monkeypatch.setattr(tempfile, "tempdir", str(spare))
    return out, spare


@pytest.mark.parametrize("command", ["stability", "modes", "forced-response"])
def test_full_disk_keeps_the_results_elsewhere(command, full_disk, capsys):
    out, spare = full_disk
    path = out / f"{command}.h5"
    extra = ["--frequencies", "250:259:3"] if command == "forced-response" else []
    assert cli.main([command, SMALL, "--out", str(path), "--json", *extra]) == 1
    captured = capsys.readouterr()
    json.loads(captured.out)  # the numbers are printed
    assert "Traceback" not in captured.err
    lines = [ln for ln in captured.err.splitlines() if ln.startswith("wheelrom:")]
    assert len(lines) == 1, captured.err
    (kept,) = os.listdir(spare)
    assert lines[0] == (
        f"wheelrom: {path}: the disk is full (errno 28, ENOSPC: No space left on device; "
        f"{lines[0].split('; ')[1].split(' free')[0]} free in '{out}'); the results are kept "
        f"in {spare / kept} (move it there once space is freed); the "
        + {"stability": "summary is", "modes": "frequencies are",
           "forced-response": "response is"}[command] + " printed above")
    assert not os.listdir(out)  # no half file, no temporary
    with h5py.File(spare / kept, "r") as f:  # the whole results file
        assert f.attrs["config"]


def test_version_and_the_nd_list(capsys):
    """``--version`` answers; ``--nd -1`` is the fastest wave as ``limit_cycle.waves = [-1]``;
    an empty item in ``--nd 5,,6`` is refused, not skipped."""
    from wheelrom import __version__
    from wheelrom.cli import main as cli_main
    from wheelrom.cli.limit_cycle import _waves
    from wheelrom.runtime.errors import InputError

    with pytest.raises(SystemExit) as stop:
        cli_main.main(["--version"])
    assert stop.value.code == 0 and __version__ in capsys.readouterr().out
    assert _waves("-1") == _waves("fastest") == (-1,)
    assert _waves("5, 33") == (5, 33)
    for bad in ("5,,6", "", "-2", "x"):
        with pytest.raises(InputError, match="--nd"):
            _waves(bad)


def test_a_sweep_angle_listed_twice_is_refused(capsys):
    from conftest import SMALL
    from wheelrom.cli import main as cli_main

    assert cli_main.main(["config", "check", SMALL, "--set",
                          "sweep.shroud_angles_deg=[50.0, 60.0, 50.0]"]) == 2
    assert "sweep.shroud_angles_deg: [50.0] listed more than once" in capsys.readouterr().err


def test_a_mode_family_past_a_free_basis_is_refused_before_computing(capsys,
                                                                     nothing_computed):
    assert cli.main(["forced-response", SMALL, "--set", "forced.family=6"]) == 2
    err = capsys.readouterr().err
    assert "forced.family: 6 is not below wheel.modes_per_segment (6)" in err, err


def test_an_attachment_basis_reaches_its_families(capsys):
    """With attachment vectors the model holds more families than
    ``wheel.modes_per_segment``: those are accepted, one past the model is refused in one
    line."""
    attachment = ["--set", 'wheel.basis="attachment"', "--json", "--frequencies", "1:2:2"]
    _refused(capsys, ["forced-response", SMALL, "--set", "forced.family=40"] + attachment[:2],
             "forced.family = 40: the model has", "mode families")
    assert cli.main(["forced-response", SMALL, "--set", "forced.family=7"] + attachment) == 0
