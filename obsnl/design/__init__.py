"""design: which sensors and which experiment make a model identifiable, before the test is run.

Owns the reverse questions of the analysis: the minimal sets of candidate sensors (the model's outputs)
for which the targets are jointly identifiable (``sensors``, on the sufficiency test of one sensor set:
``sufficiency``); the practical ranking of sufficient sets by the Cramer-Rao bound along a simulated
response, compared with effective independence on the linear part's modes (``ranking``); and the
experiment: the branches a record visits as its scale grows, the smallest scale that makes every target
identifiable and which of several records suffice (``experiment``).

May import: ``errors``, ``executor``, ``model``, ``observability`` (the joint verdict of each candidate
set), ``estimation`` (simulation and the numeric model) and ``identification`` (the output sensitivities
along a record). Must never import ``studies``, ``batch``, ``cli`` or ``report`` (the renderings of its
results live in :mod:`obsnl.report`).
"""
