"""The stiffness test of a step: the balanced bound of the spectral radius, and a driven step judged once.

Expected answers come from numpy's eigenvalues, closed forms written here, and scipy's ``solve_ivp`` (DOP853 at
tight tolerances), never from obsnl's own integrators. The Bouc-Wen structure and values are the published
benchmark's (Noel and Schoukens, "Hysteretic benchmark with a dynamic nonlinearity", 2016), in the identifiable
parameters Delta1 = beta (gamma + delta), Delta2 = beta (gamma - delta).
"""

from __future__ import annotations

import casadi as ca
import numpy as np
from scipy.integrate import solve_ivp

import obsnl
from obsnl.estimation.codegen import to_casadi
from obsnl.estimation.intersample import drive
from obsnl.estimation.numeric import _collatz_wielandt, _perron_bound

M, C, K, ALPHA, D1, D2 = 2.0, 10.0, 5e4, 5e4, -300.0, 1900.0
BOUC_WEN = obsnl.Model(
    name="boucwen",
    states=["y", "v", "z"],
    parameters=["m", "c", "k", "alpha", "Delta1", "Delta2"],
    inputs=["u"],
    equations={
        "y": "v",
        "v": "(-c*v - k*y + u - z)/m",
        "z": "alpha*v - v*(Delta1/2 - Delta2/2)*Abs(z) - z*(Delta1/2 + Delta2/2)*Abs(v)",
    },
    outputs={"y_meas": "y"},
)


def bouc_wen_field(t: float, s: np.ndarray, u: object) -> list[float]:
    y, v, z = s
    return [
        v,
        (-C * v - K * y + u(t) - z) / M,
        ALPHA * v - v * (D1 / 2 - D2 / 2) * abs(z) - z * (D1 / 2 + D2 / 2) * abs(v),
    ]


def test_the_balanced_bound_of_a_bouc_wen_jacobian_is_near_its_spectral_radius():
    # The Jacobian of the field where v = 1.5 mm/s and z = -130 N (a reversal of the benchmark's response), by hand:
    # dz'/dv = alpha - (Delta1/2 - Delta2/2) |z| - z (Delta1/2 + Delta2/2) = 5e4 + 1100*130 + 800*130 = 297000,
    # dz'/dz = -v (Delta1/2 - Delta2/2) sign(z) - (Delta1/2 + Delta2/2) |v| = -1.65 - 1.2 = -2.85.
    J = np.array([[0.0, 1.0, 0.0], [-K / M, -C / M, -1 / M], [0.0, 297000.0, -2.85]])
    A = ca.SX.sym("A", 3, 3)
    bound = float(ca.Function("b", [A], [_perron_bound(A, 3)])(np.abs(J)))
    plain = float(ca.Function("p", [A], [_collatz_wielandt(A, 3, 3)])(np.abs(J)))
    rho = max(abs(np.linalg.eigvals(np.abs(J))))
    assert rho >= max(abs(np.linalg.eigvals(J)))  # what the bound is for: RK4's stability
    assert rho <= bound <= 1.5 * rho
    h = 1 / 750 / 8  # the benchmark's sample over the 8 points of its band-limited input
    assert h * bound < 2.0 < h * plain  # unbalanced, three power iterations alternate: RK4 wrongly taken as unstable


def test_a_driven_bouc_wen_step_is_not_stiff_and_follows_scipy():
    # A multisine in the benchmark's band (5-150 Hz) at 750 Hz, band-limited between samples: obsnl's blocks give
    # 8 points per sample, linear in between, which is the input scipy integrates. 8 substeps a sample: RK4 loses
    # two orders at the kinks of |v| and |z| (the error falls 4x per halving: 2.8e-7, 7.3e-8, 2.1e-8 m at 8, 16, 32
    # substeps over 3000 samples of the benchmark's record), so 1e-6 m here is that order with a margin.
    num = to_casadi(BOUC_WEN)
    dt, T = 1 / 750, 300
    t = np.arange(T) * dt
    u = sum(20.0 * np.sin(2 * np.pi * f * t + ph) for f, ph in ((7.3, 0.1), (41.0, 1.2), (97.0, 2.0), (143.0, 0.7)))
    stepped, B = drive(num, u, ["bandlimited"], periodic=False)
    points = stepped.points
    tp = np.arange(T * points + 1) * dt / points
    up = np.r_[B[:, :points].ravel(), B[-1, points]]
    sol = solve_ivp(
        bouc_wen_field,
        (0.0, t[-1]),
        [0.0, 0.0, 0.0],
        args=(lambda s: np.interp(s, tp, up),),
        method="DOP853",
        rtol=1e-12,
        atol=[1e-16, 1e-13, 1e-10],
        t_eval=t,
        max_step=dt / points,
    )
    theta = [M, C, K, ALPHA, D1, D2]
    out = stepped.step(dt, substeps=8).mapaccum("run", T - 1, [0], [0])(np.zeros(3), theta, B[:-1].T, B[1:].T)
    y = np.r_[0.0, np.asarray(out[0])[0]]
    assert float(np.asarray(out[1]).sum()) == 0.0  # no step taken as stiff: plain RK4 throughout
    assert np.max(np.abs(y - sol.y[0])) < 1e-6
    assert np.max(np.abs(sol.y[0])) > 1e-4  # the response is a hundred times the tolerance


def test_a_driven_step_is_stiff_where_its_end_is_and_then_decays_as_the_exact_solution():
    # x' = -a x + u, the input held over the sample (zero-order hold: blocks of one point): exact
    # x(dt) = u/a + (x0 - u/a) exp(-a dt). With a = 1e5 and 8 substeps of 1/8 ms, a h = 12.5: stiff for RK4 (its
    # stability interval ends at -2.785), taken by ROS2 (L-stable) and flagged; with a = 10 plain RK4, not flagged.
    decay = to_casadi(
        obsnl.Model(
            name="decay", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "-a*x + u"}, outputs={"y": "x"}
        )
    )
    dt, x0, u = 1e-3, 1.0, 3.0
    held = decay.driven(1)
    for a, stiff in ((1e5, 1.0), (10.0, 0.0)):
        x, implicit, refined = held.step(dt, substeps=8)(x0, a, [u, u], [u, u])
        exact = u / a + (x0 - u / a) * np.exp(-a * dt)
        assert (float(implicit), float(refined)) == (stiff, 0.0)
        assert abs(float(x) - exact) <= (1e-3 * abs(exact) if stiff else 1e-12)
