"""
4. Choose the sensors and the strength of the test
==================================================

Before the test: which of the quantities one could measure make every parameter identifiable, and how strong the
excitation must be for the branches that hold the rest (a gap, a yield displacement) to be reached.

An oscillator meets a contact spring ``kc`` once its displacement passes the gap ``g``. Three candidate sensors are
written as outputs: the displacement, the velocity and the contact force.
"""

# %%
# Which sensors
# -------------
# :func:`obsnl.sensors` returns every minimal set of the candidate outputs for which the targets (here every state
# and parameter) are jointly identifiable. A superset of a sufficient set is sufficient, so the search stops early.
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

import obsnl
from obsnl.design import design, rank_sensor_sets

model = obsnl.Model(
    name="gap", states=["x", "v"], parameters=["c", "k", "kc", "g"], inputs=["u"],
    equations={"x": "v", "v": "u - c*v - k*x - kc*Max(x - g, 0)"},
    outputs={"disp": "x", "vel": "v", "contact": "kc*Max(x - g, 0)"},
    values={"c": 0.2, "k": 4.0, "kc": 40.0, "g": 0.05},
)
search = obsnl.sensors(model, seed=0)
print(search.summary())

# %%
# Each sensor alone suffices, structurally. Which one informs the parameters best along a given test is a practical
# question: :func:`obsnl.design.rank_sensor_sets` ranks sets by the Cramér-Rao bound of the parameters along the
# response of the model's ``[values]`` (1 % noise on each output, the initial state unknown).
t = np.arange(1000) * 0.01
force = np.sin(1.3 * t)
ranking = rank_sensor_sets(model, [["disp"], ["vel"], ["contact"]], t=t, inputs={"u": 0.2 * force})
for row in ranking.rows:
    print(f"{'+'.join(row.sensors):8s} worst relative std {100 * row.worst_relative_std:.2f} % ({row.worst})")

fig, ax = plt.subplots(figsize=(7, 3.4))
width = 0.25
for i, row in enumerate(ranking.rows):
    ax.bar(np.arange(len(ranking.parameters)) + (i - 1) * width, 100 * np.asarray(row.relative_std), width,
           label="+".join(row.sensors))
ax.set_xticks(range(len(ranking.parameters)), ranking.parameters)
ax.set_yscale("log")
ax.set(ylabel="Cramér-Rao std (% of the value)", title="which sensor informs which parameter (u = 0.2 sin 1.3t)")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# How strong a test
# -----------------
# Below some amplitude the oscillator never closes the gap: the contact branch is never visited and ``kc`` and ``g``
# cannot be identified from any sensor. :func:`obsnl.design.design` simulates the model's ``[values]`` under the
# record scaled by ``s``, finds the branches visited at each scale and bisects for the smallest scale at which the
# targets are jointly identifiable.
plan = design(model, [("sine", t, {"u": 0.1 * force})], sensors=["disp"], seed=0)
print(plan.summary())

# %%
# ``min_scale`` is structural: which branches the record visits, not whether so small a contact is measured well
# enough. The time spent in contact as the scale grows, and the response on either side of ``min_scale``:
scales = np.array([v.scale for v in plan.visits])
contact = np.array([sum(b.seconds for b in v.branches if b.label == "b") for v in plan.visits])
order = np.argsort(scales)


def response(scale):
    p = {name: float(value) for name, value in model.values.items()}

    def rhs(tt, s):
        x, v = s
        u = scale * 0.1 * np.sin(1.3 * tt)
        return [v, u - p["c"] * v - p["k"] * x - p["kc"] * max(x - p["g"], 0.0)]

    return solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0], t_eval=t, max_step=0.01, rtol=1e-9, atol=1e-12).y[0]


fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
ax1.semilogx(scales[order], contact[order], ".-")
ax1.axvline(plan.min_scale, color="C3", ls="--", label=f"min_scale = {plan.min_scale:.4g}")
ax1.set(xlabel="scale of the record", ylabel="seconds in contact (branch b)", title="branches visited")
ax1.legend(fontsize=8)
for s in (0.9 * plan.min_scale, 1.1 * plan.min_scale):
    ax2.plot(t, response(s), label=f"scale {s:.3g}")
ax2.axhline(float(model.values["g"]), color="k", lw=0.8, ls=":", label="gap g")
ax2.set(xlabel="time (s)", ylabel="displacement x", title="just below and just above min_scale")
ax2.legend(fontsize=8)
fig.tight_layout()
