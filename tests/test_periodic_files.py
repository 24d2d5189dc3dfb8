"""What the periodic-solution commands say of their cases: a limit cycle says which method
gave its numbers when the shot from the harmonic balance did not converge (the verdict,
the JSON and `info`), and a case examined only at the waves asked (``--nd``) is not called
stable while another of its waves flutters."""

import contextlib
import io
import json

import pytest

from conftest import SMALL
from wheelrom.cli import main as cli
from wheelrom.cli.limit_cycle import print_limit_cycles

#: the 80 deg case, small and fast: its ND 6 cycle opens both contacts
AT_80 = ["--set", "sweep.shroud_angles_deg=[80.0]", "--set", "limit_cycle.steps=4", "--set",
         "limit_cycle.seeds=[1e-4]", "--set", "limit_cycle.harmonics=5", "--set",
         'limit_cycle.floquet="off"']  # fmt: skip


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
                         "--nd", "6", "--json", "--out", str(path)])  # fmt: skip
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
        "did not converge; H = 5" in title, title  # fmt: skip
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
                     'limit_cycle.method="hb"', "--nd", "0", "--json"]) == 0  # fmt: skip
    stable, flutters = json.loads(capsys.readouterr().out)["cases"]
    assert stable["verdict"] == "stable" and stable["fastest_wave"] is None
    (wave,) = flutters["waves"]
    assert wave["nodal_diameter"] == 0 and wave["verdict"].startswith("stable up to")
    verdict = flutters["verdict"]
    assert not verdict.startswith("stable"), verdict
    assert verdict.startswith("the wave asked (ND 0) is stable at the configured intensity, "
                              "but the case flutters: its fastest wave, ND 6 (wave 6, "
                              "growing at "), verdict  # fmt: skip
    fastest = flutters["fastest_wave"]
    assert fastest["wave"] == 6 and fastest["nodal_diameter"] == 6
    assert f"growing at {fastest['growth_rate']:.3g} /s), was not examined" in verdict
