"""Force model: nozzle ND content, Van der Pol power, contact kinematics, friction, transfer."""

import math

import numpy as np
import pytest

from wheelrom import config
from wheelrom.forces.parameters import OPEN, contact_frame, force_parameters
from wheelrom.forces.reference import ReferenceForces
from wheelrom.rom.model import ReducedModel


def _forces(model, cfg, angles=None):
    """The reference force model of ``cfg`` on ``model``."""
    return ReferenceForces(force_parameters(model, cfg, angles))


def _all_off(cfg):
    return cfg.replace(
        **{
            "flutter.model": "off",
            "excitation.force": 0.0,
            "contacts.tieboss.enabled": False,
            "contacts.shroud.enabled": False,
        }
    )


def test_nozzle_contains_only_nodal_diameter_N_minus_ns(coarse_model, coarse_cfg):
    cfg = _all_off(coarse_cfg).replace(**{"excitation.force": 50.0})
    fm = _forces(coarse_model, cfg)
    N, m = coarse_model.blades, coarse_model.modes
    t = 1.234e-3
    f = fm.evaluate(t, np.zeros((N, m)), np.zeros((N, m))).copy()
    spec = np.abs(np.fft.fft(f, axis=0)).sum(axis=1)
    nd = abs(N - cfg.wheel.stator_vanes)
    big = {nd, N - nd}
    assert all(spec[k] < 1e-9 * spec.max() for k in range(N) if k not in big)
    # phase of eq. 13 on blade s
    omega = 2 * math.pi * cfg.wheel.speed_hz
    s = np.arange(N)
    FE = 50.0 * np.cos(cfg.wheel.stator_vanes * omega * t - 2 * math.pi * (1 - 64 / N) * s)
    np.testing.assert_allclose(f, FE[:, None] * coarse_model.excitation[None, :], atol=1e-12)


@pytest.mark.parametrize("model", ["absolute", "relative"])
def test_van_der_pol_power_sign(coarse_model, coarse_cfg, model):
    # every mode carries the force: y_s = p^T q_s with the whole p below
    cfg = _all_off(coarse_cfg).replace(**{"flutter.model": model, "flutter.mode": -1})
    fm = _forces(coarse_model, cfg)
    N, m = coarse_model.blades, coarse_model.modes
    p = coarse_model.aero
    rng = np.random.default_rng(3)
    v = rng.normal(size=(N, m))
    direction = rng.normal(size=(N, 1)) * p[None, :] / (p @ p)  # y_s = direction_s
    for scale, sign in ((0.2, 1.0), (8.0, -1.0)):  # |y| or |D| below / above r
        q = direction * cfg.flutter.r * scale / np.abs(direction @ p).max()
        f = fm.evaluate(0.0, q, v)
        power = float((f * v).sum())
        assert np.sign(power) == sign
        assert power == pytest.approx(fm.power[1], rel=1e-10)


def test_relative_van_der_pol_is_internal(coarse_model, coarse_cfg):
    cfg = _all_off(coarse_cfg).replace(**{"flutter.model": "relative"})
    fm = _forces(coarse_model, cfg)
    rng = np.random.default_rng(4)
    q, v = rng.normal(size=(2, coarse_model.blades, coarse_model.modes)) * 1e-3
    f = fm.evaluate(0.0, q, v)
    p = coarse_model.aero
    aero_force = f @ p / (p @ p)  # -F_s of every blade
    assert abs(aero_force.sum()) < 1e-12 * np.abs(aero_force).max()


def test_contacts_at_rest_carry_preload_without_friction(coarse_model, coarse_cfg):
    cfg = coarse_cfg.replace(**{"flutter.model": "off", "excitation.force": 0.0})
    fm = _forces(coarse_model, cfg)
    z = np.zeros((coarse_model.blades, coarse_model.modes))
    fm.evaluate(0.0, z, z)
    np.testing.assert_allclose(fm.normal_force, 400.0)
    assert np.all(fm.slip_velocity == 0.0) and fm.power[2] == 0.0


def _point_model(N=8, kind="shroud", H=2.0, l=0.03):
    """A one-'mode' model whose shapes are prescribed point motions (for kinematics)."""
    from wheelrom.segment.builtin import arm_geometry
    from wheelrom.segment.mesh import rotation_z

    phi = 2 * math.pi / N
    alpha, A, B = arm_geometry(H, l, phi)
    model = ReducedModel(
        blades=N,
        modes=3,
        segment_hz=np.ones(3),
        K_seg=np.eye(3),
        A0=np.eye(3),
        A1=np.zeros((3, 3)),
        rotation=rotation_z(phi),
        tip=np.zeros((3, 3)),
        aero=np.zeros(3),
        excitation=np.zeros(3),
    )
    model.contact_A[kind] = np.eye(3)  # q_s = displacement of A_s
    model.contact_B[kind] = np.eye(3)  # B moves with A (rigid translation) unless overridden
    model.contact_points[kind] = np.stack([A, B])
    arm = np.linalg.norm(model.rotation @ A - A)
    cfg = config.load(
        overrides=[
            f"wheel.blades={N}",
            "flutter.model='off'",
            "excitation.force=0.0",
            "contacts.tieboss.enabled=false",
            f"contacts.shroud.arm_length={arm}",
        ]
    )
    return model, cfg, A, B


def test_rigid_wheel_rotation_gives_no_relative_displacement():
    model, cfg, A, B = _point_model()
    # rotation by a small angle theta about z: u = theta ez x X at A and B of every blade
    theta = 1e-6
    ez = np.array([0.0, 0.0, 1.0])
    model.contact_A["shroud"] = np.column_stack([theta * np.cross(ez, A), np.zeros(3), np.zeros(3)])
    model.contact_B["shroud"] = np.column_stack([theta * np.cross(ez, B), np.zeros(3), np.zeros(3)])
    fm = _forces(model, cfg)
    q = np.zeros((8, 3))
    q[:, 0] = 1.0
    fm.evaluate(0.0, q, q)
    scale = theta * np.linalg.norm(A)
    assert abs(fm.relative_displacement).max() < 1e-6 * scale
    assert abs(fm.relative_velocity).max() < 1e-6 * scale


def test_separation_opens_contact():
    model, cfg, A, B = _point_model()
    fm = _forces(model, cfg)
    k = fm.params.contacts.stiffness[0, 0]
    eta = contact_frame(cfg.contacts.shroud.angle_deg)[1]
    q = np.zeros((8, 3))
    v = np.zeros((8, 3))
    R = model.rotation
    q[1] = R.T @ eta * (1.5 * 400.0 / k)  # A_1 moves along +eta (sector 0 frame)
    v[1] = R.T @ np.array([0.0, -np.sin(0.3), np.cos(0.3)]) * 0.1
    fm.evaluate(0.0, q, v)
    assert fm.normal_force[0, 0] == 0.0 and fm.contact_state[0, 0] == OPEN
    q[1] *= 0.5 / 1.5  # closed again: F_n = F_N0 - k g
    fm.evaluate(0.0, q, v)
    assert fm.normal_force[0, 0] == pytest.approx(400.0 - k * 0.5 * 400.0 / k)


def test_arm_transfer_preserves_force_and_moment_about_A():
    model, cfg, A, B = _point_model()
    # blade 0's A and B move independently: two 'modes' each
    model.contact_A["shroud"] = np.hstack([np.eye(3), np.zeros((3, 3))])
    model.contact_B["shroud"] = np.hstack([np.zeros((3, 3)), np.eye(3)])
    model.modes = 6
    # every per-mode array at 6 modes (the kernels read them without bounds checks)
    model.aero, model.excitation, model.tip = np.zeros(6), np.zeros(6), np.zeros((3, 6))
    fm = _forces(model, cfg)
    rng = np.random.default_rng(7)
    q = rng.normal(size=(8, 6)) * 1e-8
    v = rng.normal(size=(8, 6)) * 1e-1
    f = fm.evaluate(0.0, q, v)
    # forces on blade 0 at A and B (its arm end) versus the contact force they replace
    FA, FB = f[0, :3], f[0, 3:]
    # contact force on A_1 in sector 0 frame = R (own-frame force of blade 1 at A) minus the
    # part blade 1 gets as an arm owner (its own arm to blade 2) -> isolate blade 0's arm:
    T = fm.params.contacts.frame[0, 0]
    ul = fm.relative_displacement[0, 0]
    vl = fm.relative_velocity[0, 0]
    Fn = fm.normal_force[0, 0]
    vt = math.hypot(vl[0], vl[2])
    coef = (
        cfg.friction.static * vt / 0.6 if vt <= 0.6 else (0.4 + 0.2 * math.exp(-2.0 * (vt - 0.6)))
    )
    Fl = np.array([-coef * Fn * vl[0] / vt, Fn, -coef * Fn * vl[2] / vt])
    F = T.T @ Fl
    assert Fn == pytest.approx(400.0 - fm.params.contacts.stiffness[0, 0] * ul[1])
    # blade 0 also receives the contact force of blade 7's arm at its own A
    Tp = fm.params.contacts.frame[0, 7]
    vlp = fm.relative_velocity[0, 7]
    Fnp = fm.normal_force[0, 7]
    vtp = math.hypot(vlp[0], vlp[2])
    coefp = 0.6 * vtp / 0.6 if vtp <= 0.6 else 0.4 + 0.2 * math.exp(-2.0 * (vtp - 0.6))
    Fprev = model.rotation.T @ (
        Tp.T @ np.array([-coefp * Fnp * vlp[0] / vtp, Fnp, -coefp * Fnp * vlp[2] / vtp])
    )
    FA_arm = FA - Fprev
    np.testing.assert_allclose(FA_arm + FB, -F, atol=1e-9 * np.abs(F).max())
    Ad = A + q[0, :3]
    Bd = B + q[0, 3:]
    e = (Bd - Ad) / np.linalg.norm(Bd - Ad)
    L = cfg.contacts.shroud.arm_length
    moment_pair = np.cross(Bd - Ad, FB)
    moment_end = np.cross(L * e, -F)
    np.testing.assert_allclose(moment_pair, moment_end, atol=1e-9 * np.abs(moment_end).max())


def test_parameters_of_the_wrong_shape_are_refused():
    model, cfg, A, B = _point_model()
    model.contact_A["shroud"] = np.hstack([np.eye(3), np.zeros((3, 3))])
    model.contact_B["shroud"] = np.hstack([np.zeros((3, 3)), np.eye(3)])
    model.modes = 6  # aero and excitation still at 3 modes: read past their end otherwise
    with pytest.raises(ValueError, match=r"excitation has shape \(3,\), expected \(6,\)"):
        _forces(model, cfg)


def test_friction_power_never_positive(coarse_model, coarse_cfg):
    cfg = coarse_cfg.replace(**{"flutter.model": "off", "excitation.force": 0.0})
    fm = _forces(coarse_model, cfg)
    rng = np.random.default_rng(11)
    for _ in range(50):
        q = rng.normal(size=(coarse_model.blades, coarse_model.modes)) * 1e-5
        v = rng.normal(size=q.shape) * 10 ** rng.uniform(-3, 1)
        fm.evaluate(0.0, q, v)
        assert fm.power[2] <= 0.0


def _slip_power(implementation, model, cfg, speed):
    """Friction power [W] and the slip speeds and normal forces of contacts 0 and 1 when
    blade 1 slides at ``speed`` [m/s] along the tangent xi of contact 0 (it slips against
    arm 0's end and, carrying its own arm 1 along, against blade 2), from the reference
    force model or the compiled kernel."""
    from wheelrom.runtime.environment import petsc
    from wheelrom.transient import bridge
    from wheelrom.transient.problem import WheelProblem

    params = force_parameters(model, cfg)
    N, m = model.blades, model.modes
    q, v = np.zeros((N, m)), np.zeros((N, m))
    v[1] = model.rotation.T @ (params.contacts.frame[0, 0].T @ np.array([speed, 0.0, 0.0]))
    reference = ReferenceForces(params)
    reference.evaluate(0.0, q, v)
    slip, normal = reference.slip_velocity[0, :2], reference.normal_force[0, :2]
    if implementation == "reference":
        return reference.power[2], slip, normal
    problem = WheelProblem(model, cfg, [params], petsc().COMM_SELF)
    state = np.concatenate([q.ravel(), v.ravel(), np.zeros(4)])
    return bridge.evaluate(problem.context, 0.0, state)[2 * N * m + 2], slip, normal


@pytest.mark.parametrize("implementation", ["reference", "compiled"])
def test_friction_law_continuous_at_vk_and_tends_to_dynamic(implementation):
    """The friction power the implementation produces against the law of docs/theory.md
    (f_s = 0.6, f_d = 0.4, d = 2 s/m, v_k = 0.6 m/s): micro-slip f_s v / v_k below v_k,
    f_d + (f_s - f_d) exp(-d (v - v_k)) above; continuous across v_k, f_d far above."""
    model, cfg, A, B = _point_model()

    def law(v):
        return 0.6 * v / 0.6 if v <= 0.6 else 0.4 + 0.2 * math.exp(-2.0 * (v - 0.6))

    powers = {}
    for speed in (0.3, 0.6 * (1 - 1e-9), 0.6 * (1 + 1e-9), 2.0, 40.0):
        power, slip, normal = _slip_power(implementation, model, cfg, speed)
        assert slip[0] == pytest.approx(speed, rel=1e-12) and slip[1] > 0
        expected = -sum(law(v) * fn * v for v, fn in zip(slip, normal, strict=True))
        assert power == pytest.approx(expected, rel=1e-9)
        powers[speed] = power
    below, above = powers[0.6 * (1 - 1e-9)], powers[0.6 * (1 + 1e-9)]
    assert abs(below - above) < 1e-8 * abs(below)  # no jump at v_k
    _, slip, normal = _slip_power(implementation, model, cfg, 40.0)
    friction_0 = -powers[40.0] - law(slip[1]) * normal[1] * slip[1]
    assert friction_0 / (normal[0] * slip[0]) == pytest.approx(0.4, rel=1e-9)


def test_relative_velocity_is_derivative_of_relative_displacement(coarse_model, coarse_cfg):
    cfg = coarse_cfg.replace(**{"flutter.model": "off", "excitation.force": 0.0})
    fm = _forces(coarse_model, cfg)
    rng = np.random.default_rng(5)
    q = rng.normal(size=(coarse_model.blades, coarse_model.modes)) * 1e-3
    v = rng.normal(size=q.shape)
    h = 1e-7
    fm.evaluate(0.0, q + h * v, v)
    up = fm.relative_displacement.copy()
    fm.evaluate(0.0, q - h * v, v)
    um = fm.relative_displacement.copy()
    fm.evaluate(0.0, q, v)
    fd = (up - um) / (2 * h)
    np.testing.assert_allclose(fm.relative_velocity, fd, rtol=1e-5, atol=1e-6 * abs(fd).max())
