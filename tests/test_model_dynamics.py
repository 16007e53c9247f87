"""Gravity and inverse dynamics torques (register 55, report bytes 60-87) against independent models.

The reference computations here do not use ``model.dynamics``: the zero-pose frames of the xArm6 are
written out by hand from the URDF joint origins, and other poses use a
small forward chain built in this file. Static torques are then the first-principles sum
``tau_j = -z_j . sum_{i>=j} (r_com_i - o_j) x m_i g`` (the motor holds the arm against gravity).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import rx, ry, rz

from xarm_emu.model.calibration import Calibration
from xarm_emu.model.dynamics import (
    gravity_from_direction,
    gravity_torques,
    inverse_dynamics,
    inverse_dynamics_many,
    joint_friction,
    mass_matrix,
    torques_to_currents,
)
from xarm_emu.model.inertials import STANDARD_GRAVITY, get_inertials, torque_constants
from xarm_emu.model.robots import ROBOT_MODELS, XARM5, XARM6, XARM7, RobotModel, with_calibration

G = STANDARD_GRAVITY
DOWN = np.array([0.0, 0.0, -G])

# xArm6 at q = 0, frames of links 1..6 in the base frame, derived by hand (mm):
# link1: identity at (0, 0, 267); link2: Rx(-90) at the same point (its z axis = base +y);
# link3: Rx(-90) at (53.5, 0, 267 + 284.5);
# link4: Rx(-90)Rx(-90) = Rx(180) at (53.5 + 77.5, 0, 551.5 - 342.5);
# link5: Rx(180)Rx(+90) = Rx(-90) at the same point; link6: Rx(-90)Rx(-90) = Rx(180) at
# (131 + 76, 0, 209 - 97) = the flange, (207, 0, 112).
_I = np.eye(3)
_RXM90 = np.array([[1.0, 0, 0], [0, 0, 1], [0, -1, 0]])
_RX180 = np.diag([1.0, -1.0, -1.0])
XARM6_ZERO_FRAMES = [
    (_I, np.array([0.0, 0.0, 267.0])),
    (_RXM90, np.array([0.0, 0.0, 267.0])),
    (_RXM90, np.array([53.5, 0.0, 551.5])),
    (_RX180, np.array([131.0, 0.0, 209.0])),
    (_RXM90, np.array([131.0, 0.0, 209.0])),
    (_RX180, np.array([207.0, 0.0, 112.0])),
]


def static_torques(frames, model: RobotModel, g, payload_mass=0.0, payload_com=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Holding torques from link frames (R, origin mm) by the lever-arm sum, in N.m."""
    links = get_inertials(model).links
    masses = [(lk.mass, r @ np.asarray(lk.com) + o) for lk, (r, o) in zip(links, frames, strict=True)]
    r_n, o_n = frames[-1]
    if payload_mass:
        masses.append((payload_mass, r_n @ np.asarray(payload_com, dtype=float) + o_n))
    tau = np.zeros(len(frames))
    for j, (r_j, o_j) in enumerate(frames):
        z_j = r_j[:, 2]
        # bodies beyond joint j: links j..n-1 and the payload (last entry when present)
        moment = sum(np.cross((pos - o_j) / 1000.0, m * np.asarray(g)) for m, pos in masses[j:])
        tau[j] = -float(np.dot(z_j, moment))
    return tau


def chain_frames(model: RobotModel, q) -> list[tuple[np.ndarray, np.ndarray]]:
    """Independent forward chain: Trans(xyz) . Rz Ry Rx(rpy) . Rz(q) per joint, mm."""


    r, o = np.eye(3), np.zeros(3)
    frames = []
    for joint, qi in zip(model.joints, q, strict=True):
        o = o + r @ np.asarray(joint.origin_xyz)
        roll, pitch, yaw = joint.origin_rpy
        r = r @ rz(yaw) @ ry(pitch) @ rx(roll) @ rz(qi)
        frames.append((r, o))
    return frames


def check_close(actual: np.ndarray, expected: np.ndarray, rel: float = 0.01, floor: float = 1e-3) -> None:
    """Per joint within ``rel`` of the expected value (or ``floor`` N.m for values near zero)."""
    tol = np.maximum(rel * np.abs(expected), floor)
    assert np.all(np.abs(actual - expected) <= tol), (actual, expected)


def test_hand_frames_reach_the_zero_pose_flange():
    # The hand-derived frames agree with the model's zero pose and with the independent chain.
    assert np.allclose(XARM6_ZERO_FRAMES[-1][1], XARM6.zero_pose[:3])
    for (r_h, o_h), (r_c, o_c) in zip(XARM6_ZERO_FRAMES, chain_frames(XARM6, np.zeros(6)), strict=True):
        assert np.allclose(r_h, r_c, atol=1e-12) and np.allclose(o_h, o_c, atol=1e-9)


def test_xarm6_zero_pose_gravity_matches_hand_computation():
    expected = static_torques(XARM6_ZERO_FRAMES, XARM6, DOWN)
    tau = gravity_torques(XARM6, np.zeros(6))
    check_close(tau, expected)
    # The xArm6 signature (manual register 55 example): J2, J3, J5 loaded and negative; J1, J4, J6 zero.
    assert tau[1] < -5 and tau[2] < -3 and tau[4] < -0.5
    assert np.all(np.abs(tau[[0, 3, 5]]) < 1e-9)


@pytest.mark.parametrize("model, published", [
    # published zero-pose gravity torques of the vendor's HT_BR2 inertial sets, 3 decimals
    (XARM5, [0, -6.225, -3.528, -0.965, 0]),
    (XARM6, [0, -7.756, -4.424, 0, -0.982, 0]),
    (XARM7, [0, -7.390, 0, 4.298, 0, -0.968, 0]),
])
def test_zero_pose_matches_published_torques(model, published):
    assert np.allclose(gravity_torques(model, np.zeros(model.dof)), published, atol=1.5e-3)


def test_one_kg_flange_payload_adds_weight_times_lever_arm():
    base = gravity_torques(XARM6, np.zeros(6))
    loaded = gravity_torques(XARM6, np.zeros(6), payload_mass=1.0)
    delta = loaded - base
    # Horizontal lever arms from the joint axes (hand frames) to the flange at x = 207 mm.
    x_flange = 207.0
    levers = {1: x_flange - 0.0, 2: x_flange - 53.5, 4: x_flange - 131.0}
    for j, lever in levers.items():
        assert delta[j] == pytest.approx(-1.0 * G * lever / 1000.0, rel=1e-9)
    assert np.all(np.abs(delta[[0, 3, 5]]) < 1e-9)
    # Same through the lever-arm sum, and with an offset payload COM (flange x = base x at q = 0).
    check_close(loaded, static_torques(XARM6_ZERO_FRAMES, XARM6, DOWN, 1.0), rel=1e-6, floor=1e-9)
    off = gravity_torques(XARM6, np.zeros(6), payload_mass=1.0, payload_com=(10.0, 0.0, 50.0))
    assert off[1] - loaded[1] == pytest.approx(-G * 0.010, rel=1e-9)
    check_close(off, static_torques(XARM6_ZERO_FRAMES, XARM6, DOWN, 1.0, (10.0, 0.0, 50.0)),
                rel=1e-6, floor=1e-9)


def test_gravity_along_plus_x_changes_the_pattern():
    g_x = gravity_from_direction((1.0, 0.0, 0.0))
    assert np.allclose(g_x, [G, 0.0, 0.0])
    tau = gravity_torques(XARM6, np.zeros(6), gravity=g_x)
    check_close(tau, static_torques(XARM6_ZERO_FRAMES, XARM6, g_x))
    down = gravity_torques(XARM6, np.zeros(6))
    # Horizontal gravity: the shoulder is loaded by the COM heights relative to J2 instead of the reach,
    # and the vertical J1/J4/J6 axes now carry torque from the COMs' y offsets.
    assert abs(tau[1] - down[1]) > 1.0
    assert abs(tau[0]) > 0.1 and abs(tau[3]) > 1e-3


def test_gravity_direction_is_scaled_to_standard_gravity():
    assert np.allclose(gravity_from_direction((0, 0, -2.0)), DOWN)
    assert np.allclose(gravity_from_direction((0, 3.0, -4.0)), [0, 0.6 * G, -0.8 * G])
    with pytest.raises(ValueError):
        gravity_from_direction((0, 0, 0))


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7])
def test_gravity_at_random_poses_matches_independent_chain(model):
    rng = np.random.default_rng(7)
    for _ in range(20):
        q = rng.uniform(model.lower, model.upper)
        g = rng.normal(size=3)
        g *= G / np.linalg.norm(g)
        pm, pc = rng.uniform(0, 3), rng.uniform(-80, 80, 3)
        expected = static_torques(chain_frames(model, q), model, g, pm, pc)
        assert np.allclose(gravity_torques(model, q, g, pm, pc), expected, atol=1e-9)
        # at rest, inverse dynamics is the gravity torque
        zero = np.zeros(model.dof)
        assert np.allclose(inverse_dynamics(model, q, zero, zero, g, pm, pc), expected, atol=1e-9)


def test_base_rotation_symmetry():
    rng = np.random.default_rng(1)
    q = rng.uniform(XARM6.lower, XARM6.upper)
    ref = gravity_torques(XARM6, q)
    for theta in (0.3, 1.7, -2.9):
        q2 = q.copy()
        q2[0] += theta
        # vertical gravity: turning J1 changes nothing
        assert np.allclose(gravity_torques(XARM6, q2), ref, atol=1e-12)
        # turning J1 together with a horizontal gravity direction changes nothing either
        g = np.array([G * 0.6, G * 0.8, 0.0])
        c, s = math.cos(theta), math.sin(theta)
        g2 = np.array([c * g[0] - s * g[1], s * g[0] + c * g[1], 0.0])
        assert np.allclose(gravity_torques(XARM6, q2, g2), gravity_torques(XARM6, q, g), atol=1e-12)


def kinetic_energy(model, q, qd, pm=0.0):
    m = mass_matrix(model, q, pm)
    return 0.5 * qd @ m @ qd


def potential_energy(model, q, g, pm=0.0):
    """-sum m g.r over the links (and a payload at the flange origin), from the independent chain."""
    frames = chain_frames(model, q)
    pe = 0.0
    for lk, (r, o) in zip(get_inertials(model).links, frames, strict=True):
        pe -= lk.mass * np.dot(g, (r @ np.asarray(lk.com) + o) / 1000.0)
    pe -= pm * np.dot(g, frames[-1][1] / 1000.0)
    return pe


@pytest.mark.parametrize("model", [XARM6, XARM7])
def test_mass_matrix_symmetric_positive_definite(model):
    rng = np.random.default_rng(3)
    for _ in range(5):
        m = mass_matrix(model, rng.uniform(model.lower, model.upper), 1.5)
        assert np.allclose(m, m.T, atol=1e-12)
        assert np.linalg.eigvalsh(m).min() > 0


@pytest.mark.parametrize("model", [XARM5, XARM6, XARM7])
def test_velocity_terms_follow_lagrange_equations(model):
    # Coriolis/centrifugal torques h(q, qd) = dM/dt qd - 1/2 d/dq (qd' M qd), with M from mass_matrix and
    # derivatives by central differences. (Gyroscopic terms do no work, so the power balance below alone
    # would not see them.)
    rng = np.random.default_rng(5)
    n, eps, pm = model.dof, 1e-6, 0.8
    q = rng.uniform(model.lower, model.upper)
    qd = rng.uniform(-2, 2, n)
    dm = []
    for k in range(n):
        e = np.zeros(n)
        e[k] = eps
        dm.append((mass_matrix(model, q + e, pm) - mass_matrix(model, q - e, pm)) / (2 * eps))
    m_dot = sum(dm[k] * qd[k] for k in range(n))
    grad = np.array([qd @ dm[k] @ qd for k in range(n)])
    expected = m_dot @ qd - 0.5 * grad
    h = inverse_dynamics(model, q, qd, np.zeros(n), (0, 0, 0), pm)
    assert np.abs(expected).max() > 0.05
    assert np.allclose(h, expected, atol=1e-6)


@pytest.mark.parametrize("model", [XARM6, XARM7])
def test_power_balance_along_a_trajectory(model):
    # Work done by the joint torques equals the change of kinetic + potential energy.
    n = model.dof
    rng = np.random.default_rng(11)
    q0 = rng.uniform(-1, 1, n) * 0.5
    amp, omega, phase = rng.uniform(0.2, 0.6, n), rng.uniform(1.0, 3.0, n), rng.uniform(0, 6, n)
    pm = 1.2

    def traj(t):
        return (q0 + amp * np.sin(omega * t + phase),
                amp * omega * np.cos(omega * t + phase),
                -amp * omega**2 * np.sin(omega * t + phase))

    t_end, steps = 0.8, 800
    ts = np.linspace(0, t_end, steps + 1)
    power = []
    for t in ts:
        q, qd, qdd = traj(t)
        power.append(qd @ inverse_dynamics(model, q, qd, qdd, DOWN, pm))
    power = np.asarray(power)
    h = t_end / steps
    work = h / 3 * (power[0] + power[-1] + 4 * power[1:-1:2].sum() + 2 * power[2:-1:2].sum())  # Simpson
    (qa, qda, _), (qb, qdb, _) = traj(0.0), traj(t_end)
    d_energy = (kinetic_energy(model, qb, qdb, pm) - kinetic_energy(model, qa, qda, pm)
                + potential_energy(model, qb, DOWN, pm) - potential_energy(model, qa, DOWN, pm))
    assert abs(d_energy) > 0.5  # a real exchange of energy, not a trivial zero
    assert work == pytest.approx(d_energy, rel=1e-6, abs=1e-6)


def test_currents_use_torque_constants_and_speed():
    tau = gravity_torques(XARM6, np.zeros(6))
    amps = torques_to_currents(XARM6, tau)
    assert np.allclose(amps * torque_constants(6), tau)
    assert 0.5 < abs(amps[1]) < 5.0  # plausible holding current at the shoulder
    import time

    t0 = time.perf_counter()
    for _ in range(200):
        inverse_dynamics(XARM7, np.full(7, 0.3), np.ones(7), np.ones(7), DOWN, 1.0, (0, 0, 50))
    per_call = (time.perf_counter() - t0) / 200
    assert per_call < 0.002  # comfortably inside the 4 ms control period


# --- joint temperatures (controller.thermal), driven by the currents of the dynamics model --------------


def test_thermal_model_heats_with_current_squared_and_settles():
    from xarm_emu.controller.core.thermal import AMBIENT_C, THERMAL_BY_SIZE, ThermalModel

    amps = np.abs(torques_to_currents(XARM6, gravity_torques(XARM6, np.zeros(6), payload_mass=1.0)))
    model = ThermalModel(6)
    assert np.allclose(model.temperatures, AMBIENT_C)
    # after one time constant of a joint, 1 - 1/e of the way to its steady state (exact update)
    tau_l = THERMAL_BY_SIZE["L"].time_constant  # J1 is a large joint
    settle = model.steady_state(amps)
    t = model.step(tau_l, amps)
    assert t[0] == pytest.approx(AMBIENT_C + (settle[0] - AMBIENT_C) * (1 - math.exp(-1)), rel=1e-12)
    # many small steps (the 4 ms period) agree with one big step
    small = ThermalModel(6)
    for _ in range(2500):
        small.step(0.004, amps)
    big = ThermalModel(6)
    big.step(10.0, amps)
    assert np.allclose(small.temperatures, big.temperatures, atol=1e-9)
    # hours later: settled, plausible, and the more loaded joint runs hotter; rise grows with I^2
    model.step(5 * 3600.0, amps)
    temps = model.temperatures
    assert np.allclose(temps, settle)
    assert np.all((temps > AMBIENT_C) & (temps < 60.0))
    assert temps[1] > temps[0] + 3.0  # J2 holds the arm, J1 carries nothing
    rise_1 = ThermalModel(6).steady_state(np.full(6, 1.0)) - ThermalModel(6).steady_state(np.zeros(6))
    rise_2 = ThermalModel(6).steady_state(np.full(6, 2.0)) - ThermalModel(6).steady_state(np.zeros(6))
    assert np.allclose(rise_2, 4 * rise_1)
    assert model.celsius_u8() == [round(x) for x in temps]
    # no current: cools back towards ambient + idle rise
    model.step(5 * 3600.0, np.zeros(6))
    assert np.allclose(model.temperatures, model.steady_state(np.zeros(6)))


def test_payload_torque_is_flange_jacobian_transpose_of_its_weight():
    # Cross-check against model.kinematics: a point payload at the flange adds -J_v^T (m g).
    from xarm_emu.model.kinematics import jacobian

    rng = np.random.default_rng(2)
    for model in (XARM5, XARM6, XARM7):
        for _ in range(5):
            q = rng.uniform(model.lower, model.upper)
            delta = gravity_torques(model, q, payload_mass=2.0) - gravity_torques(model, q)
            j_v = jacobian(model, q)[:3] / 1000.0  # m/rad
            assert np.allclose(delta, -j_v.T @ (2.0 * DOWN), atol=1e-9)


def test_manual_register55_example_under_a_vertical_forearm_hypothesis():
    # Manual register 55 example bytes (J2, J3, J5). One unconfirmed reading explains them as an
    # xArm6 with forearm and tool vertical (J2 = -J3 = 9.8 deg) carrying 1.2 kg at cx = -4 mm (HT_BR2 fit).
    import struct

    raw = [bytes([0x2A, 0xC5, 0x5B, 0xC1]), bytes([0x79, 0xA4, 0xC5, 0xC0]), bytes([0x87, 0xA3, 0xE9, 0xBF])]
    j2, j3, j5 = (struct.unpack("<f", b)[0] for b in raw)
    a = math.radians(9.8)
    tau = gravity_torques(XARM6, [0, a, -a, 0, 0, 0], payload_mass=1.2, payload_com=(-4.0, 0.0, 0.0))
    assert np.allclose(tau[[1, 2, 4]], [j2, j3, j5], atol=0.05)
    assert np.all(np.abs(tau[[0, 3, 5]]) < 1e-9)


@pytest.mark.parametrize("key", sorted(ROBOT_MODELS))
def test_many_states_at_once_give_each_state_s_torques(key):
    """The array recursion (a replay's batch) equals the per-state one for random states, a tilted
    gravity and a payload; friction and currents of a calibrated model come out row by row."""
    model = ROBOT_MODELS[key]
    rng = np.random.default_rng(7)
    q, qd, qdd = (rng.uniform(-lim, lim, (40, 7)) for lim in (2.5, 2.0, 8.0))
    g = (1.5, -2.0, -9.3)
    many = inverse_dynamics_many(model, q, qd, qdd, g, 1.3, (10.0, -20.0, 45.0))
    assert many.shape == (40, model.dof)
    one = np.array([inverse_dynamics(model, q[i], qd[i], qdd[i], g, 1.3, (10.0, -20.0, 45.0))
                    for i in range(40)])
    np.testing.assert_allclose(many, one, rtol=0, atol=1e-9)
    cal = with_calibration(model, Calibration(viscous_friction=(0.5,) * model.dof,
                                              coulomb_friction=(0.2,) * model.dof))
    friction = joint_friction(cal, qd)
    assert friction is not None and friction.shape == (40, model.dof)
    np.testing.assert_allclose(friction[3], joint_friction(cal, qd[3]))
    np.testing.assert_allclose(torques_to_currents(model, many)[5], torques_to_currents(model, many[5]))
