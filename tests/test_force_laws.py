"""The control laws of admittance and force control (controller/applications/force_control.py) on their own:
the mass-spring-damper integrated period by period against its closed-form solution, the force PID
against a spring, and the vendor's parameter ranges."""

from __future__ import annotations

import math

import numpy as np
import pytest

from xarm_emu.controller.applications import force_control as fc

DT = 0.004
Z = [0, 0, 1, 0, 0, 0]
M = [0.5] * 3 + [0.005] * 3


State = tuple[np.ndarray, np.ndarray]


def run_admittance(wrench: list[float], K: list[float], B: list[float], seconds: float,
                   x: np.ndarray | None = None, v: np.ndarray | None = None) -> list[State]:
    x = np.zeros(6) if x is None else x
    v = np.zeros(6) if v is None else v
    out = []
    for _ in range(round(seconds / DT)):
        x, v = fc.admittance_update(x, v, np.asarray(wrench, dtype=float), M, K, B, Z, DT)
        out.append((x, v))
    return out


def test_constant_force_without_stiffness_follows_the_mass_damper_law() -> None:
    m, b, f = 0.5, 20.0, 10.0
    trace = run_admittance([0, 0, f, 0, 0, 0], [0.0] * 6, [b] * 3 + [1.0] * 3, 0.6)
    for n in (5, 25, 60, 125):  # 20 ms .. 0.5 s
        t = n * DT
        x, v = trace[n - 1]
        v_law = f / b * (1 - math.exp(-b / m * t))
        x_law = f / b * (t - m / b * (1 - math.exp(-b / m * t)))
        a_law = f / m * math.exp(-b / m * t)
        a = (trace[n][1][2] - trace[n - 2][1][2]) / (2 * DT)
        assert v[2] == pytest.approx(v_law, rel=0.02)
        assert x[2] == pytest.approx(x_law, rel=0.02)
        assert a == pytest.approx(a_law, rel=0.02)
        assert x[[0, 1, 3, 4, 5]].tolist() == [0.0] * 5  # axes not enabled stay put


def test_removing_the_force_lets_the_damping_bring_it_to_rest() -> None:
    pushed = run_admittance([0, 0, 10, 0, 0, 0], [0.0] * 6, [20.0] * 3 + [1.0] * 3, 0.3)
    x0, v0 = pushed[-1]
    released = run_admittance([0.0] * 6, [0.0] * 6, [20.0] * 3 + [1.0] * 3, 0.5, x0, v0)
    x, v = released[-1]
    assert abs(v[2]) < 1e-6
    assert x[2] == pytest.approx(x0[2] + v0[2] * 0.5 / 20.0, rel=1e-3)  # coasts m v0 / b further


def test_with_stiffness_it_settles_at_force_over_stiffness() -> None:
    K = [400.0] * 3 + [4.0] * 3
    trace = run_admittance([0, 0, 10, 0, 0, 0], K, [0.0] * 6, 2.0)  # B = 0: the box's own damping
    x, v = trace[-1]
    assert x[2] * 1000.0 == pytest.approx(10.0 / 400.0 * 1000.0, abs=0.1)  # 25 mm within 0.1 mm
    assert max(s[0][2] for s in trace) <= 10.0 / 400.0 * 1.001  # critically damped: no overshoot


def test_the_discrete_law_is_the_exact_solution_of_an_underdamped_axis() -> None:
    m, k, b, f = 0.2, 800.0, 2.0, 5.0
    wn = math.sqrt(k / m)
    zeta = b / (2 * math.sqrt(k * m))
    wd = wn * math.sqrt(1 - zeta ** 2)
    x = v = 0.0
    (a00, a01, a10, a11), (b0, b1) = fc.discrete_law(m, k, b, DT)
    for _ in range(100):
        x, v = a00 * x + a01 * v + b0 * f, a10 * x + a11 * v + b1 * f
    t = 100 * DT
    x_law = f / k * (1 - math.exp(-zeta * wn * t) * (math.cos(wd * t) + zeta / math.sqrt(1 - zeta ** 2)
                                                      * math.sin(wd * t)))
    assert x == pytest.approx(x_law, rel=1e-9)


def test_zero_damping_means_the_box_damping_at_least_critical() -> None:
    b = fc.effective_damping([0.0, 0.0, 7.0, 0.0, 0.0, 0.5])
    assert b[2] == 7.0 and b[5] == 0.5  # given: kept
    heaviest, stiffest = [1.0] * 3 + [0.01] * 3, [2000.0] * 3 + [20.0] * 3
    critical = [2 * math.sqrt(m * k) for m, k in zip(heaviest, stiffest, strict=True)]
    assert all(b[i] >= critical[i] for i in (0, 1, 3, 4))


def spring_contact(kp: float, ki: float, kd: float, start_mm: float, seconds: float,
                   xe_limit: float = 200.0) -> list[float]:
    """Depth (mm) of a TCP under force control pressing on a 10 N/mm spring from ``start_mm``."""
    pid = fc.Pid()
    depth, out = start_mm, []
    for _ in range(round(seconds / DT)):
        external = -10.0 * max(depth, 0.0)  # the spring pushes back along -z
        v = fc.force_update(pid, -np.array([0, 0, external, 0, 0, 0]), [0, 0, 20, 0, 0, 0], [kp] * 6,
                            [ki] * 6, [kd] * 6, [xe_limit] * 6, Z, DT)
        depth += v[2] * DT
        out.append(depth)
    return out


def test_force_pid_settles_on_the_spring_share() -> None:
    depths = spring_contact(0.005, 0.00005, 0.05, -5.0, 4.0)
    assert 10.0 * depths[-1] == pytest.approx(20.0, abs=0.5)
    assert depths[-1] == pytest.approx(2.0, abs=0.05)
    proportional = spring_contact(0.005, 0.0, 0.0, -5.0, 4.0)
    assert max(proportional) <= 2.0 + 1e-9  # no integral: it never presses deeper than the share


def test_force_pid_speed_is_capped_by_xe_limit() -> None:
    pid = fc.Pid()
    v = fc.force_update(pid, np.zeros(6), [0, 0, 200, 0, 0, 0], [0.05] * 6, [0.0005] * 6, [0.0] * 6,
                        [15.0] * 6, Z, DT)
    assert v[2] == pytest.approx(15.0)
    assert pid.integral[2] == 0.0  # capped: the sum does not wind up
    v = fc.force_update(pid, np.zeros(6), [0, 0, 0.1, 0, 0, 0], [0.005] * 6, [0.0] * 6, [0.0] * 6,
                        [15.0] * 6, Z, DT)
    assert v[2] == pytest.approx(0.005 * 0.1 / DT)  # mm per period per N


@pytest.mark.parametrize("M_, K_, B_, bad", [
    ([0.02] * 3 + [0.0001] * 3, [0.0] * 6, [0.0] * 6, None),
    ([1.0] * 3 + [0.01] * 3, [2000.0] * 3 + [20.0] * 3, [50.0] * 6, None),
    ([0.01] + [0.06] * 2 + [0.001] * 3, [0.0] * 6, [0.0] * 6, "M[0]"),
    ([0.06] * 3 + [0.02] * 3, [0.0] * 6, [0.0] * 6, "M[3]"),
    ([0.06] * 3 + [0.001] * 3, [0.0, 2001.0] + [0.0] * 4, [0.0] * 6, "K[1]"),
    ([0.06] * 3 + [0.001] * 3, [0.0] * 5 + [21.0], [0.0] * 6, "K[5]"),
    ([0.06] * 3 + [0.001] * 3, [0.0] * 6, [0.0] * 4 + [-1.0, 0.0], "B[4]"),
])
def test_admittance_ranges(M_: list[float], K_: list[float], B_: list[float], bad: str | None) -> None:
    problem = fc.mkb_problem(M_, K_, B_)
    assert (problem is None) if bad is None else (problem is not None and problem.startswith(bad))


def test_force_ranges() -> None:
    ok = ([0.05] * 6, [0.0005] * 6, [0.05] * 6, [200.0] * 6)
    assert fc.pid_problem(*ok) is None
    assert fc.pid_problem([0.06] + [0.0] * 5, *ok[1:]) == "kp[0] = 0.06 outside [0, 0.05]"
    assert fc.pid_problem(ok[0], [0.001] * 6, *ok[2:]).startswith("ki[0]")  # type: ignore[union-attr]
    assert fc.pid_problem(*ok[:3], [0.0] * 5 + [201.0]).startswith("xe_limit[5]")  # type: ignore[union-attr]
    assert fc.f_ref_problem([150, -150, 200, 4, -4, 4]) is None
    assert fc.f_ref_problem([0, 0, 200.5, 0, 0, 0]).startswith("f_ref[2]")  # type: ignore[union-attr]
    assert fc.f_ref_problem([0, 0, 0, 0, 0, -4.1]).startswith("f_ref[5]")  # type: ignore[union-attr]
