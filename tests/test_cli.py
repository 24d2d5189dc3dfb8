"""Commands through the CLI: compare, modes --out/--vtu, run --out with a short last window."""

import json

import h5py
import numpy as np
import pytest

from conftest import HANG_S, SMALL
from wheelrom.cli import main as cli


def test_compare_command_agrees_with_the_reference(capsys):
    assert cli.main(["compare", SMALL, "--steps", "200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["steps"] == 200 and out["step_s"] == 5e-6
    assert 0 <= out["max_relative_difference"] < 1e-9
    # relative to the run's largest tip displacement (the reference's samples), not the last
    # instant's: the absolute difference over it
    assert out["max_relative_difference"] == pytest.approx(
        out["max_difference_m"] / out["largest_tip_displacement_m"], rel=1e-12)
    assert out["largest_tip_displacement_m"] > 0


def test_the_compared_difference_is_relative_to_the_run():
    """A last state whose tips pass near zero (the nozzle's response crossing it) is read
    against the largest tip displacement over the run, not against its own."""
    from types import SimpleNamespace

    from wheelrom.transient.reference import tip_difference

    model = SimpleNamespace(size=2, blades=2, modes=1, tip=np.array([[0.0], [1.0], [0.0]]))
    reference = np.array([[5e-5, -4e-5], [1e-9, -2e-9]])  # (samples, state): q of 2 blades
    final = np.array([1e-9 + 3e-15, -2e-9])
    relative, absolute, scale = tip_difference(model, reference, final)
    assert absolute == pytest.approx(3e-15, rel=1e-6) and scale == 5e-5
    assert relative == pytest.approx(6e-11, rel=1e-6)


def test_compare_takes_the_step_from_the_ts():
    """-wheel_ts_dt overrides time.step: the reference integrates with the TS's step (in a
    subprocess: options after -- go into that process's PETSc database for good)."""
    import subprocess
    import sys

    res = subprocess.run([sys.executable, "-m", "wheelrom.cli.main", "compare", SMALL, "--steps",
                          "100", "--json", "--", "-wheel_ts_dt", "2.5e-6"],
                         capture_output=True, text=True, check=True, timeout=HANG_S)
    out = json.loads(res.stdout)
    assert out["step_s"] == 2.5e-6 and out["max_relative_difference"] < 1e-9


def test_modes_out_and_vtu(tmp_path, capsys, small_model):
    import meshio

    out, vtu = tmp_path / "m.h5", tmp_path / "w.vtu"
    assert cli.main(["modes", SMALL, "--json", "--out", str(out), "--vtu", str(vtu),
                     "--vtu-nd", "3"]) == 0
    printed = json.loads(capsys.readouterr().out)
    table = small_model.frequencies_by_nodal_diameter()
    np.testing.assert_allclose(printed["reduced_hz_by_nd"], table, rtol=1e-12)
    with h5py.File(out, "r") as f:
        np.testing.assert_allclose(f["model/frequencies_by_nd"][()], table, rtol=1e-12)
        np.testing.assert_array_equal(f["model/A1"][()], small_model.A1)
        assert f["model/wheel_hz"].shape == (small_model.size,)
        assert "config" in f.attrs
    mesh = meshio.read(vtu)
    u = mesh.point_data["displacement"]
    assert u.shape == mesh.points.shape and np.abs(u).max() == 1.0
    assert mesh.points.shape[0] % small_model.blades == 0


def test_run_out_window_end_is_the_runs(tmp_path, capsys):
    """time.end not a multiple of time.window: the file's window ends are the run's."""
    out = tmp_path / "r.h5"
    argv = ["run", SMALL, "--json", "--set", "time.end=0.0025", "--set", "time.window=0.001",
            "--out", str(out)]
    assert cli.main(argv) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["simulated_s"] == pytest.approx(0.0025, rel=1e-9)
    with h5py.File(out, "r") as f:
        ends = f["cases/window_end"][()]
        assert ends[-1] == pytest.approx(summary["simulated_s"], rel=1e-9)
        np.testing.assert_allclose(ends, [0.001, 0.0025])
        assert np.isfinite(f["cases/max_tip_amplitude"][0]).all()


def no_constants(name):
    raise AssertionError(f"bare {name} in JSON output")


def test_print_json_is_strict_with_null_fields(capsys):
    """NaN/inf (also in numpy arrays, numpy scalars, nested dicts) print as null, and
    null_fields says which keys and why."""
    from wheelrom.cli.output import print_json

    print_json({"energy_balance_error": float("nan"), "ok": np.float64(1.5),
                "table": np.array([[1.0, np.nan], [np.inf, 2.0]]), "peak": np.float32(-np.inf),
                "min_normal_force": {"tieboss": np.nan, "shroud": 3.0}, "steps": np.int64(7),
                "cases": [{"wall_s": 1.0}, {"wall_s": np.nan}]})
    text = capsys.readouterr().out
    out = json.loads(text, parse_constant=no_constants)
    json.dumps(out, allow_nan=False)
    assert out["energy_balance_error"] is None and out["ok"] == 1.5 and out["steps"] == 7
    assert out["table"] == [[1.0, None], [None, 2.0]] and out["peak"] is None
    assert out["min_normal_force"] == {"tieboss": None, "shroud": 3.0}
    assert out["cases"] == [{"wall_s": 1.0}, {"wall_s": None}]
    nulls = out["null_fields"]
    assert set(nulls) == {"energy_balance_error", "table", "peak", "min_normal_force.tieboss",
                          "cases[1].wall_s"}
    assert nulls["energy_balance_error"].startswith("NaN: no energy balance")
    assert nulls["table"].startswith("2 of 4 values NaN/inf")
    assert nulls["peak"] == "infinite (-inf)" and nulls["cases[1].wall_s"] == "not finite (NaN)"
    assert "no output sample" in nulls["min_normal_force.tieboss"]


def test_run_json_with_non_finite_statistics_is_strict_json(capsys, monkeypatch):
    """Window statistics that are NaN (a window without a sample, a non-finite state) print
    as null in run --json, with the reason in null_fields."""
    from wheelrom.transient import run

    real = run.run_case

    def nan_statistics(*args, **kwargs):
        res = real(*args, **kwargs)
        res.max_tip_amplitude[-1] = res.energy[-1] = np.nan
        for kind in res.min_normal_force:
            res.min_normal_force[kind][-1] = res.open_fraction[kind][-1] = np.nan
        return res

    monkeypatch.setattr(run, "run_case", nan_statistics)
    assert cli.main(["run", SMALL, "--json", "--set", "time.end=0.001"]) == 0
    out = json.loads(capsys.readouterr().out, parse_constant=no_constants)
    assert out["status"] == "done" and out["max_tip_amplitude"] is None
    assert out["min_normal_force"] == {"tieboss": None, "shroud": None}
    assert out["energy_balance_error"] is None and out["steps"] == 200
    reasons = out["null_fields"]
    assert set(reasons) == {"max_tip_amplitude", "energy_balance_error", "growth_rate",
                            *(f"{key}.{kind}" for key in ("min_normal_force", "open_fraction")
                              for kind in ("tieboss", "shroud"))}
    assert reasons["max_tip_amplitude"].startswith("NaN: no output sample in the last window")
    assert reasons["energy_balance_error"].startswith("NaN: no energy balance")


def test_plain_output_is_for_people(capsys):
    """run's plain output: no Python reprs, 4 significant digits, units from the keys."""
    assert cli.main(["run", SMALL, "--set", "time.end=0.001"]) == 0
    lines = dict(line.split(":", 1) for line in capsys.readouterr().out.splitlines())
    lines = {k.strip(): v.strip() for k, v in lines.items()}
    assert lines["status"] == "done" and lines["steps"] == "200"
    assert lines["simulated_s"] == "0.001 s"  # not 0.0010000000000000002
    wall = lines["wall_s"].split()
    assert wall[1] == "s" and float(wall[0]) == float(f"{float(wall[0]):.4g}") > 0
    assert lines["max_tip_amplitude"].endswith(" m")
    assert lines["min_normal_force"].startswith("tieboss ") and ", shroud " in lines[
        "min_normal_force"] and lines["min_normal_force"].endswith(" N")
    assert lines["preload_residual"] == "n/a"
    assert lines["options"] == "ts_type rk, ts_rk_type 3bs, ts_dt 5e-06, ts_adapt_type none"
    assert not any(c in v for v in lines.values() for c in "{}'[]")


def test_compare_plain_output(capsys):
    assert cli.main(["compare", SMALL, "--steps", "100"]) == 0
    lines = [line.split(":", 1) for line in capsys.readouterr().out.splitlines()]
    out = {k.strip(): v.strip() for k, v in lines}
    assert out["steps"] == "100" and out["step_s"] == "5e-06 s"
    assert out["petsc_wall_s"].endswith(" s") and out["reference_wall_s"].endswith(" s")
    assert float(out["max_relative_difference"]) < 1e-9


def test_human_values():
    from wheelrom.cli.output import human_value, unit_of

    assert human_value(0.020000000000000788, "s") == "0.02 s"
    assert human_value(None) == "n/a" and human_value(float("nan"), "m") == "NaN"
    assert human_value({"tieboss": 1234.5678, "shroud": 0.0}, "N") == "tieboss 1235 N, shroud 0 N"
    assert human_value(list(range(20)), "Hz") == "0, 1, 2, ..., 19 Hz (20 values)"
    assert human_value(np.float64(3.14159265)) == "3.142"
    assert [unit_of(k) for k in ("wall_s", "us_per_rhs", "segment_hz", "steps_per_s",
                                 "paper_case_s_in_batch", "machine_gmadd_per_s", "steps",
                                 "fe_stiffness_n_per_m")] == [
        "s", "us", "Hz", "/s", "s", "Gmadd/s", "", "N/m"]
