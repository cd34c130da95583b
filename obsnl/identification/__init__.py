"""identification: from measured data (or a simulated experiment) to parameter estimates a user can trust.

Owns the identification workflow on top of the filter core: the experiment set-up and its coordinates
(``setup``), the filter protocol and tuning (``experiments``), practical identifiability at an estimate
(``practical``, with Monte-Carlo replicates on an executor: ``replicates``), the maximum-likelihood
refinement after the filter (``likelihood``) and its profile-likelihood intervals (``profile``), one
identification run as a result value (``runs``, ``results``), and the public entry points that check the
model's structure first (``identify``: :func:`obsnl.identify`, the simulation study, the result folder).

May import: ``errors``, ``executor``, ``model``, ``observability`` (the structural verdict comes first:
``analyze``, the branch-table check), ``estimation`` (the filter core: codegen, numeric steps, simulation,
UKF/DUKF, records) and ``report`` (only to write a result folder). Must never import ``studies``, ``cli``
or ``batch``, and nothing here imports sympy except through ``model``/``observability`` at the door.
"""
