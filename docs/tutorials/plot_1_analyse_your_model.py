"""
1. Analyse your own model
=========================

A model is a set of differential equations, the roles of its symbols (states, parameters, inputs) and the outputs
your sensors measure. obsnl answers, before any data are taken, which states and parameters those outputs reveal.

Here a single-storey frame with a Bouc-Wen hysteretic element under a measured ground acceleration ``ag``, of which
only the relative displacement ``x`` is measured.
"""

# %%
# The model
# ---------
# Every symbol is declared in its role; the equations are written in sympy's syntax. ``sign`` and ``Abs`` make the
# model non-smooth: obsnl splits it into smooth branches, one per sign pattern of the switching functions.
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

import obsnl
from obsnl import report
from obsnl.model import split_branches

model = obsnl.Model(
    name="bouc_wen_sdof",
    description="Bouc-Wen hysteretic oscillator under a measured ground acceleration",
    states=["x", "v", "z"],
    parameters=["c_m", "k1", "k2", "A", "beta", "gamma", "n"],
    inputs=["ag"],
    equations={
        "x": "v",
        "v": "-c_m*v - k1*x - k2*z - ag",
        "z": "v*(A - (beta*sign(v*z) + gamma)*Abs(z)**n)",
    },
    outputs={"y": "x"},  # only the displacement is measured
)
print(model)

# %%
# The branches
# ------------
# ``sign(v*z)`` is factored into its two switching functions ``v`` and ``z``, so the model has four smooth branches.
for branch in split_branches(model):
    print(f"({branch.label})", branch.guard_text)

# %%
# A response visits them all: here one simulated with scipy (values chosen for the picture only), each sample
# coloured by its branch. The loop of the hysteretic force ``k2*z`` against ``x`` is the engineer's view of it.
values = {"c_m": 0.6, "k1": 25.0, "k2": 40.0, "A": 1.0, "beta": 150.0, "gamma": 250.0, "n": 2.0}
t = np.linspace(0.0, 12.0, 3001)
ag = 2.0 * np.sin(5.6 * t) * np.exp(-0.1 * t)


def rhs(tt, s, p=values):
    x, v, z = s
    a = np.interp(tt, t, ag)
    dz = v * (p["A"] - (p["beta"] * np.sign(v * z) + p["gamma"]) * abs(z) ** p["n"])
    return [v, -p["c_m"] * v - p["k1"] * x - p["k2"] * z - a, dz]


sol = solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="Radau", rtol=1e-8, atol=1e-10)
x, v, z = sol.y
label = np.where(z > 0, np.where(v > 0, "a", "b"), np.where(v < 0, "c", "d"))

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4))
ax1.plot(t, x, color="0.7", lw=0.8)
for name, colour in zip("abcd", ["C0", "C1", "C2", "C3"]):
    on = label == name
    ax1.plot(t[on], x[on], ".", ms=2, color=colour, label=f"branch ({name}): {on.mean():.0%} of the time")
    ax2.plot(x[on], values["k2"] * z[on], ".", ms=2, color=colour)
ax1.set(xlabel="time (s)", ylabel="displacement x", title="the response, by branch")
ax1.legend(fontsize=8, markerscale=4)
ax2.set(xlabel="displacement x", ylabel="hysteretic force k2*z", title="the hysteresis loop")
fig.tight_layout()

# %%
# The analysis
# ------------
# :func:`obsnl.analyze` tests every branch (Sedoglavic's randomized test, exact modulo a prime) and then the branches
# together: the *joint verdict*. ``seed`` makes it reproducible; the error probability is printed with it.
result = obsnl.analyze(model, seed=0)
print(result.summary())

# %%
# The joint verdict first, then the union over branches (observable in at least one branch), then each branch.
# Here neither is complete: the displacement cannot tell ``z``, ``k2``, ``A``, ``beta``, ``gamma`` apart.
print("jointly unobservable:", result.joint.unobservable)
print("union over branches, unobservable:", result.overall_unobservable)

# %%
# The same result as a Markdown table (``report.to_latex`` writes the paper's LaTeX), one column per group of
# identical branches.
print(report.to_markdown(result))

# %%
# The branch table
# ----------------
# The JSON contract between the analysis and the estimators: per branch, which parameters the DUKF must freeze. It is
# made from an analysis with :func:`obsnl.report.branch_table`; a table made for another model is refused. The next
# tutorial makes this model identifiable first; a table of the original model would freeze the five parameters
# above in every branch.
table = report.branch_table(result, model)
print(table.to_json()[:600], "...")
