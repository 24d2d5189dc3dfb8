"""Sweeps under mpirun (subprocesses), resume after SIGKILL, failure isolation, figures."""

import os
import signal
import subprocess
import sys

import h5py
import numpy as np
import pytest

import handshake
from conftest import HANG_S, SMALL

WHEELROM = [sys.executable, "-m", "wheelrom.cli.main"]
ENV = dict(
    os.environ,
    OMPI_ALLOW_RUN_AS_ROOT="1",
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1",
    OMPI_MCA_rmaps_base_oversubscribe="1",
)


def sweep(out, *extra, ranks=1, check=True, env=ENV):
    cmd = WHEELROM + ["sweep", SMALL, "--out", str(out), *extra]
    if ranks > 1:
        cmd = ["mpirun", "-n", str(ranks), *cmd]
    return subprocess.run(cmd, env=env, capture_output=True, text=True, check=check, timeout=HANG_S)


# timing and the rank count, not the physics
NOT_PHYSICS = ("cases/wall_s", "cases/compile_s", "cases/batch", "cases/checksum")  # + wall


def case_data(path):
    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            physics = name.startswith("cases/") and name not in NOT_PHYSICS
            if isinstance(obj, h5py.Dataset) and physics:
                out[name] = obj[()]

        f.visititems(visit)
    return out


def assert_same(a, b):
    assert a.keys() == b.keys()
    for k in a:
        if a[k].dtype.kind == "f":
            assert np.array_equal(a[k], b[k], equal_nan=True), k
        else:
            assert np.array_equal(a[k], b[k]), k


@pytest.fixture(scope="module")
def serial_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep") / "n1.h5"
    sweep(path)
    return path


def test_two_ranks_bitwise_equal_one_rank(serial_run, tmp_path):
    sweep(tmp_path / "n2.h5", ranks=2)
    a, b = case_data(serial_run), case_data(tmp_path / "n2.h5")
    assert all(s == b"done" for s in a["cases/status"])
    assert np.isfinite(a["cases/max_tip_amplitude"]).all()
    assert_same(a, b)


def test_elastic_law_two_ranks_bitwise_equal_one_rank(tmp_path):
    """The elastic contact law from the preloaded equilibrium with a 10 um seed (the shroud
    slips from the start): a sweep on two ranks equals one process, the work and the friction
    (tangential) work are recorded per window, and friction dissipates."""
    law = ["--set", "contacts.law=elastic", "--set", "time.start=preload",
           "--set", "time.perturbation=1e-5"]
    sweep(tmp_path / "n1.h5", *law)
    sweep(tmp_path / "n2.h5", *law, ranks=2)
    a, b = case_data(tmp_path / "n1.h5"), case_data(tmp_path / "n2.h5")
    assert all(s == b"done" for s in a["cases/status"])
    assert_same(a, b)
    work = a["cases/work"]
    assert work.shape[-1] == 4 and np.isfinite(work).all()
    assert (work[:, -1, 2] < 0).all()  # the tangential forces' work over the run
    slip = a["cases/slip_fraction/shroud"]  # the seed makes the shroud slip, then it sticks
    assert slip.max() > 0 and np.nanmin(slip) < slip.max()


def test_existing_file_is_not_overwritten(serial_run):
    before = os.path.getmtime(serial_run)
    res = sweep(serial_run, check=False)
    assert res.returncode == 2 and "--force" in res.stderr
    assert os.path.getmtime(serial_run) == before


def test_killed_sweep_resumes_to_the_same_file(serial_run, tmp_path):
    """SIGKILL while the second of three cases runs, held there by a handshake
    (tests/handshake.py; killed once the first case's line appeared instead, a fast machine
    could have finished them all): the file opens and holds the first case, and --resume
    completes it to the one process's file."""
    out = tmp_path / "killed.h5"
    held = handshake.script(tmp_path, handshake.SWEEP_SECOND_ROUND)
    proc = subprocess.Popen([*held, "sweep", SMALL, "--out", str(out), "--batch", "1"],
                            env=ENV, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True)
    handshake.read_until(proc, handshake.HOLDING)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=HANG_S)
    with h5py.File(out, "r") as f:  # opens, holds the first case
        assert [s.decode() for s in f["cases/status"][:]] == ["done", "pending", "pending"]
    # the killed job's lock stays and is reported stale (tests/test_safety.py); once removed,
    # --resume completes the file
    assert sweep(out, "--resume", check=False).returncode == 2
    os.remove(tmp_path / ".killed.h5.lock")
    sweep(out, "--resume")
    assert_same(case_data(serial_run), case_data(out))


def test_diverging_case_fails_alone(tmp_path):
    """At 90 deg the tip passes time.divergence_amplitude (1.5e-5 m: the 90 deg case reaches
    1.74e-5 m by 0.9 ms, the 20 deg one stays at 1.35e-5 m), the 20 deg case goes on. (A
    stiffness the explicit step cannot follow, 1e14 N/m, is beyond the key's range now.)"""
    out = tmp_path / "div.h5"
    res = sweep(
        out,
        "--set",
        "sweep.shroud_angles_deg=[20.0, 90.0]",
        "--set",
        "time.divergence_amplitude=1.5e-5",
        check=False,
    )
    assert res.returncode == 1
    with h5py.File(out, "r") as f:
        status = [s.decode() for s in f["cases/status"][:]]
        assert status[0] == "done"
        assert status[1].startswith("failed:") and "t =" in status[1]
        assert np.isfinite(f["cases/max_tip_amplitude"][0]).all()


def test_figures_render_headless(serial_run, tmp_path):
    res = subprocess.run(
        WHEELROM + ["plot", str(serial_run), "--outdir", str(tmp_path)],
        env=dict(ENV, MPLBACKEND="Agg"),
        capture_output=True,
        text=True,
        check=True,
    )
    names = [
        "fig08_frequencies",
        "interference",
        "fig05_contact_stiffness",
        "fig10_amplitude",
        "fig11_normal_force",
        "fig12_nd_spectrum",
        "summary",
    ]
    for name in names:
        png = tmp_path / f"{name}.png"
        assert png.stat().st_size > 5000
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert res.stdout.count(".png") == len(names)


def test_plot_names_the_missing_quantity(serial_run, tmp_path):
    broken = tmp_path / "broken.h5"
    with h5py.File(serial_run, "r") as src, h5py.File(broken, "w") as dst:
        for key, value in src.attrs.items():
            dst.attrs[key] = value
        src.copy("model", dst)
        src.copy("cases", dst)
        del dst["cases/nd_spectrum"]
    res = subprocess.run(
        WHEELROM + ["plot", str(broken), "--outdir", str(tmp_path)],
        env=ENV,
        capture_output=True,
        text=True,
    )
    assert res.returncode == 2 and "cases/nd_spectrum" in res.stderr


def test_run_json_summary(tmp_path):
    import json

    res = subprocess.run(
        WHEELROM
        + [
            "run",
            SMALL,
            "--json",
            "--set",
            "time.end=0.001",
            "--out",
            str(tmp_path / "c.h5"),
            "--",
            "-wheel_ts_rk_type",
            "4",
        ],
        env=ENV,
        capture_output=True,
        text=True,
        check=True,
    )
    summary = json.loads(res.stdout)
    assert summary["status"] == "done" and summary["steps"] == 200
    assert summary["options"]["ts_rk_type"] == "4"
    assert set(summary["min_normal_force"]) == {"tieboss", "shroud"}
    assert summary["max_tip_amplitude"] > 0


def test_model_on_comm_world_gives_the_same_physics(serial_run, tmp_path):
    """--model-comm world: distributed segment eigen-solve; tip motion equals the rank-0 build
    to the eigen-solver tolerance (mode signs may differ, physical outputs do not)."""
    out = tmp_path / "world.h5"
    sweep(out, "--model-comm", "world", ranks=2)
    a, b = case_data(serial_run), case_data(out)
    assert all(s == b"done" for s in b["cases/status"])
    tip_a, tip_b = a["cases/tip_history"], b["cases/tip_history"]
    scale = np.nanmax(np.abs(tip_a))
    assert scale > 0
    assert np.nanmax(np.abs(tip_a - tip_b)) < 1e-5 * scale
    np.testing.assert_allclose(
        b["cases/min_normal_force/shroud"], a["cases/min_normal_force/shroud"], rtol=1e-5
    )


def test_nd_spectrum_for_chosen_angles(serial_run, tmp_path):
    from wheelrom.plots.figures import plot_file
    from wheelrom.runtime.errors import InputError

    written = plot_file(str(serial_run), str(tmp_path), nd_angles=(20.0, 80.0))
    assert str(tmp_path / "fig12_nd_spectrum.png") in written
    with pytest.raises(InputError, match="shroud angle 33 deg is not in"):
        plot_file(str(serial_run), str(tmp_path), nd_angles=(33.0, 80.0))


def test_single_run_file_draws_amplitude_panels(tmp_path):
    """A `run --out` file holds one case: the Fig. 10 line and map must hold visible data (the
    map once drew a zero-height cell at the single shroud angle, an empty panel)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import QuadMesh

    from wheelrom.plots.figures import _fig10_amplitude, _Sweep, plot_file

    out = tmp_path / "one.h5"
    subprocess.run(
        WHEELROM + ["run", SMALL, "--set", "time.end=0.001", "--out", str(out)],
        env=ENV,
        capture_output=True,
        text=True,
        check=True,
    )
    written = plot_file(str(out), str(tmp_path / "fig"))
    assert str(tmp_path / "fig" / "fig10_amplitude.png") in written
    with h5py.File(out, "r") as f:
        fig = _fig10_amplitude(_Sweep(f, str(out)), plt)
    try:
        panels = {ax.get_title(): ax for ax in fig.axes}  # colorbars have no title
        line_ax, map_ax = panels["Blade-tip amplitude per window"], panels["Amplitude map"]
        (line,) = line_ax.get_lines()
        y = np.asarray(line.get_ydata(), dtype=float)
        assert y.size >= 1 and np.isfinite(y).all() and (y > 0).all()
        assert line.get_marker() not in (None, "", "None", " ")  # one window shows as a point
        (mesh,) = [c for c in map_ax.collections if isinstance(c, QuadMesh)]
        xy = mesh.get_coordinates()  # (rows + 1, cols + 1, 2) cell corners
        assert xy.shape[:2] == (2, 3)  # one angle x two windows
        assert np.ptp(xy[..., 1]) > 0 and np.ptp(xy[..., 0]) > 0
        assert np.isfinite(mesh.get_array()).all()
    finally:
        plt.close(fig)


def test_existing_file_is_refused_once_under_mpirun(serial_run):
    """Under mpirun the refusal is decided on rank 0 and broadcast: every rank stops, the
    file is named once (rank 0), and nothing is written."""
    before = os.path.getmtime(serial_run)
    res = sweep(serial_run, ranks=2, check=False)
    assert res.returncode != 0 and os.path.getmtime(serial_run) == before
    lines = [ln for ln in res.stderr.splitlines() if "exists: pass --resume" in ln]
    assert lines == [f"wheelrom: {serial_run} exists: pass --resume to complete it or --force "
                     "to overwrite it"], res.stderr


TIMINGS = ("assembly_s", "eigen_solve_s", "build_s", "prestress_s", "solve_s")


def every_number(path):
    """Every dataset and attribute of a file, timings (and the TS batch width, which records
    how the cases were dealt to the ranks) aside; the model's build ``info`` without its
    timings."""
    import json

    out = {}
    with h5py.File(path, "r") as f:

        def visit(name, obj):
            for key, value in obj.attrs.items():
                if key == "info":
                    value = {k: v for k, v in json.loads(value).items()
                             if not k.endswith("_s")}
                out[f"{name}@{key}"] = value
            if isinstance(obj, h5py.Dataset) and name not in NOT_PHYSICS:
                out[name] = obj[()]

        f.visititems(visit)
    return out


def test_any_rank_count_writes_the_same_file_on_the_attachment_basis(tmp_path):
    """A plain run (every core visible) and `mpirun -n 2` (one core each) write the same
    numbers, model included: the basis depends on neither the BLAS thread count nor the
    eigensolver's signs (docs/theory.md, "Reproducibility")."""
    extra = ["--set", 'wheel.basis="attachment"', "--set", "time.step=2e-6",
             "--set", "time.end=5e-4"]
    # a user's shell: no thread counts set (this test process has them from bootstrap())
    shell = {k: v for k, v in ENV.items() if not k.endswith("_NUM_THREADS")}
    sweep(tmp_path / "n1.h5", *extra, env=shell)
    sweep(tmp_path / "n2.h5", *extra, ranks=2, env=shell)
    a, b = every_number(tmp_path / "n1.h5"), every_number(tmp_path / "n2.h5")
    assert a.keys() == b.keys() and "model/A1" in a and "model@info" in a
    different = [k for k in a if not np.array_equal(np.asarray(a[k]), np.asarray(b[k]),
                 equal_nan=np.asarray(a[k]).dtype.kind == "f")]
    assert not different, different
