"""What the periodic-solution commands say of their cases: a limit cycle says which method
gave its numbers when the shot from the harmonic balance did not converge (the verdict,
the JSON and `info`), and a case examined only at the waves asked (``--nd``) is not called
stable while another of its waves flutters; `info --verify` checks the limit-cycle and
settle files' checksums (it exited 0 on a changed value without saying nothing was
checked)."""

import contextlib
import io
import json
import shutil

import h5py
import numpy as np
import pytest

from conftest import SMALL, VDP_WHEEL
from wheelrom.cli import main as cli
from wheelrom.cli.limit_cycle import print_limit_cycles

#: the 80 deg case, small and fast: its ND 6 cycle opens both contacts
AT_80 = ["--set", "sweep.shroud_angles_deg=[80.0]", "--set", "limit_cycle.steps=4", "--set",
         "limit_cycle.seeds=[1e-4]", "--set", "limit_cycle.harmonics=5", "--set",
         'limit_cycle.floquet="off"']


def _main(argv: list[str]) -> tuple[int, str]:
    """``wheelrom ARGV``'s status and stdout (a module fixture has no capsys)."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = cli.main(argv)
    return status, out.getvalue()


@pytest.fixture(scope="module")
def missed_shot(tmp_path_factory):
    """The 80 deg case by shooting: the shot from the harmonic balance's ND 6 cycle stalls
    at a residual of ~1.5 at every step (its contacts lift off within the cycle), so the
    cycle reported is the harmonic balance's. ``(file, the JSON printed)``."""
    path = tmp_path_factory.mktemp("shot") / "lc.h5"
    status, out = _main(["limit-cycle", SMALL, *AT_80, "--set", 'limit_cycle.method="shooting"',
                         "--nd", "6", "--json", "--out", str(path)])
    assert status == 0
    return path, json.loads(out)


def test_a_missed_shot_is_named_where_the_cycle_is(missed_shot, capsys):
    """The verdict, the JSON and the printed cycle say the numbers are the harmonic
    balance's, with the shot's residual: it was presented as the exact orbit, the failure
    only in the wave's `end` attribute."""
    _, out = missed_shot
    case = out["cases"][0]
    (cycle,) = case["waves"][0]["cycles"]
    assert cycle["method"] == "hb" and cycle["shooting"]["converged"] is False
    residual = cycle["shooting"]["residual"]
    assert residual > 0.1
    said = f"harmonic balance (the shot did not converge: residual {residual:.2g})"
    assert cycle["source"] == said
    assert case["verdict"].startswith("flutters (ND 6): limit cycle at ")
    assert f" Hz by {said}, " in case["verdict"], case["verdict"]
    print_limit_cycles(out["cases"])
    line = next(ln for ln in capsys.readouterr().out.splitlines() if "cycle " in ln[:20])
    assert f"Hz by {said}, stability not computed" in line, line


def test_info_says_which_method_gave_the_cycle(missed_shot, capsys):
    """`info` listed the harmonic balance's cycle under "exact orbit by shooting"."""
    path, _ = missed_shot
    assert cli.main(["info", str(path)]) == 0
    text = capsys.readouterr().out
    title = text.splitlines()[0]
    assert "(exact orbit by shooting;" not in title, title
    assert "exact orbit by shooting for 0 of 1 cycle(s), harmonic balance for 1 whose shot " \
        "did not converge; H = 5" in title, title
    cycle = next(ln.strip() for ln in text.splitlines() if "tip " in ln and " um at " in ln)
    assert cycle.startswith("harmonic balance (the shot did not converge: residual "), cycle
    assert cli.main(["info", str(path), "--json"]) == 0
    row = json.loads(capsys.readouterr().out)["cases"][0]["waves"][0]["cycles"][0]
    assert row["method"] == "hb" and row["shot_missed"] is True


def test_a_case_examined_at_a_stable_wave_is_not_called_stable(capsys):
    """`--nd 0` at 80 deg, where ND 6 flutters: only ND 0 was examined, and it is stable;
    the headline said "stable". Now it says so of the wave asked and names the fastest
    wave of the linear analysis; at 20 deg, where every wave is stable, it says "stable"."""
    shrouds = "sweep.shroud_angles_deg=[20.0, 80.0]"
    assert cli.main(["limit-cycle", SMALL, *AT_80, "--set", shrouds, "--set",
                     'limit_cycle.method="hb"', "--nd", "0", "--json"]) == 0
    stable, flutters = json.loads(capsys.readouterr().out)["cases"]
    assert stable["verdict"] == "stable" and stable["fastest_wave"] is None
    (wave,) = flutters["waves"]
    assert wave["nodal_diameter"] == 0 and wave["verdict"].startswith("stable up to")
    verdict = flutters["verdict"]
    assert not verdict.startswith("stable"), verdict
    assert verdict.startswith("the wave asked (ND 0) is stable at the configured intensity, "
                              "but the case flutters: its fastest wave, ND 6 (wave 6, "
                              "growing at "), verdict
    fastest = flutters["fastest_wave"]
    assert fastest["wave"] == 6 and fastest["nodal_diameter"] == 6
    assert f"growing at {fastest['growth_rate']:.3g} /s), was not examined" in verdict


def flip_bit(path, dataset: str, row: int = 0) -> None:
    """One bit of ``dataset``'s row ``row`` flipped in the file's bytes, as a disk or a copy
    would (its first chunk's, for a chunked one)."""
    with h5py.File(path, "r") as f:
        d = f[dataset]
        if d.chunks:
            offset = d.id.get_chunk_info(0).byte_offset + 20
        else:
            offset = d.id.get_offset() + row * int(np.prod(d.shape[1:])) * d.dtype.itemsize + 3
    with open(path, "r+b") as fh:
        fh.seek(offset)
        byte = fh.read(1)
        fh.seek(offset)
        fh.write(bytes([byte[0] ^ 0x10]))


def verify(path, capsys) -> tuple[int, str, str]:
    status = cli.main(["info", str(path), "--verify"])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def check_verify(path, flips: dict, tmp_path, capsys) -> None:
    """``path`` verifies intact (exit 0); a copy with one bit flipped in each dataset of
    ``flips`` (dataset -> (row, how info names it)) is named, exit 1; a copy whose
    checksums are removed (a file of an earlier version) says nothing was checked, exit 0."""
    assert cli.main(["info", str(path), "--verify", "--json"]) == 0
    checks = json.loads(capsys.readouterr().out)["checksums"]
    assert checks["stored"] and checks["scope"] == "file" and checks["mismatched"] == []
    assert checks["checked"] > 20
    for dataset, (row, named) in flips.items():
        bad = tmp_path / "flipped.h5"
        shutil.copy(path, bad)
        flip_bit(bad, dataset, row)
        status, out, err = verify(bad, capsys)
        assert status == 1, out
        assert f"CHANGED since written: {named}\n" in out, out
        assert err == f"wheelrom: {bad}: {named} changed since written (checksum mismatch): " \
            "compute the file again\n"
    old = tmp_path / "old.h5"
    shutil.copy(path, old)
    with h5py.File(old, "r+") as f:
        del f["checksums"]
    status, out, err = verify(old, capsys)
    assert status == 0
    assert "checksums:     none stored (a file written before wheelrom kept them): nothing " \
        "was checked" in out
    assert err == f"wheelrom: {old}: no checksums stored (written before wheelrom kept them): " \
        "nothing was verified\n"


def test_info_verify_names_a_changed_value_of_a_limit_cycle_file(missed_shot, tmp_path,
                                                                  capsys):
    """A cycle's amplitude, a per-case row, the model: each named with its case."""
    path, _ = missed_shot
    check_verify(path, {
        "limit_cycle/case_0/wave_6/cycles/tip_amplitude":
            (0, "case 0 (limit_cycle/case_0/wave_6/cycles/tip_amplitude)"),
        "limit_cycle/wall_s": (0, "case 0 (limit_cycle/wall_s)"),
        "model/segment_hz": (2, "model/segment_hz"),
    }, tmp_path, capsys)
    changed = tmp_path / "attribute.h5"
    shutil.copy(path, changed)
    with h5py.File(changed, "r+") as f:
        f["limit_cycle/case_0/wave_6"].attrs["critical_lam"] = 0.5
    status, out, _ = verify(changed, capsys)
    assert status == 1 and "case 0 (limit_cycle/case_0/wave_6@critical_lam)" in out, out


@pytest.fixture(scope="module")
def settle_file(tmp_path_factory):
    """The Van der Pol wheel from its seeded equilibrium for 0.2 s: not settled, 6 windows."""
    path = tmp_path_factory.mktemp("settle") / "settle.h5"
    keys = [*VDP_WHEEL, "sweep.shroud_angles_deg=[50.0]", 'settle.start="preload"',
            "settle.max_time=0.2", "settle.min_time=0.05", "settle.window_periods=4"]
    status, _ = _main(["settle", SMALL, *sum((["--set", k] for k in keys), []), "--json",
                       "--out", str(path)])
    assert status == 0
    return path


def test_info_verify_names_a_changed_value_of_a_settle_file(settle_file, tmp_path, capsys):
    """A blade's amplitude, a per-case row, the compressed tip history (whose chunk may no
    longer inflate): each named with its case."""
    check_verify(settle_file, {
        "settle/case_0/amplitude": (3, "case 0 (settle/case_0/amplitude)"),
        "settle/max_amplitude": (0, "case 0 (settle/max_amplitude)"),
        "settle/case_0/tip": (0, "case 0 (settle/case_0/tip)"),
    }, tmp_path, capsys)
