"""The tuning of the seed experiment's filters: one rung of successive halving on unreported noise seeds.

The tuning seeds are noise seeds of the record at hand (the experiment's own ground motion, never another's):
``obsnl reproduce --record`` tunes on that record. Each reported run then confirms the choice on its own data
(:func:`obsnl.studies.seed_runs.reported_with_fallbacks`).

Every configuration of the grid runs on the first tuning seed; the best :data:`HALVING_KEEP` of each protocol
(one pass, and the refined protocol's passes) go on to the other tuning seeds (:func:`successive_halving`); the
same procedure for both filters. :func:`tuning_protocol` says in one sentence how the configurations were chosen
(written into ``table2.json``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from obsnl.identification.experiments import Tuning

__all__ = ["TUNING_SEEDS", "HALVING_KEEP", "successive_halving", "tuning_protocol"]

#: Noise seeds of the tuning (never reported): 1000, 1001, ...; five by default.
TUNING_SEEDS = 1000
#: Successive halving of the tuning: after the first tuning seed, the best ``HALVING_KEEP`` configurations of
#: each protocol (one pass, and ``passes``) go on to the other tuning seeds (one rung, a quarter of the
#: 48-configuration grid per protocol; the union of the two protocols' survivors runs). The maximum-likelihood
#: refinement starts from the tuned filter's estimate and needs only its basin, which the survivors reach.
HALVING_KEEP = 12


def tuning_protocol(
    keep: int | None, n_grid: int, n_seeds: int, n_runs: int, *, floor: float | None = None, candidates: int = 1
) -> str:
    """One sentence on how the configurations were chosen.

    Parameters
    ----------
    keep : int or None
        Survivors per protocol after the first tuning seed (None: the full grid on every seed).
    n_grid : int
        Configurations of the grid.
    n_seeds : int
        Tuning seeds.
    n_runs : int
        Runs of the tuning, both filters together.
    floor : float or None
        The reported runs' noise floor in times the output noise level (None: not said).
    candidates : int
        Configurations of the ranking a reported run may try on its own data.

    Returns
    -------
    str

    Examples
    --------
    >>> tuning_protocol(None, 48, 5, 480)
    'full grid: 48 configurations x 5 tuning seed(s) per filter (480 runs); the smallest mean free-run output misfit wins'
    """
    on_record = (
        ""
        if floor is None
        else f"; each reported seed confirms the choice on its own data (free-run output misfit at most {floor:g}x "
        f"the noise level), else the next configurations of the ranking run on those data, at most {candidates} in "
        f"all, and the smallest misfit there is reported"
    )
    if keep is None or keep >= n_grid or n_seeds < 2:
        return (
            f"full grid: {n_grid} configurations x {n_seeds} tuning seed(s) per filter ({n_runs} runs); the smallest "
            f"mean free-run output misfit wins{on_record}"
        )
    return (
        f"successive halving: {n_grid} configurations on the first tuning seed, the best {keep} of each protocol "
        f"(one pass, refined) on the other {n_seeds - 1}, each as far as the protocols it was kept for ({n_runs} "
        f"runs for both filters); per protocol, the smallest mean free-run output misfit over the tuning seeds "
        f"wins among the configurations that ran on all of them{on_record}"
    )


def successive_halving(
    names: Sequence[str],
    grid: Sequence[Tuning],
    seeds: Sequence[int],
    run: Any,
    *,
    keep: int | None,
    protocols: Sequence[int],
) -> tuple[dict[tuple[str, int], tuple[list[Tuning], dict[Tuning, float]]], dict[tuple[str, Tuning, int], int]]:
    """Tune each filter by one rung of successive halving: every configuration on ``seeds[0]`` scored for every
    protocol, then the best ``keep`` of each protocol on the other seeds, each run only as far as the protocols it
    goes on for (a configuration kept for the one-pass protocol alone runs one pass there).

    Parameters
    ----------
    names : sequence of str
        The filters.
    grid : sequence of Tuning
        The configurations.
    seeds : sequence of int
        Tuning noise seeds (the first one screens).
    run : callable
        ``run([(name, tuning, seed, passes), ...]) -> [{protocol: misfit}, ...]``, a run of ``passes`` passes
        giving the misfit of every protocol up to ``passes`` (in one batch: the executor's map).
    keep : int or None
        Survivors per protocol (None, or at least ``len(grid)``: the full grid on every seed).
    protocols : sequence of int
        The protocols scored (passes: 1 and the refined protocol's).

    Returns
    -------
    tuple
        ``({(name, protocol): (ranking, scores)}, {(name, tuning, protocol): seeds run})``: per protocol, the
        configurations that ran on the most seeds first, each group by its mean misfit (ties: grid order); the
        first of the ranking is the chosen one, the next ones the candidates of a reported run whose data it does not
        fit to the noise floor.

    Examples
    --------
    >>> g = [Tuning(s, 0.0, 1.0) for s in (0.1, 0.2, 0.3)]
    >>> misfit = {(0.1, 0): 1.0, (0.2, 0): 2.0, (0.3, 0): 3.0, (0.1, 1): 5.0, (0.2, 1): 0.0, (0.3, 1): 0.0}
    >>> fake = lambda tasks: [{1: misfit[(t.s0, s)]} for _, t, s, _ in tasks]
    >>> ranks, runs = successive_halving(["ukf"], g, [0, 1], fake, keep=2, protocols=[1])
    >>> [t.s0 for t in ranks[("ukf", 1)][0]], runs[("ukf", g[2], 1)]   # 0.3 was screened out on seed 0
    ([0.2, 0.1, 0.3], 1)
    """
    got: dict[tuple[str, Tuning, int], Mapping[int, float]] = {}
    last = max(protocols)

    def rung(tasks: list[tuple[str, Tuning, int, int]]) -> None:
        got.update(((n, t, s), v) for (n, t, s, _), v in zip(tasks, run(tasks)))

    def scored(name: str, t: Tuning, k: int) -> list[float]:
        return [v[k] for (n, t_, _), v in got.items() if n == name and t_ == t and k in v]

    order = {t: i for i, t in enumerate(grid)}
    rung([(n, t, seeds[0], last) for n in names for t in grid])
    if len(seeds) > 1:
        later = []
        for n in names:
            goes_on = {t: last for t in grid}  # passes each configuration runs on the other seeds
            if keep is not None and keep < len(grid):
                goes_on = {}
                for k in protocols:
                    for t in sorted(grid, key=lambda t: (float(np.mean(scored(n, t, k))), order[t]))[:keep]:
                        goes_on[t] = max(goes_on.get(t, 0), k)
            later += [(n, t, s, goes_on[t]) for t in grid if t in goes_on for s in seeds[1:]]
        rung(later)
    runs = {(n, t, k): len(scored(n, t, k)) for n in names for t in grid for k in protocols}
    out = {}
    for n in names:
        for k in protocols:
            scores = {t: float(np.mean(scored(n, t, k))) for t in grid}
            out[(n, k)] = (sorted(grid, key=lambda t: (-runs[(n, t, k)], scores[t], order[t])), scores)
    return out, runs
