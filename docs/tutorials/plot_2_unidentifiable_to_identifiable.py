"""
2. From unidentifiable to identifiable
======================================

The first tutorial found five quantities of the Bouc-Wen oscillator that the displacement does not reveal. Here
obsnl says *why* (the symmetries of the model that leave the output unchanged) and writes the model in the
combinations that the output does reveal (:func:`obsnl.reparametrize`).
"""

# %%
# The symmetries
# --------------
# :func:`obsnl.symmetries` takes a smooth model, so one branch at a time. Each generator is a direction in which the
# states and parameters can move without changing the output, verified symbolically.
import matplotlib.pyplot as plt
import numpy as np
from scipy.integrate import solve_ivp

import obsnl
from obsnl import report
from obsnl.model import split_branches

model = obsnl.Model(
    name="bouc_wen_sdof",
    states=["x", "v", "z"],
    parameters=["c_m", "k1", "k2", "A", "beta", "gamma", "n"],
    inputs=["ag"],
    equations={
        "x": "v",
        "v": "-c_m*v - k1*x - k2*z - ag",
        "z": "v*(A - (beta*sign(v*z) + gamma)*Abs(z)**n)",
    },
    outputs={"y": "x"},
)
branch_a = split_branches(model)[0]
print(obsnl.symmetries(branch_a.model).summary())

# %%
# Two of them: in branch (a) only ``beta + gamma`` enters (the translation), and a scaling of the hysteretic
# variable. Its flow, ``z -> lam*z``, ``k2 -> k2/lam``, ``A -> lam*A``, ``beta, gamma -> lam**(1-n) * (beta, gamma)``,
# changes the hidden state but not the displacement: two parameter sets that no record can tell apart.
lam = 2.0
p1 = {"c_m": 0.6, "k1": 25.0, "k2": 40.0, "A": 1.0, "beta": 150.0, "gamma": 250.0, "n": 2.0}
p2 = dict(p1, k2=p1["k2"] / lam, A=lam * p1["A"], beta=lam ** (1 - p1["n"]) * p1["beta"],
          gamma=lam ** (1 - p1["n"]) * p1["gamma"])
t = np.linspace(0.0, 8.0, 2001)
ag = 2.0 * np.sin(5.6 * t)


def simulate(p):
    def rhs(tt, s):
        x, v, z = s
        dz = v * (p["A"] - (p["beta"] * np.sign(v * z) + p["gamma"]) * abs(z) ** p["n"])
        return [v, -p["c_m"] * v - p["k1"] * x - p["k2"] * z - np.interp(tt, t, ag), dz]

    return solve_ivp(rhs, (t[0], t[-1]), [0.0, 0.0, 0.0], t_eval=t, method="Radau", rtol=1e-10, atol=1e-12).y


s1, s2 = simulate(p1), simulate(p2)
print("largest difference of the displacements:", np.max(np.abs(s1[0] - s2[0])), "(integrator tolerance)")

fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
ax1.plot(t, s1[0], label=f"k2={p1['k2']:g}, A={p1['A']:g}")
ax1.plot(t, s2[0], "--", label=f"k2={p2['k2']:g}, A={p2['A']:g}")
ax1.set(xlabel="time (s)", ylabel="displacement x (measured)", title="the output: identical")
ax1.legend(fontsize=8)
ax2.plot(t, s1[2], label="z, first set")
ax2.plot(t, s2[2], "--", label="z, second set")
ax2.set(xlabel="time (s)", ylabel="hysteretic variable z", title="the hidden state: scaled by 2")
ax2.legend(fontsize=8)
fig.tight_layout()

# %%
# The identifiable model
# ----------------------
# :func:`obsnl.reparametrize` takes the invariants of these symmetries, merges them over the branches and writes
# the model in them: ``z_p = z/A``, ``k2_p = A*k2`` and two new parameters ``Delta1``, ``Delta2`` (the seed paper's
# device), one per pair of branches. ``A`` is normalised away (set to 1, assumed positive, as the description says).
rep = obsnl.reparametrize(model)
print(rep.summary())
print(rep.model)

# %%
# The new model is what a record can identify: jointly every state and parameter, while each branch alone still
# misses one of the Deltas (``Delta1`` acts only where ``v*z > 0``, ``Delta2`` only where ``v*z < 0``).
new = obsnl.analyze(rep.model, seed=0)
print(new.summary())

# %%
# As a model file (``[definitions]`` gives each new symbol in the old ones; ``obsnl reparametrize MODEL -o NEW.toml``
# writes the same from the command line), and the branch table the DUKF reads for it.
print(rep.to_toml())
table = report.branch_table(new, rep.model)
for b in table.to_dict()["branches"]:
    print(f"({b['label']}) {b['guard']}: the DUKF freezes {b['unidentifiable_parameters']}")
