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
from dataclasses import dataclass, field, replace
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
    search = _Search(model, candidates, targets, max_size, full, analyses, seed, prob, max_seconds, executor, bar)
    search.run()
    bar.close()
    return SensorSearch(
        model.name,
        candidates,
        targets,
        max_size,
        tuple(search.minimal),
        tuple(search.undecided),
        checked=search.checked(),
        analyses=search.analyses,
        seed=seed,
        assumptions=assumptions,
        seconds=time.perf_counter() - t0,
        complete=search.complete,
    )


@dataclass(eq=False)
class _Search:
    """The level-wise search of :func:`sensors` once the full set is known not to be insufficient (steps 2 to 5 of
    the module docstring), with its state.

    ``known`` holds the answer of every set decided (by analysis, reachability or implication), in the order
    decided; ``insufficient`` the sets proven insufficient, whose subsets are implied insufficient; ``minimal``
    and ``undecided`` the answer so far; ``free`` the candidates (their indices) that do not suffice alone;
    ``complete`` whether every minimal set of any size is listed; ``analyses`` the joint verdicts run.
    """

    model: Model
    candidates: tuple[str, ...]
    targets: tuple[str, ...]
    max_size: int
    full: Sufficiency
    analyses: int
    seed: int
    prob: float
    max_seconds: float | None
    executor: Executor
    bar: Progress
    known: dict[frozenset[str], Sufficiency] = field(init=False)
    insufficient: list[frozenset[str]] = field(init=False, default_factory=list)
    minimal: list[tuple[str, ...]] = field(init=False, default_factory=list)
    undecided: list[tuple[str, ...]] = field(init=False, default_factory=list)
    essential_done: bool = field(init=False, default=False)
    # every minimal set of any size is listed (every larger set without one is insufficient)
    complete: bool = field(init=False, default=False)
    # the candidates that do not suffice alone: a set with one of the others is covered
    free: list[int] = field(init=False)
    # what each candidate reaches in the dependency graph (the reach of a set: the union)
    reach: dict[str, set[str]] = field(init=False)

    def __post_init__(self) -> None:
        """Start from the full set's answer, every candidate free, and each candidate's reach."""
        self.known = {frozenset(self.candidates): self.full}
        self.free = list(range(len(self.candidates)))
        self.reach = {c: output_reachable(restrict(self.model, [c])) for c in self.candidates}

    def run(self) -> None:
        """Search size by size, smallest first, up to ``max_size``: decide what a level's sets need no analysis
        for, analyse the others, record the answers; stop early when the answer is already complete, and find
        the essential sensors once when the next size is large."""
        for k in range(1, self.max_size + 1):
            level = self._level(k)
            before = len(self.minimal)
            todo, covered = self._classify(level)
            self._check(todo, done=lambda i, r: self.bar())
            self._record(level, covered, k)
            if len(self.minimal) > before and k < len(self.candidates) and self._complete_after(k):
                break
            if self._essential_worth(k):
                self._find_essential()
        self.complete = self.complete or (self.max_size == len(self.candidates) and not self.undecided)

    def _level(self, k: int) -> list[tuple[str, ...]]:
        """The sets of ``k`` sensors to examine: those of the free candidates (a set with a sensor that suffices
        alone is sufficient and not minimal: counted as decided, never listed).

        A level of more than :data:`MAX_LEVEL_SETS` sets is refused, with the ``max_size`` that stays within it.
        """
        m = len(self.candidates)
        if k == 2:
            self.free = [i for i in self.free if (self.candidates[i],) not in self.minimal]
        n = math.comb(len(self.free), k)
        if n > MAX_LEVEL_SETS:
            self.bar.close()
            raise OptionError(
                f"{n:,} sets of {k} sensors to examine among the {len(self.free)} candidates that do not "
                f"suffice alone, more than {MAX_LEVEL_SETS:,}; give max_size= of at most {max(k - 1, 1)}, "
                f"or fewer candidate outputs"
            )
        if math.comb(m, k) > n:
            self.bar(math.comb(m, k) - n)  # each contains a sensor that suffices alone: sufficient, not minimal
        return [tuple(self.candidates[i] for i in idx) for idx in itertools.combinations(self.free, k)]

    def _classify(self, level: list[tuple[str, ...]]) -> tuple[list[tuple[str, ...]], set[frozenset[str]]]:
        """Decide the level's sets that need no analysis, in order, and return the others (to analyse) and the
        sets that contain a minimal set (sufficient, not minimal: ``covered``).

        A set decided before keeps its answer; the others are answered by :meth:`_without_analysis` when it can.
        """
        todo: list[tuple[str, ...]] = []
        covered: set[frozenset[str]] = set()
        bases = [frozenset(x) for x in self.minimal]
        for s in level:
            key = frozenset(s)
            if any(key >= x for x in bases):  # contains a minimal set: sufficient, not minimal
                covered.add(key)
            elif key not in self.known:
                answer = self._without_analysis(s)
                if answer is None:
                    todo.append(s)
                    continue
                self.known[key] = answer
            self.bar()
        return todo, covered

    def _without_analysis(self, s: tuple[str, ...]) -> Sufficiency | None:
        """The answer for ``s`` without an analysis, None when there is none: a subset of a set proven
        insufficient is insufficient (monotonicity), and so is a set that some target has no path to."""
        key = frozenset(s)
        bigger = next((x for x in self.insufficient if key <= x), None)
        if bigger is not None:
            return Sufficiency(
                s,
                False,
                missing=self.known[bigger].missing,
                how="implied",
                probability=None,
                reason="a subset of {" + ", ".join(self.known[bigger].sensors) + "}, insufficient",
            )
        return self._unreached(s)

    def _unreached(self, s: tuple[str, ...]) -> Sufficiency | None:
        """Insufficient when some target has no path to any output of ``s`` (exact, from the dependency graph:
        as :func:`~obsnl.design.sufficiency.check_sensors` decides it, without building the restricted model);
        None when every target is reached."""
        reach = set().union(*(self.reach[c] for c in s))
        return None if set(self.targets) <= reach else unreached(s, [n for n in self.targets if n not in reach])

    def _check(self, sets: list[tuple[str, ...]], done: Callable[[int, Any], None] | None = None) -> list[Sufficiency]:
        """Analyse ``sets`` on the executor, each independently; count the analyses, keep the answers."""
        tasks = [(self.model, x, self.targets, self.seed, self.prob, self.max_seconds) for x in sets]
        found = self.executor.map(_check_task, tasks, done=done)
        self.analyses += sum(r.how == "analysis" for r in found)
        self.known.update((frozenset(x), r) for x, r in zip(sets, found))
        return found

    def _record(self, level: list[tuple[str, ...]], covered: set[frozenset[str]], k: int) -> None:
        """Record the answers of the level's sets that contain no minimal set, in order.

        An insufficient set joins ``insufficient`` (its subsets are then implied); an undecided set joins
        ``undecided``. A sufficient set is minimal when each of its subsets of size ``k - 1`` was proven
        insufficient; if one of them was left undecided, the set is reported sufficient with its minimality
        undecided, never as minimal.
        """
        for s in level:
            if frozenset(s) in covered:
                continue
            r = self.known.get(frozenset(s))
            if r is None or r.sufficient is None:
                if r is not None:
                    self.undecided.append(s)
                continue
            if r.sufficient is False:
                self.insufficient.append(frozenset(s))
                continue
            subs = [self.known.get(frozenset(x)) for x in itertools.combinations(s, k - 1)] if k > 1 else []
            if all(x is not None and x.sufficient is False for x in subs):
                self.minimal.append(s)
            else:
                self.undecided.append(s)
                self.known[frozenset(s)] = replace(
                    r, reason="sufficient; minimality undecided: a subset with one sensor fewer was not decided"
                )

    def _complete_after(self, k: int) -> bool:
        """Whether the minimal sets found up to size ``k`` are every minimal set of any size (then ``complete``).

        A larger set is minimal only if it contains none of them, and every such set lies within one of the
        largest sets that contain none (:func:`_largest_without`): when each of those is proven insufficient, so
        is every set they contain, and every larger set is counted as decided. Those largest sets proven
        insufficient join ``insufficient`` either way.
        """
        not_alone = [i for i in self.free if (self.candidates[i],) not in self.minimal]
        largest = _largest_without(self.candidates, self.minimal)
        # worth analyses only when they are fewer than the sets of the next size; at the last size asked, only
        # what is decided without an analysis
        if largest is None or (k < self.max_size and len(largest) >= math.comb(len(not_alone), k + 1)):
            return False
        check = self._check if k < self.max_size else None
        found = _without_minimal(largest, self.known, self.insufficient, self._unreached, check)
        self.insufficient.extend(frozenset(x) for x, r in zip(largest, found) if r is False and x)
        if not all(r is False for r in found):
            return False
        # every larger set lacks a minimal set: it lies within an insufficient one
        self.complete = True
        m = len(self.candidates)
        self.bar(sum(math.comb(m, j) for j in range(k + 1, self.max_size + 1)))  # each larger set is decided
        return True

    def _essential_worth(self, k: int) -> bool:
        """Whether to find the essential sensors after size ``k``: once, when no set of ``k`` sensors suffices
        and the next size has many sets to analyse (more than twice the candidates reach every target).

        A next size too large to enumerate is refused before any work, so it is not prepared for.
        """
        m = len(self.candidates)
        return (
            not self.essential_done
            and not self.minimal
            and k < self.max_size
            and math.comb(m, k + 1) <= MAX_LEVEL_SETS
            and _pending(self.candidates, k + 1, self.reach, self.targets) > 2 * m
        )

    def _find_essential(self) -> None:
        """Find the essential sensors, those without which even every other sensor is not enough: each candidate
        is left out of the full set in turn, and what remains is analysed (unless known). A remainder proven
        insufficient joins ``insufficient``: every set lacking that candidate is then implied insufficient as a
        subset of it, so only supersets of the essential sensors are analysed from then on."""
        self.essential_done = True
        rest = [tuple(c for c in self.candidates if c != x) for x in self.candidates]
        rest = [r for r in rest if frozenset(r) not in self.known]
        for r_set, r in zip(rest, self._check(rest)):
            if r.sufficient is False:
                self.insufficient.append(frozenset(r_set))

    def checked(self) -> tuple[Sufficiency, ...]:
        """Every answer established, smallest sets first, in the order decided within a size."""
        order = {frozenset(c.sensors): i for i, c in enumerate(self.known.values())}
        return tuple(sorted(self.known.values(), key=lambda c: (len(c.sensors), order[frozenset(c.sensors)])))


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
