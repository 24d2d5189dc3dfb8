"""`wheelrom info FILE`: what a sweep, run --out or modes --out file holds; pending and failed
cases counted with their reasons; foreign files refused with one line naming them."""

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from conftest import HANG_S, SMALL
from wheelrom.cli import main as cli
from wheelrom.cli.output_info import LONG_LISTING, print_info
from wheelrom.results.info import file_info, resume_hint, study_flags, ts_scheme

END = ["--set", "time.end=0.001"]  # two windows of 0.5 ms: a short sweep
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
           OMPI_MCA_rmaps_base_oversubscribe="1")


def no_constants(name):
    raise AssertionError(f"bare {name} in JSON output")


def info_json(capsys, path) -> dict:
    assert cli.main(["info", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out, parse_constant=no_constants)


@pytest.fixture(scope="module")
def sweep_file(tmp_path_factory):
    """The 3-case small sweep (45 deg tie-boss; shroud 20, 50, 80 deg), 2 windows."""
    path = tmp_path_factory.mktemp("info") / "sweep.h5"
    subprocess.run([sys.executable, "-m", "wheelrom.cli.main", "sweep", SMALL, *END, "--out",
                    str(path)], env=ENV, check=True, capture_output=True, timeout=HANG_S)
    return path


def test_info_json_of_a_sweep_lists_its_cases(sweep_file, capsys):
    info = info_json(capsys, sweep_file)
    with h5py.File(sweep_file, "r") as f:
        windows_done = f["cases/windows_done"][()].tolist()
        wall = f["cases/wall_s"][()]
        source = f.attrs["config_source"]
    assert info["kind"] == "results" and info["format"] == "wheelrom-sweep-1"
    assert info["config_source"] == source and source.startswith(SMALL)
    assert info["counts"] == {"done": 3, "failed": 0, "pending": 0, "total": 3}
    assert [(c["tieboss_deg"], c["shroud_deg"]) for c in info["cases"]] == [
        (45.0, 20.0), (45.0, 50.0), (45.0, 80.0)]
    assert [c["status"] for c in info["cases"]] == ["done"] * 3
    assert [c["windows_done"] for c in info["cases"]] == windows_done == [2, 2, 2]
    assert info["windows"] == 2 and info["time_end_s"] == pytest.approx(0.001)
    assert info["window_s"] == 0.0005
    assert info["total_wall_s"] == pytest.approx(wall.sum())
    assert {c["scheme"] for c in info["cases"]} == {"rk/3bs dt=5e-06"}
    assert info["model"]["blades"] == 12 and info["model"]["modes"] == 6
    assert len(info["model"]["segment_hz"]) == 6 and info["hint"] is None


def test_info_human_output_has_a_header_and_a_line_per_case(sweep_file, capsys):
    assert cli.main(["info", str(sweep_file)]) == 0
    out = capsys.readouterr().out
    assert "wheelrom-sweep-1 results, 3 cases" in out
    assert f"config source: {SMALL}" in out
    assert "12 blades x 6 modes" in out and "end 0.001 s, window 0.0005 s (2 windows)" in out
    assert "3 done, 0 failed, 0 pending" in out
    rows = [line.split() for line in out.splitlines() if line.split()[:1] in (["0"], ["1"],
                                                                               ["2"])]
    assert [r[:5] for r in rows] == [["0", "45", "20", "done", "2/2"], ["1", "45", "50", "done",
                                     "2/2"], ["2", "45", "80", "done", "2/2"]]
    assert all(r[-2:] == ["rk/3bs", "dt=5e-06"] for r in rows)
    assert "{" not in out and "None" not in out


def test_pending_and_failed_cases_are_counted_with_reasons(sweep_file, tmp_path, capsys):
    path = tmp_path / "partial.h5"
    shutil.copy(sweep_file, path)
    with h5py.File(path, "r+") as f:
        f["cases/status"][0] = b"failed: diverged at t = 0.0004 s (amplitude 2 m)"
        f["cases/status"][2] = b"pending"
        f["cases/windows_done"][2] = 0
        f["cases/wall_s"][2] = np.nan
    info = info_json(capsys, path)
    assert info["counts"] == {"done": 1, "failed": 1, "pending": 1, "total": 3}
    failed, pending = info["cases"][0], info["cases"][2]
    assert failed["status"] == "failed"
    assert failed["reason"] == "diverged at t = 0.0004 s (amplitude 2 m)"
    assert pending["status"] == "pending" and pending["wall_s"] is None
    # the sweep was configured with --set: the hint names the configuration to use again
    assert "1 case(s) pending: rerun the sweep with --resume" in info["hint"]
    assert info["config_source"] in info["hint"] and "1 case(s) failed" in info["hint"]
    assert cli.main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "1 done, 1 failed, 1 pending" in out and "rerun the sweep with --resume" in out
    assert "diverged at t = 0.0004 s" in out


def test_a_long_sweep_lists_its_ends_and_failed_cases(sweep_file, capsys):
    info = file_info(str(sweep_file))
    count = LONG_LISTING + 20
    info["cases"] = [dict(info["cases"][0], index=i, shroud_deg=float(i)) for i in range(count)]
    info["cases"][30] |= {"status": "failed", "reason": "TS diverged"}
    info["counts"] = {"done": count - 1, "failed": 1, "pending": 0, "total": count}
    print_info(info)
    out = capsys.readouterr().out.splitlines()
    listed = [int(line.split()[0]) for line in out if line.split()[0].isdigit()]
    assert listed == [0, 1, 2, 3, 4, 30, count - 5, count - 4, count - 3, count - 2, count - 1]
    assert any("25 case(s) not shown (--all" in line for line in out)
    assert any(line.split()[:2] == ["30", "45"] and "TS diverged" in line for line in out)
    print_info(info, show_all=True)
    listed = [line for line in capsys.readouterr().out.splitlines() if line.split()[0].isdigit()]
    assert len(listed) == count


def test_info_of_a_run_out_file(tmp_path, capsys, small_cfg):
    path = tmp_path / "run.h5"
    assert cli.main(["run", SMALL, *END, "--json", "--out", str(path)]) == 0
    capsys.readouterr()
    info = info_json(capsys, path)
    assert info["counts"] == {"done": 1, "failed": 0, "pending": 0, "total": 1}
    (case,) = info["cases"]
    assert case["tieboss_deg"] == small_cfg.contacts.tieboss.angle_deg
    assert case["shroud_deg"] == small_cfg.contacts.shroud.angle_deg
    assert case["windows_done"] == info["windows"] == 2 and case["batch"] == 1


def test_info_of_a_model_file_says_what_it_holds(tmp_path, capsys):
    path = tmp_path / "model.h5"
    assert cli.main(["modes", SMALL, "--json", "--out", str(path)]) == 0
    hz = json.loads(capsys.readouterr().out)["segment_hz"]
    info = info_json(capsys, path)
    assert info["kind"] == "model" and "cases" not in info
    model = info["model"]
    assert model["blades"] == 12 and model["modes"] == 6 and model["nodal_diameters"] == 7
    np.testing.assert_allclose(model["segment_hz"], hz, rtol=1e-12)
    assert "wheel_hz" in model["extras"] and "full_wheel_hz" not in model["extras"]
    assert cli.main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "reduced model (modes --out)" in out and "12 blades x 6 modes" in out
    assert f"{hz[0]:.4g}" in out and "ND 0..6 x 6 families" in out


@pytest.mark.parametrize("kind", ["missing", "text", "foreign_hdf5"])
def test_a_file_not_made_by_wheelrom_is_one_line_exit_2(kind, tmp_path, capsys):
    path = tmp_path / f"{kind}.h5"
    if kind == "text":
        path.write_text("not HDF5\n")
    elif kind == "foreign_hdf5":
        with h5py.File(path, "w") as f:
            f["x"] = np.arange(3)
    assert cli.main(["info", str(path), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"wheelrom: {path}: ")
    expected = {"missing": "no such file", "text": "not an HDF5 file",
                "foreign_hdf5": "not a wheelrom results or model file"}
    assert expected[kind] in lines[0]


@pytest.mark.parametrize("command, extra", [("info", []), ("info", ["--json"]), ("plot", []),
                                            ("export", ["--csv", "x"]), ("animate", [])])
def test_a_directory_is_one_line_naming_it(command, extra, tmp_path, capsys):
    """`info` and `plot` printed HDF5's two-line dump of its read call, `export` and `animate`
    said "no such file": each says what the path is, exit 2, nothing written."""
    folder = tmp_path / "results.h5"
    folder.mkdir()
    extra = [str(tmp_path / e) if e == "x" else e for e in extra]
    assert cli.main([command, str(folder), *extra]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == f"wheelrom: {folder} is a directory, not a wheelrom results file\n"
    assert sorted(os.listdir(tmp_path)) == ["results.h5"]


def test_ts_scheme_names_the_method_step_and_adaptor():
    assert ts_scheme({"ts_type": "rk", "ts_rk_type": "3bs", "ts_dt": 5e-06,
                      "ts_adapt_type": "none"}) == "rk/3bs dt=5e-06"
    assert ts_scheme({"ts_type": "rk", "ts_rk_type": "5dp", "ts_dt": 1e-05,
                      "ts_adapt_type": "basic", "ts_rtol": "1e-6"}) == \
        "rk/5dp dt=1e-05 adapt=basic rtol=1e-6"
    assert ts_scheme({}) == "-"


def test_resume_hint_gives_the_command_for_a_plain_configuration():
    counts = {"done": 1, "failed": 0, "pending": 2, "total": 3}
    assert resume_hint("s.h5", "run/paper.toml", counts) == (
        "2 case(s) pending: rerun the sweep with --resume: "
        "wheelrom sweep run/paper.toml --out s.h5 --resume")
    assert resume_hint("s.h5", "<built-in default>", counts).endswith(
        "wheelrom sweep --out s.h5 --resume")
    assert resume_hint("s.h5", "a.toml", dict(counts, pending=0)) is None


def test_resume_hint_of_a_study_repeats_its_mode_and_forced():
    counts = {"pending": 3, "failed": 0}
    flags = study_flags("screen", True)
    assert resume_hint("m.h5", "map.toml", counts, "study", flags) == (
        "3 case(s) pending: rerun the study with --screen --forced --resume: "
        "wheelrom study map.toml --out m.h5 --screen --forced --resume")
    assert study_flags("full", False) == ""


def _flip_byte(path, offset: int) -> None:
    with open(path, "r+b") as fh:
        fh.seek(offset)
        byte = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([byte[0] ^ 0x10]))


@pytest.mark.parametrize("dataset", ["max_tip_amplitude", "tip_history"])
def test_info_verify_finds_a_flipped_byte(dataset, tmp_path, capsys):
    """Issue #40: `info --verify` recomputes each written case's CRC-32 and names the case
    whose stored numbers changed (a contiguous dataset and a chunked history), exit 1."""
    out = tmp_path / "r.h5"
    keys = ["--set", "time.end=0.001", "--set", "sweep.shroud_angles_deg=[20.0, 80.0]"]
    assert cli.main(["sweep", SMALL, *keys, "--out", str(out)]) == 0
    capsys.readouterr()
    assert cli.main(["info", str(out), "--verify", "--json"]) == 0
    checks = json.loads(capsys.readouterr().out)["checksums"]
    assert checks == {"stored": True, "checked": 2, "mismatched": [], "scope": "cases"}
    bad = tmp_path / "copy.h5"
    shutil.copy(out, bad)
    with h5py.File(bad, "r") as f:
        d = f[f"cases/{dataset}"]
        if d.chunks:  # case 1's first chunk
            offset = d.id.get_chunk_info_by_coord((1,) + (0,) * (d.ndim - 1)).byte_offset
        else:  # case 1's row: one row of doubles past the start
            offset = d.id.get_offset() + int(np.prod(d.shape[1:])) * d.dtype.itemsize
    _flip_byte(bad, offset + 3)
    assert cli.main(["info", str(bad), "--verify"]) == 1
    captured = capsys.readouterr()
    assert "CHANGED since written: 1" in captured.out
    assert "case(s) 1 changed since they were written" in captured.err
    assert cli.main(["info", str(bad)]) == 0  # without --verify: nothing read, nothing said


#: the files written in one piece: the command, and per dataset flipped its row and how
#: `info --verify` names it
ONE_PIECE = {
    "stability": (["stability", SMALL],
                  {"stability/growth_rate": (1, "case 1 (stability/growth_rate)")}),
    "forced-response": (["forced-response", SMALL, "--frequencies", "380:395:4"],
                        {"blade_amplitude": (2, "blade_amplitude")}),
    "modes": (["modes", SMALL], {"model/wheel_hz": (5, "model/wheel_hz")}),
    "study": (["study", SMALL, "--stability-only", "--set",
               'study.grid={"contacts.shroud.angle_deg" = [20.0, 80.0]}'],
              {"stability/max_growth_rate": (1, "case 1 (stability/max_growth_rate)"),
               "models/0/A0": (0, "models/0/A0")}),
}


@pytest.mark.parametrize("kind", ONE_PIECE)
def test_info_verify_checks_a_file_written_in_one_piece(kind, tmp_path, capsys):
    """Issue 47: `info --verify` exited 0 on a changed value of a stability, forced-response
    or model file without saying nothing was checked (checksums were a sweep's only). Every
    dataset (row) and attribute has one: a flipped bit is named, exit 1; a changed attribute
    too; a file without them says so, exit 0."""
    from test_periodic_files import check_verify, verify

    argv, flips = ONE_PIECE[kind]
    path = tmp_path / f"{kind}.h5"
    assert cli.main([*argv, "--json", "--out", str(path)]) == 0
    capsys.readouterr()
    check_verify(path, flips, tmp_path, capsys)
    with h5py.File(path, "r+") as f:
        f.attrs["config_source"] = "somewhere else"
    status, out, _ = verify(path, capsys)
    assert status == 1 and "CHANGED since written: @config_source" in out, out
