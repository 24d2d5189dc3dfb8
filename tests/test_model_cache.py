"""The reduced-model cache (rom/cache.py): a command reads the model an earlier one built for
the same wheel, exactly; anything the model depends on builds a new one."""

import numpy as np

from wheelrom.rom import cache
from wheelrom.rom.build import build_model
from wheelrom.rom.model import ReducedModel

FIELDS = ("segment_hz", "K_seg", "A0", "A1", "rotation", "tip", "aero", "excitation")


def _equal(a: ReducedModel, b: ReducedModel) -> None:
    assert (a.blades, a.modes) == (b.blades, b.modes)
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for name in cache.PER_KIND:
        assert sorted(getattr(a, name)) == sorted(getattr(b, name)), name
        for kind, value in getattr(a, name).items():
            np.testing.assert_array_equal(value, getattr(b, name)[kind], err_msg=name)


def test_a_second_command_reads_the_model_the_first_built(small_cfg, comm, tmp_path,
                                                          monkeypatch):
    monkeypatch.setenv(cache.ENVIRONMENT, str(tmp_path))
    said = []
    built = build_model(small_cfg, comm, log=said.append)
    assert not any("from the cache" in line for line in said)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    said.clear()
    # the forces, the contact angles and the mistuning are each case's: the same model
    mistuned = small_cfg.replace(**{"flutter.mu": 50.0, "contacts.shroud.angle_deg": 10.0,
                                    "mistuning.alternate": 0.01})
    read = build_model(mistuned, comm, log=said.append)
    assert any("from the cache" in line for line in said), said
    _equal(built, read)
    assert built.mistuning is None
    np.testing.assert_array_equal(read.mistuning, 0.01 * (-1.0) ** np.arange(12))
    assert read.info["segment_dofs"] == built.info["segment_dofs"]
    # a key the model depends on: another model, another file
    other = build_model(small_cfg.replace(**{"wheel.modes_per_segment": 5}), comm)
    assert other.modes == 5 and len(list(tmp_path.glob("*.npz"))) == 2


def test_an_unreadable_file_is_built_again(small_cfg, comm, tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENVIRONMENT, str(tmp_path))
    built = build_model(small_cfg, comm)
    (path,) = tmp_path.glob("*.npz")
    whole = path.read_bytes()
    for damaged in (b"not a model", whole[: len(whole) // 2], b""):  # ValueError, zip, EOF
        path.write_bytes(damaged)
        assert cache.load(path) is None
        said = []
        again = build_model(small_cfg, comm, log=said.append)
        assert not any("from the cache" in line for line in said)
        _equal(built, again)
        assert cache.load(path) is not None  # replaced by a whole file


def test_the_model_solvers_options_are_part_of_the_key(small_cfg):
    from wheelrom.runtime.environment import petsc

    options = petsc().Options()
    before = cache.cache_key(small_cfg)
    options.setValue("segment_eps_tol", "1e-12")
    try:
        assert cache.cache_key(small_cfg) != before
    finally:
        options.delValue("segment_eps_tol")
    options.setValue("wheel_ts_type", "rk")  # the transient's: the same model
    try:
        assert cache.cache_key(small_cfg) == before
    finally:
        options.delValue("wheel_ts_type")


def test_off_builds_every_time(small_cfg, comm, tmp_path, monkeypatch):
    monkeypatch.setenv(cache.ENVIRONMENT, "off")
    assert cache.directory() is None
    build_model(small_cfg, comm)
    assert not list(tmp_path.iterdir())
