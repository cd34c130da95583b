"""The Monte-Carlo replicates of an identification on an executor (local processes or a Dask cluster).

A task carries a :class:`Recipe` (the symbolic model, the set-up's plain values, the filter's kind
and the branch table's JSON), the estimate, the record and which replicates to run, never a
compiled object: a worker rebuilds the experiment once (:func:`rebuild`; compiled filters come from
the disk cache when ``jit``) and keeps it for its next tasks. Replicate ``b`` draws its noise from
``[seed, b]`` (:func:`obsnl.identification.experiments.mc_replicates`), so any split of the replicates
over any number of workers gives the numbers of the run in one process.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, TypedDict

import numpy as np

from obsnl._text import quote
from obsnl.errors import OptionError
from obsnl.estimation.accelerogram import Record
from obsnl.estimation.numeric import NumericModel
from obsnl.estimation.ukf import UKF
from obsnl.executor import Executor, built_once
from obsnl.identification.experiments import Tuning, mc_replicates, mc_spread, mc_truth, monte_carlo
from obsnl.identification.practical import Spread
from obsnl.identification.setup import Data, Setup, coordinates, make_filter

if TYPE_CHECKING:  # the symbolic model is named, not imported: sympy stays out of the identification
    from obsnl.model.core import Model

__all__ = [
    "Recipe",
    "recipe_of",
    "rebuild",
    "replicates_task",
    "spread_on",
    "check_replicates",
    "check_passes",
    "MAX_REPLICATES",
    "MAX_PASSES",
]

#: The most Monte-Carlo replicates and filter passes of one run (1e8 replicates: a MemoryError after 13 s).
MAX_REPLICATES, MAX_PASSES = 10_000, 100


def _count(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def check_replicates(replicates: int) -> int:
    """The Monte-Carlo rule, in one place: 0 (off) or from 3 to :data:`MAX_REPLICATES` replicates.

    Parameters
    ----------
    replicates : int
        The number asked for.

    Returns
    -------
    int
        ``replicates``, checked.

    Raises
    ------
    OptionError
        Any other number (a spread of fewer than 3 replicates says nothing; each replicate is one more filter
        run whose results are kept in memory).

    Examples
    --------
    >>> check_replicates(0), check_replicates(32)
    (0, 32)
    """
    if not _count(replicates) or replicates < 0 or 0 < replicates < 3:
        raise OptionError(f"replicates= must be 0 (off) or at least 3, got {quote(replicates, 30)}")
    if replicates > MAX_REPLICATES:
        raise OptionError(
            f"replicates= {quote(replicates, 30)} is more than {MAX_REPLICATES}: each replicate is "
            "one more filter run whose results are kept in memory; a few hundred give a Monte-Carlo "
            "interval"
        )
    return replicates


def check_passes(passes: int) -> int:
    """The number of filter passes over a record: from 1 to :data:`MAX_PASSES`.

    Parameters
    ----------
    passes : int
        The number asked for.

    Returns
    -------
    int
        ``passes``, checked.

    Raises
    ------
    OptionError
        Any other number.

    Examples
    --------
    >>> check_passes(3)
    3
    """
    if not _count(passes) or passes < 1:
        raise OptionError(f"passes= must be at least 1, got {quote(passes, 30)}")
    if passes > MAX_PASSES:
        raise OptionError(
            f"passes= {quote(passes, 30)} is more than {MAX_PASSES}: each pass is one more filter run "
            "over the whole record; the estimates settle within a few passes"
        )
    return passes


#: Replicates per task (any split gives the same replicates; ``obsnl reproduce`` uses it too).
CHUNK = 8


class SetupFields(TypedDict):
    """The fields of a :class:`~obsnl.identification.setup.Setup` a worker rebuilds it from: every one but the
    compiled model and the coordinates (made again there), with Setup's types."""

    record: Record
    truth: Mapping[str, float] | None
    guess: Mapping[str, float]
    noise: float
    substeps: int
    refine: int
    jit: bool
    y_true: np.ndarray
    channel_noise: Mapping[str, float] | None
    fit_substeps: int | None
    locate: bool
    initial: Mapping[str, float] | None
    known: tuple[str, ...]
    objective: str
    bounds: Mapping[str, tuple[float, float]] | None


def _setup_fields(setup: Setup) -> SetupFields:
    """The :class:`SetupFields` of ``setup``."""
    return SetupFields(
        record=setup.record,
        truth=setup.truth,
        guess=setup.guess,
        noise=setup.noise,
        substeps=setup.substeps,
        refine=setup.refine,
        jit=setup.jit,
        y_true=setup.y_true,
        channel_noise=setup.channel_noise,
        fit_substeps=setup.fit_substeps,
        locate=setup.locate,
        initial=setup.initial,
        known=setup.known,
        objective=setup.objective,
        bounds=setup.bounds,
    )


@dataclass(frozen=True, eq=False)
class Recipe:
    """What a worker needs to rebuild an identification experiment: plain data only."""

    model: Model
    switching: tuple[str, ...] | None
    constants: Mapping[str, float] | None
    setup: SetupFields
    method: str
    table_json: str | None
    points: int = 0


def recipe_of(setup: Setup, method: str, table: Any) -> Recipe:
    """The recipe of an experiment whose compiled model came from :func:`obsnl.estimation.codegen.to_casadi`
    and whose parameters are estimated in log coordinates with the sign of the guesses.

    Parameters
    ----------
    setup : Setup
        The experiment.
    method : str
        ``"ukf"`` or ``"dukf"``.
    table : BranchTable or None
        The DUKF's branch table.

    Returns
    -------
    Recipe

    Raises
    ------
    OptionError
        The compiled model does not say how it was made (built by hand, not by ``to_casadi``).
    """
    source = setup.model.source
    if source is None:
        raise OptionError(
            f"the compiled model {setup.model.name!r} was not made by obsnl.estimation.to_casadi; run its "
            f"replicates in this process (workers=1)"
        )
    model, switching, constants = source
    return Recipe(
        model=model,
        switching=switching,
        constants=constants,
        setup=_setup_fields(setup),
        method=method,
        table_json=None if table is None else table.to_json(),
        points=setup.model.points,
    )


def compiled(recipe: Recipe) -> NumericModel:
    """The recipe's compiled model, driven by input blocks as the original was (``recipe.points``)."""
    from obsnl.estimation.codegen import to_casadi

    num = to_casadi(recipe.model, switching=recipe.switching, constants=recipe.constants)
    return num.driven(recipe.points) if recipe.points else num


def rebuild(recipe: Recipe) -> tuple[Setup, UKF]:
    """The experiment and its filter, built once per process (:func:`obsnl.executor.built_once`).

    Parameters
    ----------
    recipe : Recipe
        What to build.

    Returns
    -------
    tuple
        ``(Setup, filter)``.
    """

    def build() -> tuple[Setup, UKF]:
        from obsnl.observability.contract.branch_table import BranchTable

        num = compiled(recipe)
        setup = Setup(model=num, coordinates=coordinates(num, "log", reference=recipe.setup["guess"]), **recipe.setup)
        table = None if recipe.table_json is None else BranchTable.from_dict(json.loads(recipe.table_json))
        return setup, make_filter(setup, recipe.method, table=table)

    return built_once(recipe, build)


def replicates_task(
    task: tuple[
        Recipe,
        tuple[float, ...],
        np.ndarray,
        np.ndarray,
        np.ndarray,
        Tuning,
        int,
        int,
        tuple[int, ...],
        bool,
        float | None,
    ],
) -> list[tuple]:
    """Replicates ``indices`` of one Monte-Carlo check: ``(log|estimate| or None, held)`` per replicate.

    Parameters
    ----------
    task : tuple
        ``(recipe, theta, u, y, y_hat, tuning, passes, seed, indices, fix_flagged, hold_below)``.

    Returns
    -------
    list of tuple
    """
    recipe, theta, u, y, y_hat, tuning, passes, seed, indices, fix_flagged, hold_below = task
    setup, filt = rebuild(recipe)
    return mc_replicates(
        setup,
        filt,
        Data(seed=None, u=u, y=y),
        y_hat,
        tuning,
        passes=passes,
        seed=seed,
        indices=indices,
        fix_flagged=fix_flagged,
        hold_below=hold_below,
    )


def spread_on(
    executor: Executor | None,
    setup: Setup,
    filt: UKF,
    theta: np.ndarray,
    data: Data,
    tuning: Tuning,
    *,
    method: str,
    table: Any,
    passes: int,
    replicates: int,
    seed: int,
    progress: Callable[[], Any] | None = None,
    fix_flagged: bool = True,
    hold_below: float | None = None,
) -> Spread:
    """:func:`obsnl.identification.experiments.monte_carlo` with the replicates on ``executor`` (None or one
    worker: this process); the same spread whatever the executor.

    Parameters
    ----------
    executor : Executor or None
        Where the replicates run.
    setup : Setup
        The experiment.
    filt : UKF
        Its filter (used in this process).
    theta : numpy.ndarray
        The estimate (the replicates' truth).
    data : Data
        The measured record.
    tuning : Tuning
        The filter configuration.
    method : str
        ``"ukf"`` or ``"dukf"`` (rebuilt by the workers).
    table : BranchTable or None
        The DUKF's branch table.
    passes : int
        Passes per replicate.
    replicates : int
        Number of replicates (at least 3).
    seed : int
        Root seed of the replicates.
    progress : callable or None
        Called once per replicate done.
    fix_flagged : bool
        The reported run's holding (:func:`~obsnl.identification.experiments.run_passes`), repeated by each replicate.
    hold_below : float or None
        Likewise.

    Returns
    -------
    Spread
    """
    if executor is None or executor.kind == "serial":
        return monte_carlo(
            setup,
            filt,
            theta,
            data,
            tuning,
            passes=passes,
            replicates=replicates,
            seed=seed,
            progress=progress,
            fix_flagged=fix_flagged,
            hold_below=hold_below,
        )
    if replicates < 3:
        raise OptionError(f"monte_carlo needs at least 3 replicates, got {replicates}")
    recipe = recipe_of(setup, method, table)
    y_hat = mc_truth(setup, theta, data)
    if y_hat is None:
        if progress:  # not run (the estimate cannot be simulated): the count still ends at its total
            for _ in range(replicates):
                progress()
        return mc_spread(setup, [], replicates=replicates, seed=seed, simulated=False)
    th = tuple(float(v) for v in theta)
    tasks = [
        (
            recipe,
            th,
            data.u,
            data.y,
            y_hat,
            tuning,
            passes,
            seed,
            tuple(range(lo, min(replicates, lo + CHUNK))),
            fix_flagged,
            hold_below,
        )
        for lo in range(0, replicates, CHUNK)
    ]
    done = (lambda i, chunk: [progress() for _ in chunk]) if progress else None

    def named(task: tuple) -> str:  # a task's name in a message (a worker that died while running it)
        return f"Monte-Carlo replicates {task[8][0] + 1} to {task[8][-1] + 1} of {replicates}"

    outcomes = [o for chunk in executor.map(replicates_task, tasks, done=done, label=named) for o in chunk]
    return mc_spread(setup, outcomes, replicates=replicates, seed=seed)
