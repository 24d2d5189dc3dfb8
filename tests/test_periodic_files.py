"""What the periodic-solution commands say of their cases: a limit cycle says which method
gave its numbers when the shot from the harmonic balance did not converge (the verdict,
the JSON and `info`), and a case examined only at the waves asked (``--nd``) is not called
stable while another of its waves flutters."""

import json

from conftest import SMALL
from wheelrom.cli import main as cli

#: the 80 deg case, small and fast: its ND 6 cycle opens both contacts
AT_80 = ["--set", "sweep.shroud_angles_deg=[80.0]", "--set", "limit_cycle.steps=4", "--set",
         "limit_cycle.seeds=[1e-4]", "--set", "limit_cycle.harmonics=5", "--set",
         'limit_cycle.floquet="off"']  # fmt: skip


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
