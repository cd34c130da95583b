"""Which sensors make a model identifiable: every minimal set of candidate sensors for which the targets
are jointly identifiable, or the proof that no set of them is enough.

The candidates are the model's outputs (a model lists every quantity one could measure); a set is
*sufficient* when :func:`obsnl.design.sufficiency.check_sensors` finds every target jointly identifiable
with those outputs alone, *minimal* when no proper subset is sufficient.

The search is level-wise, smallest sets first, on the monotonicity of the test (a superset of a
sufficient set is sufficient, a subset of an insufficient set is not):

1. The full set is tested first. If it is insufficient, no set is sufficient: the answer is that proof
   (the targets no sensor reveals, and the symmetries of the model that every branch shares and no
   sensor breaks, when the symmetry search finds them).
2. At size ``k``, a set that contains a minimal set found at a smaller size is sufficient and not
   minimal (no analysis); a subset of a set already proven insufficient is insufficient (no analysis);
   a set in which some target has no path to any chosen output is insufficient (exact, from the
   dependency graph, no analysis). Only the remaining sets are analysed (the joint verdict), each
   independently, on the given executor.
3. When no set of size ``k`` suffices and the next size has many sets to analyse (more than twice the
   candidates reach every target),
   the *essential* sensors are found once: each candidate is left out of the full set in turn; if what
   remains is insufficient, every set without that candidate is insufficient (a subset of it) and costs
   no analysis from then on.
4. A sufficient set of size ``k`` is minimal when each of its subsets of size ``k - 1`` was proven
   insufficient; if one of them was left undecided (a time limit, an inconclusive verdict), the set is
   reported as sufficient with its minimality undecided, never as minimal.
5. After a size that found new minimal sets, the search stops when the answer is already complete: a
   larger set is minimal only if it contains none of the minimal sets found, and every such set lies
   within one of the largest sets that contain none (the complements of the minimal transversals of the
   minimal sets, :func:`_largest_without`). When each of those is proven insufficient (by reachability,
   by an analysis, or as a subset of a set proven insufficient), so is every set they contain: no larger
   minimal set exists, and no larger size is enumerated (nor refused for its size). With one sensor that
   suffices alone among 30 candidates that reach nothing of the target, that is one more check after size 1
   instead of the 2**29 sets of the others.

Each minimal set comes with its certificate: the probability bound and seed of its own analysis, and for
each sensor removed, how the remaining set was proven insufficient. On a building whose every floor
alone reveals everything, the search of all sets up to size 2 runs ``m + 1`` analyses instead of the
``2^m - 1`` sets there are.
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

from obsnl._progress import Progress
from obsnl._text import quote
from obsnl.design.arguments import model_argument
from obsnl.design.sensor_search import SearchAssumptions, SensorSearch
from obsnl.design.sufficiency import Sufficiency, check_sensors, resolve_targets, restrict, unreached
from obsnl.errors import OptionError
from obsnl.executor import Executor
from obsnl.model.core import Model
from obsnl.model.files import read_model
from obsnl.observability.analyze import assumptions
from obsnl.observability.certificates.certify import shared_symmetries
from obsnl.observability.engines.decompose import output_reachable
from obsnl.observability.engines.inputs import resolve_unknown_input_derivatives
from obsnl.observability.joint.selection import select_branches

__all__ = ["sensors", "rank_sufficient_sets"]

#: Most sets of one size the search enumerates (sets with a sensor that suffices alone are counted, not listed): past
#: it the level is refused with the max_size= that stays within it (a hang on 24 outputs enumerated 2**24 sets).
MAX_LEVEL_SETS = 100_000


#: Most largest sets without a minimal set that the completeness check tests (past it the search goes on by size).
MAX_COMPLETENESS_SETS = 64


def _largest_without(candidates: Sequence[str], minimal: Sequence[tuple[str, ...]]) -> list[tuple[str, ...]] | None:
    """The largest sets of ``candidates`` that contain none of the ``minimal`` sets: the complements of the minimal
    transversals (hitting sets) of ``minimal``, by Berge's algorithm; None when there are more than
    :data:`MAX_COMPLETENESS_SETS`.

    Examples
    --------
    >>> _largest_without(["a", "b", "c", "d"], [("a",), ("b", "c")])
    [('b', 'd'), ('c', 'd')]
    """
    hitting: list[frozenset[str]] = [frozenset()]
    for edge in minimal:
        grown = {h if h & set(edge) else h | {e} for h in hitting for e in edge}
        hitting = [h for h in grown if not any(o < h for o in grown)]
        if len(hitting) > MAX_COMPLETENESS_SETS:
            return None
    order = {c: i for i, c in enumerate(candidates)}
    out = [tuple(c for c in candidates if c not in h) for h in hitting]
    return sorted(out, key=lambda s: [order[c] for c in s])


def _check_task(task: tuple) -> Sufficiency:
    """One analysis (module level: pickled by name for worker processes)."""
    model, names, targets, seed, prob, max_seconds = task
    return check_sensors(model, names, targets, seed=seed, prob=prob, max_seconds=max_seconds)


def _pending(candidates: Sequence[str], size: int, anc: dict[str, set[str]], targets: Sequence[str]) -> int:
    """How many sets of ``size`` candidates reach every target (the ones a level would analyse at most)."""
    want = set(targets)
    return sum(want <= set().union(*(anc[c] for c in s)) for s in itertools.combinations(candidates, size))


def shared_symmetry_text(model: Model, seed: int) -> str:
    """``symmetries of every branch that no output breaks: ...`` (empty when the symmetry search finds none).

    Parameters
    ----------
    model : Model
        The model with the outputs measured.
    seed : int
        Seed of the branch selection and of the symmetry search.

    Returns
    -------
    str
        The generators shared by every analysed branch; an explanation, never the proof (the joint verdict is).
    """
    try:
        chosen, _ = select_branches(model, seed=seed)
        gens = shared_symmetries(model, [b for b in chosen if not b.undecided], seed=seed)
    except Exception:  # noqa: BLE001  the symmetry is an explanation; the proof is the analysis
        gens = ()
    return "symmetries of every branch that no output breaks: " + "; ".join(str(g) for g in gens) if gens else ""


def _symmetry_proof(model: Model, missing: Sequence[str], seed: int) -> str:
    """The targets no sensor reveals, and the shared symmetries that move them (when found)."""
    text = (
        f"{', '.join(missing)} {'is' if len(missing) == 1 else 'are'} not jointly identifiable even with "
        f"every candidate sensor"
    )
    gens = shared_symmetry_text(model, seed)
    return f"{text}; {gens}" if gens else text


def sensors(
    model: Model | str,
    *,
    target: str | Sequence[str] = "parameters",
    max_size: int | None = None,
    seed: int = 0,
    prob: float = 0.99,
    max_seconds: float | None = None,
    executor: Executor | None = None,
    progress: bool | Callable[[int], Any] = False,
) -> SensorSearch:
    """Every minimal set of the model's outputs that makes ``target`` jointly identifiable.

    Parameters
    ----------
    model : Model or str
        A model whose outputs are the candidate sensors, or its file (a path or ``obsnl:NAME``).
    target : str or sequence of str
        ``"parameters"`` (the default: what an identification needs), ``"all"`` (every state and parameter) or names
        (see
        :func:`obsnl.design.sufficiency.resolve_targets`).
    max_size : int or None
        Largest set searched (default: every size).
    seed : int
        Seed of every analysis (:func:`obsnl.analyze`).
    prob : float
        Wanted probability bound of every analysis (:func:`obsnl.analyze`).
    max_seconds : float or None
        Time limit of each analysis (its undecided targets leave the set undecided).
    executor : Executor or None
        Where the analyses of one size run (default: this process).
    progress : bool or callable
        True: a progress bar on stderr (tqdm); a callable: called with the number of sets decided.

    Returns
    -------
    SensorSearch

    Raises
    ------
    OptionError
        A model that is not a Model or a path, a model without outputs, a bad target, ``max_size`` not a
        whole number >= 1, an executor that is not an :class:`~obsnl.executor.Executor`, a ``progress`` that is
        neither a bool nor a callable; a size with more than :data:`MAX_LEVEL_SETS` sets to examine that the
        search has to enumerate, its answer not complete before it (the message names the ``max_size`` that fits).

    Examples
    --------
    Two masses that do not interact, measured separately or by one sensor of their sum:

    >>> from obsnl import Model
    >>> m = Model(name="two", states=["x", "z"], parameters=["a", "b"],
    ...           equations={"x": "-a*x", "z": "-b*z"}, outputs={"y1": "x", "y2": "z", "s": "x + 2*z"})
    >>> res = sensors(m, target="parameters")
    >>> res.minimal_sets
    (('s',), ('y1', 'y2'))
    >>> res.analyses  # the full set, {s}, {y1, y2}; {y1} and {y2} fail on reachability alone
    3
    """
    model_argument(model, "sensors", files=True)
    if executor is not None and not isinstance(executor, Executor):
        raise OptionError(f"executor is an obsnl.executor.Executor or None, got {type(executor).__name__}")
    if isinstance(model, str) or hasattr(model, "__fspath__"):
        model = read_model(model)
    candidates = tuple(model.output_names)
    if not candidates:
        raise OptionError(f"model {model.name!r} has no outputs: list every quantity one could measure as an output")
    targets = resolve_targets(model, target)
    m = len(candidates)
    if max_size is None:
        max_size = m
    if not isinstance(max_size, int) or isinstance(max_size, bool) or max_size < 1:
        raise OptionError(f"max_size must be a whole number >= 1, got {max_size!r}")
    max_size = min(max_size, m)
    if not (isinstance(progress, bool) or callable(progress)):
        raise OptionError(f"progress is True, False or a callable, got {quote(progress, 30)}")
    executor = executor or Executor(workers=1)
    bar = Progress(progress, sum(math.comb(m, k) for k in range(1, max_size + 1)), "sensor sets", "set", counted=True)
    t0 = time.perf_counter()
    full = check_sensors(model, candidates, targets, seed=seed, prob=prob, max_seconds=max_seconds)
    analyses = int(full.how == "analysis")
    assumptions = _assumptions(model, full)
    if full.sufficient is False:
        bar.close()
        return SensorSearch(
            model.name,
            candidates,
            targets,
            max_size,
            (),
            none_exists=True,
            proof=_symmetry_proof(model, full.missing, seed),
            checked=(full,),
            analyses=analyses,
            seed=seed,
            assumptions=assumptions,
            seconds=time.perf_counter() - t0,
            complete=True,
        )
    known: dict[frozenset, Sufficiency] = {frozenset(candidates): full}
    insufficient: list[frozenset] = []
    minimal: list[tuple[str, ...]] = []
    undecided: list[tuple[str, ...]] = []
    essential_done = False

    def check(sets: list[tuple[str, ...]], done: Callable[[int, Any], None] | None = None) -> list[Sufficiency]:
        """Analyse ``sets`` on the executor, count the analyses, keep the answers."""
        nonlocal analyses
        found = executor.map(_check_task, [(model, x, targets, seed, prob, max_seconds) for x in sets], done=done)
        analyses += sum(r.how == "analysis" for r in found)
        known.update((frozenset(x), r) for x, r in zip(sets, found))
        return found

    anc = {c: output_reachable(restrict(model, [c])) for c in candidates}  # reach of a set: the union
    want = set(targets)
    free = list(range(m))  # the candidates that do not suffice alone: a set with one of the others is covered
    complete = False  # every minimal set of any size is listed (every larger set without one is insufficient)
    for k in range(1, max_size + 1):
        if k == 2:
            free = [i for i in free if (candidates[i],) not in minimal]
        n = math.comb(len(free), k)
        if n > MAX_LEVEL_SETS:
            bar.close()
            raise OptionError(
                f"{n:,} sets of {k} sensors to examine among the {len(free)} candidates that do not "
                f"suffice alone, more than {MAX_LEVEL_SETS:,}; give max_size= of at most {max(k - 1, 1)}, "
                f"or fewer candidate outputs"
            )
        if math.comb(m, k) > n:
            bar(math.comb(m, k) - n)  # each contains a sensor that suffices alone: sufficient, not minimal
        level = [tuple(candidates[i] for i in idx) for idx in itertools.combinations(free, k)]
        todo, covered, before = [], set(), len(minimal)
        bases = [frozenset(x) for x in minimal]
        for s in level:
            key = frozenset(s)
            base = next((x for x in bases if key >= x), None)
            if base is not None:  # contains a minimal set: sufficient, not minimal
                covered.add(key)
                bar()
                continue
            if key in known:
                bar()
                continue
            bigger = next((x for x in insufficient if key <= x), None)
            if bigger is not None:
                known[key] = Sufficiency(
                    s,
                    False,
                    missing=known[bigger].missing,
                    how="implied",
                    probability=None,
                    reason="a subset of {" + ", ".join(known[bigger].sensors) + "}, insufficient",
                )
                bar()
                continue
            reach = set().union(*(anc[c] for c in s))
            if not want <= reach:  # as check_sensors decides it, without building the restricted model
                known[key] = unreached(s, [n for n in targets if n not in reach])
                bar()
                continue
            todo.append(s)
        check(todo, done=lambda i, r: bar())
        for s in level:
            if frozenset(s) in covered:
                continue
            r = known.get(frozenset(s))
            if r is None or r.sufficient is None:
                if r is not None:
                    undecided.append(s)
                continue
            if r.sufficient is False:
                insufficient.append(frozenset(s))
                continue
            subs = [known.get(frozenset(x)) for x in itertools.combinations(s, k - 1)] if k > 1 else []
            if all(x is not None and x.sufficient is False for x in subs):
                minimal.append(s)
            else:
                undecided.append(s)
                known[frozenset(s)] = replace(
                    r, reason="sufficient; minimality undecided: a subset with one sensor fewer was not decided"
                )
        if k == m and full.sufficient is None and not minimal:
            break
        if len(minimal) > before and k < m:
            not_alone = [i for i in free if (candidates[i],) not in minimal]
            largest = _largest_without(candidates, minimal)
            # worth analyses only when they are fewer than the sets of the next size; at the last size asked, only
            # what is decided without an analysis
            if largest is not None and (k == max_size or len(largest) < math.comb(len(not_alone), k + 1)):

                def lost(x: tuple[str, ...]) -> Sufficiency | None:
                    reach = set().union(*(anc[c] for c in x))
                    return None if want <= reach else unreached(x, [n for n in targets if n not in reach])

                found = _without_minimal(largest, known, insufficient, lost, check if k < max_size else None)
                insufficient.extend(frozenset(x) for x, r in zip(largest, found) if r is False and x)
                if all(r is False for r in found):  # every larger set lacks a minimal set: within an insufficient one
                    complete = True
                    bar(sum(math.comb(m, j) for j in range(k + 1, max_size + 1)))  # each larger set is decided
                    break
        if (
            not essential_done
            and not minimal
            and k < max_size
            and math.comb(m, k + 1) <= MAX_LEVEL_SETS
            and _pending(candidates, k + 1, anc, targets) > 2 * m
        ):  # (a larger next size is refused before any work)
            # no set of k sensors suffices and the next size is large: find the essential sensors (those
            # without which even every other sensor is not enough); every set lacking one is then implied
            # insufficient as a subset of that set, so only supersets of the essential sensors are analysed
            essential_done = True
            rest = [tuple(c for c in candidates if c != x) for x in candidates]
            rest = [r for r in rest if frozenset(r) not in known]
            for r_set, r in zip(rest, check(rest)):
                if r.sufficient is False:
                    insufficient.append(frozenset(r_set))
    bar.close()
    order = {frozenset(c.sensors): i for i, c in enumerate(known.values())}
    checked = tuple(sorted(known.values(), key=lambda c: (len(c.sensors), order[frozenset(c.sensors)])))
    complete = complete or (max_size == m and not undecided)
    return SensorSearch(
        model.name,
        candidates,
        targets,
        max_size,
        tuple(minimal),
        tuple(undecided),
        checked=checked,
        analyses=analyses,
        seed=seed,
        assumptions=assumptions,
        seconds=time.perf_counter() - t0,
        complete=complete,
    )


def _without_minimal(
    largest: Sequence[tuple[str, ...]],
    known: dict[frozenset, Sufficiency],
    insufficient: Sequence[frozenset],
    lost: Callable[[tuple[str, ...]], Sufficiency | None],
    check: Callable[[list[tuple[str, ...]]], list[Sufficiency]] | None,
) -> list[bool | None]:
    """Whether each of the largest sets without a minimal set is sufficient: the empty set is not; a set
    decided before keeps its answer, a subset of a set proven insufficient is insufficient, and so is a set that
    does not reach every target (``lost``: its answer from the dependency graph, kept in ``known``); the others
    are analysed by ``check`` (None: left undecided)."""
    answers: dict[tuple[str, ...], bool | None] = {}
    todo = []
    for x in largest:
        key = frozenset(x)
        if not x:
            answers[x] = False
        elif key in known:
            answers[x] = known[key].sufficient
        elif any(key <= other for other in insufficient):
            answers[x] = False
        elif (graph := lost(x)) is not None:
            known[key], answers[x] = graph, False
        else:
            todo.append(x)
    if check is not None:
        answers.update((x, r.sufficient) for x, r in zip(todo, check(todo)))
    return [answers.get(x) for x in largest]


def _assumptions(model: Model, full: Sufficiency) -> SearchAssumptions:
    """What every verdict of the search assumes."""
    analysis = assumptions(model, resolve_unknown_input_derivatives(model, None), None)
    return SearchAssumptions(analysis, visited=full.visited or "every feasible branch")


def rank_sufficient_sets(
    search: SensorSearch, model: Model, *, t: Any, inputs: Any, size: int | None = None, noise: float = 0.01
) -> SensorSearch:
    """``search`` with its sufficient sets of one size ranked along a record, and effective independence's choice.

    Parameters
    ----------
    search : SensorSearch
        The result of :func:`sensors` on ``model``.
    model : Model
        The model, with ``[values]`` for every parameter (nonzero) and optionally the initial states.
    t, inputs : Any
        The record: sample times and the known inputs (:func:`obsnl.design.ranking.rank_sensor_sets`).
    size : int or None
        Size of the sets ranked (default: the size of the smallest minimal set).
    noise : float
        Relative noise level of every output (std = level x RMS of the noise-free output).

    Returns
    -------
    SensorSearch
        With ``ranking`` (:class:`obsnl.design.ranking.Ranking`, best first) and ``effective_independence``
        (Kammer's choice of ``size`` sensors on the modes at rest; empty when the model has fewer modes).

    Raises
    ------
    OptionError
        No sufficient set of that size, or a model the ranking cannot use (see ``rank_sensor_sets``).
    """
    from obsnl.design.ranking import effective_independence, rank_sensor_sets

    if size is not None and (not isinstance(size, int) or not 1 <= size <= len(search.candidates)):
        raise OptionError(
            f"the rank size is a number of sensors from 1 to {len(search.candidates)} (the model's "
            f"outputs), got {quote(size, 30)}"
        )
    if size is None:
        if not search.minimal_sets:
            raise OptionError("no sufficient sensor set to rank: " + (search.proof or "none found"))
        size = min(len(s) for s in search.minimal_sets)
    sets = search.sufficient_sets(size)
    if not sets:
        raise OptionError(
            f"no sufficient set of {size} sensors to rank (the minimal sets have "
            f"{sorted({len(s) for s in search.minimal_sets}) or 'no'} sensors)"
        )
    ranking = rank_sensor_sets(model, sets, t=t, inputs=inputs, noise=noise)
    try:
        efi = effective_independence(model, size)
    except OptionError:  # fewer vibration modes than sensors: Kammer's method has no answer
        efi = ()
    return replace(search, ranking=ranking, effective_independence=tuple(efi))
