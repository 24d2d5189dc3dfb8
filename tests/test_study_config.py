"""The [study] section: grid ranges, zipped lists and CSV cases expand into validated case
configurations; every problem is named (file, key, CSV row); model and batch grouping."""

import numpy as np
import pytest

from wheelrom import config
from wheelrom.config import ConfigError
from wheelrom.config.study import batch_key, expand, model_key
from wheelrom.studies.plan import balance, batches, boundary, group_by, selection


def study(tmp_path, text: str, csv: str | None = None):
    path = tmp_path / "study.toml"
    path.write_text(text)
    if csv is not None:
        (tmp_path / "cases.csv").write_text(csv)
    return config.load(path)


def test_grid_range_and_zip_expand_first_axis_slowest(tmp_path):
    cfg = study(tmp_path, """
[study.grid]
contacts.tieboss.angle_deg = [30.0, 60.0]
contacts.shroud.angle_deg = "0:90:45"
[study.zip]
friction.static = [0.6, 0.8]
friction.dynamic = [0.4, 0.5]
""")
    s = expand(cfg)
    assert s.names == ("contacts.tieboss.angle_deg", "contacts.shroud.angle_deg",
                       "friction.static", "friction.dynamic")
    assert s.shape == (2, 3, 2) and s.axis == (0, 1, 2, 2) and s.size == 12
    assert s.values[0] == (30.0, 0, 0.6, 0.4)
    assert s.values[1] == (30.0, 0, 0.8, 0.5)
    assert s.values[2] == (30.0, 45, 0.6, 0.4)
    assert s.values[11] == (60.0, 90, 0.8, 0.5)
    c = s.configs[11]
    assert (c.contacts.tieboss.angle_deg, c.contacts.shroud.angle_deg) == (60.0, 90.0)
    assert (c.friction.static, c.friction.dynamic) == (0.8, 0.5)
    assert c.contacts.shroud.normal_preload == cfg.contacts.shroud.normal_preload


def test_float_range_includes_stop_and_reads_back(tmp_path):
    cfg = study(tmp_path, '[study.grid]\nfriction.decay = "0.0:0.3:0.1"\n')
    assert [v for (v,) in expand(cfg).values] == [0.0, 0.1, 0.2, 0.3]
    again = config.from_dict(__import__("tomllib").loads(config.to_toml(cfg)))
    assert again.study == cfg.study


def test_csv_cases_relative_to_the_toml(tmp_path):
    cfg = study(tmp_path, '[study]\ncases = "cases.csv"\n',
                "friction.static, contacts.shroud.normal_preload, segment.preset\n"
                "0.6, 400, coarse\n\n0.8, 250.5, default\n")
    s = expand(cfg)
    assert s.shape == (2,)
    assert s.values == ((0.6, 400, "coarse"), (0.8, 250.5, "default"))
    assert s.configs[1].contacts.shroud.normal_preload == 250.5
    assert s.configs[1].segment.preset == "default"


def test_sweep_only_config_is_the_angle_grid():
    cfg = config.load(overrides=["sweep.tieboss_angles_deg=[30.0, 45.0]",
                                 "sweep.shroud_angles_deg=[0.0, 50.0, 90.0]"])
    s = expand(cfg)
    assert s.legacy and s.shape == (2, 3)
    from wheelrom.results.layout import case_angles

    assert np.array_equal(np.array(s.values), case_angles(cfg))


@pytest.mark.parametrize("text, message", [
    ('[study.grid]\ncontacts.shroud.angle_deg = "0:90:0"',
     "study.grid.contacts.shroud.angle_deg: '0:90:0' step must be positive"),
    ('[study.grid]\ncontacts.shroud.angle_deg = "90:0:5"',
     "study.grid.contacts.shroud.angle_deg: '90:0:5' stop is below start"),
    ('[study.grid]\ncontacts.shroud.angle_deg = "0:x:5"',
     "study.grid.contacts.shroud.angle_deg: '0:x:5' is not start:stop:step"),
    ('[study.grid]\ncontacts.shroud.angle_deg = "0:100:50"',
     "study.grid.contacts.shroud.angle_deg[2]: must be <= 90.0 deg, got 100"),
    ("[study.grid]\nfriction.statik = [0.5]",
     "study.grid.friction.statik: unknown key ('statik' is not in friction)"),
    ('[study.grid]\nsegment.source = ["a.inp"]', "study.grid.segment.source: is not numeric"),
    ("[study.grid]\nmistuning.pattern = [0.1]", "study.grid.mistuning.pattern: is not numeric"),
    ("[study.grid]\nwheel.blades = [12, 24]", "study.grid.wheel.blades: cannot vary"),
    ("[study.grid]\ntime.end = [0.1]", "study.grid.time.end: cannot vary"),
    ("[study.grid]\nfriction = [1]", "study.grid.friction: is a section, not a key"),
    ('[study.grid]\nsegment.preset = ["coarse", "fine"]',
     "study.grid.segment.preset[1]: 'fine' is not one of"),
    ("[study.zip]\nfriction.static = [0.5, 0.6]\nfriction.dynamic = [0.3]",
     "study.zip: lists of unequal length (friction.static: 2, friction.dynamic: 1)"),
    ("[study.grid]\nfriction.static = [0.5]\n[study.zip]\nfriction.static = [0.6]",
     "study: friction.static varied twice"),
    ("[study.grid]\nfriction.dynamic = [0.3, 0.7]",
     "study case 1 (static.dynamic=0.7): friction.dynamic: must not exceed friction.static"),
])
def test_named_errors(tmp_path, text, message):
    cfg = study(tmp_path, text + "\n")
    with pytest.raises(ConfigError) as err:
        expand(cfg)
    assert any(p.startswith(f"{cfg.source}: ") and message.replace("static.dynamic",
               "friction.dynamic") in p for p in err.value.problems), err.value.problems


@pytest.mark.parametrize("csv, message", [
    ("friction.static\n0.6\nabc\n",
     "cases.csv row 3 column friction.static: 'abc' is not a number"),
    ("friction.static\n0.6\n0.7, 3\n", "cases.csv row 3: 2 values for 1 columns"),
    ("friction.nosuch\n0.6\n", "cases.csv column 1 ('friction.nosuch'): unknown key"),
    ("friction.static\n-1\n", "cases.csv row 2 column friction.static: must be >= 0.0, got -1"),
    ("friction.static\n", "study.cases: cases.csv: needs a header of dotted keys and a row"),
])
def test_csv_named_errors(tmp_path, csv, message):
    cfg = study(tmp_path, '[study]\ncases = "cases.csv"\n', csv)
    with pytest.raises(ConfigError) as err:
        expand(cfg)
    assert any(message in p for p in err.value.problems), err.value.problems


def test_missing_csv_is_named(tmp_path):
    cfg = study(tmp_path, '[study]\ncases = "nowhere.csv"\n')
    with pytest.raises(ConfigError, match="study.cases: nowhere.csv: cannot be read"):
        expand(cfg)


def test_all_problems_at_once(tmp_path):
    cfg = study(tmp_path, '[study.grid]\nfriction.statik = [1]\nwheel.blades = [3]\n'
                'contacts.shroud.angle_deg = "0:1:-1"\n')
    with pytest.raises(ConfigError) as err:
        expand(cfg)
    assert len(err.value.problems) == 3


def test_model_groups_segment_keys_apart_and_forces_together(tmp_path):
    cfg = study(tmp_path, """
[study.grid]
segment.preset = ["coarse", "default"]
contacts.shroud.angle_deg = [20.0, 80.0]
friction.static = [0.6, 0.8]
flutter.mu = [50.0, 100.0]
""")
    s = expand(cfg)
    of, members = group_by([model_key(c) for c in s.configs])
    assert len(members) == 2
    assert [s.configs[i].segment.preset for i in members[0]] == ["coarse"] * 8
    # the angles alone may share a TS; friction and mu may not
    bkeys = [batch_key(c) for c in s.configs]
    assert len(set(bkeys)) == 2 * 2 * 2 and bkeys[0] == bkeys[4]


@pytest.mark.parametrize("key, value", [("contacts.shroud.height", 2.1),
                                        ("wheel.modes_per_segment", 8),
                                        ("wheel.basis", "enriched"),
                                        ("contacts.shroud.enabled", False)])
def test_model_keys_see_every_model_input(key, value):
    cfg = config.load()
    assert model_key(cfg) != model_key(cfg.replace(**{key: value}))


def test_mistuning_is_put_on_the_shared_model_per_case():
    """Monte Carlo realisations share one (tuned) model; they may not share a TS."""
    cfg = config.load()
    mistuned = cfg.replace(**{"mistuning.alternate": 0.01})
    assert model_key(cfg) == model_key(mistuned)
    assert batch_key(cfg) != batch_key(mistuned)


def test_fe_stiffness_makes_the_arm_a_model_input():
    cfg = config.load()
    assert model_key(cfg) == model_key(cfg.replace(**{"contacts.shroud.arm_length": 0.25}))
    fe = cfg.replace(**{"contacts.shroud.stiffness": "fe"})
    assert model_key(fe) != model_key(fe.replace(**{"contacts.shroud.arm_length": 0.25}))


# ---------------------------------------------------------------- screen and scheduling


def test_boundary_of_a_synthetic_map():
    # 4 x 5 map, unstable where column + row > 4: the boundary is the staircase's two sides
    rows, cols = np.indices((4, 5))
    unstable = (rows + cols > 4).reshape(-1)
    labels = np.where(unstable, "unstable", "stable")
    edge = boundary(labels, (4, 5)).reshape(4, 5)
    expected = np.zeros((4, 5), dtype=bool)
    for r in range(4):
        for c in range(5):
            for dr, dc in ((0, 1), (0, -1), (1, 0), (-1, 0)):
                rr, cc = r + dr, c + dc
                if 0 <= rr < 4 and 0 <= cc < 5 and (rr + cc > 4) != (r + c > 4):
                    expected[r, c] = True
    assert np.array_equal(edge, expected)
    assert edge.sum() == 7  # the cells on both sides of the staircase


def test_boundary_is_only_along_axes_and_includes_failures():
    labels = ["stable", "stable", "stable", "failed", "stable", "stable", "stable", "stable",
              "unstable"]
    edge = boundary(labels, (3, 3))
    # (1, 0) failed: it and its axis neighbours (0, 0), (2, 0), (1, 1); (2, 2) unstable: it,
    # (1, 2), (2, 1); the diagonal (0, 2), (0, 1) is not a neighbour of either
    assert edge.tolist() == [True, False, False, True, True, True, True, True, True]
    assert not boundary(["stable"] * 4, (4,)).any()


def test_selection_names_why():
    labels = ["stable", "stable", "unstable", "unstable"]
    assert selection(labels, (4,), [0, 2], "screen") == ["user", "boundary", "boundary+user",
                                                          "none"]
    assert selection(labels, (4,), [], "full") == ["all"] * 4
    assert selection(labels, (4,), [], "stability") == ["none"] * 4


def test_balance_is_greedy_longest_first_and_complete():
    costs = [5.0, 1.0, 1.0, 4.0, 3.0, 3.0, 2.0]
    plan = balance(costs, 3)
    assert sorted(i for part in plan for i in part) == list(range(7))
    assert [sum(costs[i] for i in part) for part in plan] == [7.0, 6.0, 6.0]
    assert balance(costs, 3) == plan and balance(costs, 1) == [list(range(7))]


def test_batches_keep_keys_apart_and_respect_width():
    keys = ["a", "b", "a", "a", "b"]
    assert batches([0, 1, 2, 3, 4], keys, 0) == [[0, 2, 3], [1, 4]]
    assert batches([0, 1, 2, 3, 4], keys, 2) == [[0, 2], [1, 4], [3]]


@pytest.mark.parametrize("command", ["sweep", "stability"])
def test_sweep_and_stability_refuse_a_study(command):
    from wheelrom.runtime.errors import InputError
    from wheelrom.studies.stability import refuse_study

    refuse_study(config.load(), command)  # no [study]: fine
    cfg = config.load(overrides=['study.grid={"friction.static"=[0.5, 0.7]}'])
    with pytest.raises(InputError, match=f"has a \\[study\\] section, which '{command}' does "
                       "not run"):
        refuse_study(cfg, command)


def test_stability_arrays_pad_models_and_record_failures(small_cfg, small_model):
    from wheelrom.analysis.stability import analyse
    from wheelrom.results.study_layout import stability_arrays

    res = analyse(small_model, small_cfg, {"shroud": 50.0})
    arrays = stability_arrays([res, "RuntimeError: SNES diverged"])
    E, m = res.eigenvalue.size, small_model.modes
    assert arrays["verdict"].tolist() == [res.verdict().encode(),
                                          b"failed: RuntimeError: SNES diverged"]
    assert np.array_equal(np.sort(arrays["growth_rate"][0])[::-1], np.sort(res.growth_rate)[::-1])
    assert arrays["max_growth_rate"][0] == res.growth_rate.max()
    assert np.isnan(arrays["growth_rate"][1]).all() and (arrays["nodal_diameter"][1] == -1).all()
    assert arrays["modal_share"].shape == (2, E, m)
    assert np.array_equal(arrays["normal_force"][0], res.normal_force)  # both kinds, in order


def test_flutter_mode_varies_over_numbers_and_auto(tmp_path):
    cfg = study(tmp_path, '[study.grid]\nflutter.mode = [-1, 0, "auto"]\n')
    assert [c.flutter.mode for c in expand(cfg).configs] == [-1, 0, "auto"]
    bad = study(tmp_path, '[study.grid]\nflutter.mode = ["x"]\n')
    with pytest.raises(ConfigError, match=r"study.grid.flutter.mode\[0\]: expected 'auto' or"):
        expand(bad)


def test_tangential_stiffness_varies_over_numbers_and_mindlin(tmp_path):
    """The elastic law's ``k_t`` is a number or 'mindlin': a study varies it (issue #44:
    'study (any key, including k_t)'); other words are refused per value, naming it."""
    key = "contacts.shroud.tangential_stiffness"
    elastic = '[contacts]\nlaw = "elastic"\n[study.grid]\n'
    cfg = study(tmp_path, f'{elastic}{key} = [1.5e7, "mindlin"]\n')
    assert [c.contacts.shroud.tangential_stiffness for c in expand(cfg).configs] == \
        [1.5e7, "mindlin"]
    bad = study(tmp_path, f'{elastic}{key} = ["stiff"]\n')
    with pytest.raises(ConfigError, match=rf"study.grid.{key}\[0\]"):
        expand(bad)
