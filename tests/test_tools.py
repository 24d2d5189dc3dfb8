"""Scripts in run/: the TS tuning script (library API, options per run)."""

import importlib.util
import json
import os

import pytest

from convergence import assert_order

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)


def _load_script(name):
    spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, "run", f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_tune_ts_script_orders_and_options(capsys, tmp_path):
    tune = _load_script("tune_ts")
    fig = tmp_path / "wp.png"
    small = os.path.join(HERE, "data", "small.toml")
    # contacts off: the smooth linear wheel must show the design order (with the contacts on,
    # this 12-blade free-basis wheel gives 4-7x per halving over 2 ms; the default wheel's
    # clean third order from the preloaded equilibrium is in docs/performance.md)
    smooth = ["--set", "contacts.shroud.enabled=false", "--set", "contacts.tieboss.enabled=false"]
    argv = [small, *smooth, "--end", "0.002", "--json", "--plot", str(fig)]
    assert tune.main(argv) == 0
    table = json.loads(capsys.readouterr().out)
    runs = {r["setting"]: r for r in table["runs"]}
    assert all(r["status"] == "done" for r in runs.values())
    # the options each run reports are the ones it asked for
    assert runs["5dp adaptive rtol=1e-06"]["options"]["ts_rk_type"] == "5dp"
    assert runs["5dp adaptive rtol=1e-06"]["options"]["ts_adapt_type"] == "basic"
    fixed = [r for label, r in runs.items() if label.startswith("3bs dt=")]
    steps = [r["steps"] for r in fixed]
    assert steps == [170, 340, 680, 1360, 2720]  # 2.04 ms (a multiple of every step)
    floor = table["reference_error"]  # the reference's own error (5dp at two steps)
    # Bogacki-Shampine is third order: halving the step cuts the error by about 8
    assert_order([r["tip_error"] for r in fixed], floor, 6.0, 10.0)
    # the exponential scheme is fourth order: about 16 per halving, held on its two coarsest
    # steps (measured 3.3e-9, 2.1e-10, 1.3e-11, 1.2e-12: the last two within 10x of the
    # reference's rounding floor, ~1.5e-12, which 5dp at half or a quarter of its step does
    # not lower; the script still reports them)
    exp = [r for label, r in runs.items() if label.startswith("exponential dt=")]
    assert [r["options"]["ts_scheme"] for r in exp] == ["etdrk4"] * 4
    assert_order([r["tip_error"] for r in exp[:2]], floor, 11.0, 22.0)
    # tighter adaptive tolerances are more accurate
    tight, loose = runs["5dp adaptive rtol=1e-08"], runs["5dp adaptive rtol=1e-04"]
    assert tight["tip_error"] < loose["tip_error"]
    assert fig.stat().st_size > 1000


@pytest.mark.parametrize("bad", [["--end", "-1"], ["--set", "time.step=0"]])
def test_tune_ts_rejects_bad_input(bad):
    from wheelrom.config import ConfigError

    tune = _load_script("tune_ts")
    with pytest.raises(ConfigError):
        tune.main(bad)


def test_validate_full_wheel_script_on_a_small_wheel(capsys):
    """The validation script's two references (assembled wheel, exact cyclic symmetry) agree
    on the 12-blade test wheel; its exit status says so."""
    validate = _load_script("validate_full_wheel")
    small = os.path.join(HERE, "data", "small.toml")
    assert validate.main([small, "--families", "1"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["modes"] == 12 and out["ranks"] == 1
    assert out["max_relative_difference"] < 1e-6
