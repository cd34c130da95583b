"""The branch table: per-branch observability as data, read by the estimators.

This is the contract between the analysis and the DUKF (schema ``obsnl.branch-table/1``,
shipped as ``obsnl/schemas/branch_table.schema.json``). It is written by
:meth:`BranchTable.from_result` from an analysis result and read here without sympy, so the numeric
estimators can load it. A table that fails the schema, contradicts itself, or was made for
another model is refused with a :class:`~obsnl.errors.TableError` that says what is wrong.
"""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from obsnl._files import read_document
from obsnl._text import quoted
from obsnl.errors import DataError, TableError, refuse_non_path
from obsnl.model.bounds.textsize import quote, shorten
from obsnl.model.branching.signature import TABLE_FIX, ModelSignature
from obsnl.observability.assumptions import Assumptions

if TYPE_CHECKING:  # the estimators read this module: the result class is named, not imported
    from obsnl.observability.results import AnalysisResult

__all__ = ["SCHEMA_ID", "BranchEntry", "BranchTable", "read_branch_table", "schema"]

SCHEMA_ID = "obsnl.branch-table/1"


def schema() -> dict[str, Any]:
    """The JSON Schema of a branch table."""
    text = resources.files("obsnl").joinpath("schemas/branch_table.schema.json").read_text(encoding="utf-8")
    return json.loads(text)


#: The analysis methods a table can come from (:data:`obsnl.observability.analyze.METHODS`; the estimators read this
#: module without the analysis, so the names are repeated here): ``check_table`` re-runs the table's method.
TABLE_METHODS: tuple[str, ...] = ("auto", "orc", "sedoglavic")

#: Most branches of a table: an analysis splits into at most 1024 (:func:`obsnl.model.split_branches`); 4096 =
#: 2**12 sign patterns, the most switching functions of one group of representative branches.
MAX_TABLE_BRANCHES = 4096
#: Most names in one list of a table (states, parameters, inputs, outputs, switching functions).
MAX_TABLE_NAMES = 4096


def _check_sizes(data: Mapping[str, Any]) -> None:
    """Refuse a table over the size caps on its raw data, before the schema is validated."""
    for key in ("branches", "states", "parameters", "inputs", "outputs", "switching"):
        value = data.get(key)
        cap = MAX_TABLE_BRANCHES if key == "branches" else MAX_TABLE_NAMES
        if isinstance(value, (list, tuple)) and len(value) > cap:
            raise TableError(
                f"the branch table lists {len(value)} {key}, more than the {cap} a table of an obsnl "
                f"analysis can have; {TABLE_FIX}"
            )


def _assumptions(data: Any) -> Assumptions | None:
    """The table's ``assumptions`` read (None when absent or empty), a wrong one refused naming the key."""
    if not data:
        return None
    try:
        return Assumptions.from_dict(data)
    except DataError as exc:
        raise TableError(f"the branch table's {exc}; {TABLE_FIX}") from None


@dataclass(frozen=True)
class BranchEntry:
    """One branch of a table: its sign pattern and what is (un)identifiable in it."""

    label: str
    guard: str
    signs: tuple[int, ...]
    observable: tuple[str, ...]
    unobservable: tuple[str, ...]
    absent: tuple[str, ...]
    identifiable_parameters: tuple[str, ...]
    unidentifiable_parameters: tuple[str, ...]
    transcendence_degree: int
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        return {
            "label": self.label,
            "guard": self.guard,
            "signs": list(self.signs),
            "observable": list(self.observable),
            "unobservable": list(self.unobservable),
            "absent": list(self.absent),
            "identifiable_parameters": list(self.identifiable_parameters),
            "unidentifiable_parameters": list(self.unidentifiable_parameters),
            "transcendence_degree": self.transcendence_degree,
            "verdict": self.verdict,
        }


@dataclass(frozen=True)
class BranchTable:
    """A validated branch table (see the module docstring)."""

    model: str
    fingerprint: str
    states: tuple[str, ...]
    parameters: tuple[str, ...]
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    switching: tuple[str, ...]
    method: str
    seed: int | None
    probability: float | None
    branches: tuple[BranchEntry, ...]
    overall_observable: tuple[str, ...]
    overall_unobservable: tuple[str, ...]
    joint: Mapping[str, tuple[str, ...]] | None = None
    assumptions: Assumptions | None = None

    # ------------------------------------------------------------------ io
    @classmethod
    def from_dict(cls, data: Any) -> BranchTable:
        """Validate ``data`` against the schema and its own consistency, then build the table."""
        import jsonschema

        if not isinstance(data, Mapping):
            raise TableError("a branch table must be a JSON object; this one is not")
        if data.get("schema") != SCHEMA_ID:
            raise TableError(
                f"not a branch table of schema {SCHEMA_ID!r} (found schema={quote(data.get('schema'))}); "
                f"write one with `obsnl analyze MODEL --format json-table -o TABLE.json`"
            )
        _check_sizes(data)  # before the schema: validating 60 000 branches took 11.5 s
        if "method" in data and data["method"] not in TABLE_METHODS:  # else check_table would run "auto"
            raise TableError(
                f"the branch table's method {quote(data['method'])} is not an analysis method of obsnl; "
                f"known: {', '.join(TABLE_METHODS)}; {TABLE_FIX}"
            )
        try:
            jsonschema.validate(dict(data), schema())
        except jsonschema.ValidationError as exc:
            where = "/".join(str(p) for p in exc.absolute_path) or "(top level)"
            raise TableError(
                f"branch table fails its schema at {shorten(where, 80)}: {shorten(exc.message, 200)}"
            ) from None
        table = cls(
            model=data["model"],
            fingerprint=data["fingerprint"],
            states=tuple(data["states"]),
            parameters=tuple(data["parameters"]),
            inputs=tuple(data["inputs"]),
            outputs=tuple(data["outputs"]),
            switching=tuple(data["switching"]),
            method=data["method"],
            seed=data["seed"],
            probability=data["probability"],
            branches=tuple(
                BranchEntry(
                    label=b["label"],
                    guard=b["guard"],
                    signs=tuple(b["signs"]),
                    observable=tuple(b["observable"]),
                    unobservable=tuple(b["unobservable"]),
                    absent=tuple(b["absent"]),
                    identifiable_parameters=tuple(b["identifiable_parameters"]),
                    unidentifiable_parameters=tuple(b["unidentifiable_parameters"]),
                    transcendence_degree=b["transcendence_degree"],
                    verdict=b["verdict"],
                )
                for b in data["branches"]
            ),
            overall_observable=tuple(data["overall"]["observable"]),
            overall_unobservable=tuple(data["overall"]["unobservable"]),
            joint=({k: tuple(v) for k, v in data["joint"].items()} if data.get("joint") is not None else None),
            assumptions=_assumptions(data.get("assumptions")),
        )
        table._check_consistency()
        return table

    def to_dict(self) -> dict[str, Any]:
        return {
            "schema": SCHEMA_ID,
            "model": self.model,
            "fingerprint": self.fingerprint,
            "states": list(self.states),
            "parameters": list(self.parameters),
            "inputs": list(self.inputs),
            "outputs": list(self.outputs),
            "switching": list(self.switching),
            "method": self.method,
            "seed": self.seed,
            "probability": self.probability,
            "branches": [b.to_dict() for b in self.branches],
            "overall": {"observable": list(self.overall_observable), "unobservable": list(self.overall_unobservable)},
            **(
                {"joint": {k: list(self.joint[k]) for k in ("observable", "unobservable", "inconclusive")}}
                if self.joint is not None
                else {}
            ),
            **({"assumptions": self.assumptions.to_dict()} if self.assumptions is not None else {}),
        }

    @property
    def frozen_everywhere(self) -> tuple[str, ...]:
        """Parameters unidentifiable in every branch: a DUKF that freezes per branch never moves them."""
        return tuple(p for p in self.parameters if all(p in b.unidentifiable_parameters for b in self.branches))

    def jointly_identifiable_but_frozen(self, joint_observable: Sequence[str] | None = None) -> tuple[str, ...]:
        """Parameters the joint verdict identifies that every branch freezes (Bouc-Wen beta, gamma): the
        per-branch DUKF cannot learn them; a reparametrization (``obsnl reparametrize``) can.

        Parameters
        ----------
        joint_observable : sequence of str or None
            The jointly observable variables (default: the table's own ``joint`` key; none without it).

        Returns
        -------
        tuple of str
        """
        if joint_observable is None:
            joint_observable = self.joint["observable"] if self.joint is not None else ()
        return tuple(p for p in self.frozen_everywhere if p in joint_observable)

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=2) + "\n"

    # ------------------------------------------------------------------ checks
    def _check_consistency(self) -> None:
        variables = set(self.states) | set(self.parameters)
        params = set(self.parameters)
        labels = [b.label for b in self.branches]
        if self.probability is not None and not (
            isinstance(self.probability, (int, float)) and 0.0 <= self.probability <= 1.0
        ):
            raise TableError(f"probability {quote(self.probability)} is not a number in [0, 1]; {TABLE_FIX}")
        if len(set(self.switching)) != len(self.switching) or len(self.branches) > 2 ** len(self.switching):
            raise TableError(
                f"{len(self.branches)} branches for {len(self.switching)} switching functions; {TABLE_FIX}"
            )
        obs_union = set().union(*(b.observable for b in self.branches)) if self.branches else set()
        unobs_all = set(variables).intersection(*(b.unobservable for b in self.branches)) if self.branches else set()
        if (
            not set(self.overall_observable) <= obs_union
            or not set(self.overall_unobservable) <= unobs_all
            or (set(self.overall_observable) & set(self.overall_unobservable))
        ):
            raise TableError(
                f"'overall' contradicts the branches (observable must be observable in some branch, "
                f"unobservable in every branch); {TABLE_FIX}"
            )
        if len(set(labels)) != len(labels):
            raise TableError(
                f"branch labels repeat: {quoted(sorted(x for x, n in Counter(labels).items() if n > 1))}; {TABLE_FIX}"
            )
        patterns = set()
        for b in self.branches:
            where = f"branch {quote(b.label)}"
            if len(b.signs) != len(self.switching):
                raise TableError(
                    f"{where} has {len(b.signs)} signs for {len(self.switching)} switching functions; {TABLE_FIX}"
                )
            if b.signs in patterns:
                raise TableError(f"{where} repeats the sign pattern of another branch; {TABLE_FIX}")
            patterns.add(b.signs)
            for key in ("observable", "unobservable", "absent", "identifiable_parameters", "unidentifiable_parameters"):
                unknown = set(getattr(b, key)) - variables
                if unknown:
                    raise TableError(
                        f"{where}: {key} names {quoted(sorted(unknown))}, which are not states or "
                        f"parameters; {TABLE_FIX}"
                    )
            if not 0 <= b.transcendence_degree <= len(variables):
                raise TableError(
                    f"{where}: transcendence degree {b.transcendence_degree} is not between 0 and the "
                    f"number of states and parameters ({len(variables)}); {TABLE_FIX}"
                )
            if b.verdict == "observable" and b.unobservable:
                raise TableError(
                    f"{where}: verdict 'observable' with unobservable variables {quoted(b.unobservable)}; {TABLE_FIX}"
                )
            if set(b.observable) & set(b.unobservable):
                raise TableError(
                    f"{where}: {quoted(sorted(set(b.observable) & set(b.unobservable)))} are both "
                    f"observable and unobservable; {TABLE_FIX}"
                )
            if not set(b.absent) <= set(b.unobservable):
                raise TableError(f"{where}: absent variables must also be unobservable; {TABLE_FIX}")
            if set(b.identifiable_parameters) | set(b.unidentifiable_parameters) != params or (
                set(b.identifiable_parameters) & set(b.unidentifiable_parameters)
            ):
                raise TableError(
                    f"{where}: identifiable_parameters and unidentifiable_parameters must split the "
                    f"parameters {quoted(sorted(params))} exactly; {TABLE_FIX}"
                )
            if set(b.unidentifiable_parameters) != set(b.unobservable) & params:
                raise TableError(f"{where}: unidentifiable_parameters disagree with unobservable; {TABLE_FIX}")

    @property
    def signature(self) -> ModelSignature:
        """The signature of the model the table was made for."""
        return ModelSignature(
            name=self.model,
            fingerprint=self.fingerprint,
            states=tuple(self.states),
            parameters=tuple(self.parameters),
            inputs=tuple(self.inputs),
            outputs=tuple(self.outputs),
            switching=tuple(self.switching),
        )

    def check_model(
        self,
        *,
        states: Sequence[str],
        parameters: Sequence[str],
        inputs: Sequence[str],
        outputs: Sequence[str],
        switching_count: int,
        fingerprint: str,
    ) -> None:
        """Refuse the table unless it was made for this model (names, order, fingerprint).

        A keyword form of ``table.signature.check(ModelSignature.of(model))``.

        Raises
        ------
        TableError
            Naming the first difference and how to regenerate the table.
        """
        other = ModelSignature(
            name="",
            fingerprint=fingerprint,
            states=tuple(states),
            parameters=tuple(parameters),
            inputs=tuple(inputs),
            outputs=tuple(outputs),
            switching=("",) * switching_count,
        )
        self.signature.check(other, fix=TABLE_FIX)

    @classmethod
    def from_result(cls, result: AnalysisResult) -> BranchTable:
        """The branch table of an analysis result (:class:`~obsnl.observability.results.AnalysisResult`).

        The result must carry its model's signature and each branch's sign pattern (``obsnl.analyze``
        records both). The table is validated like any table read from disk.

        Raises
        ------
        TableError
            The result carries no signature or no sign pattern.
        """
        sig = getattr(result, "signature", None)
        if sig is None:
            raise TableError("this result carries no model signature; analyse the model with obsnl.analyze")
        params = sig.parameters
        joint = getattr(result, "joint", None)
        entries = []
        for b in result.branches:
            if not b.signs and sig.switching:
                raise TableError(
                    f"branch {quote(b.label)} carries no sign pattern; analyse the model with obsnl.analyze"
                )
            entries.append(
                BranchEntry(
                    label=b.label,
                    guard=b.guard,
                    signs=tuple(b.signs),
                    observable=tuple(b.observable),
                    unobservable=tuple(b.unobservable),
                    absent=tuple(b.absent),
                    identifiable_parameters=tuple(p for p in params if p not in b.unobservable),
                    unidentifiable_parameters=tuple(p for p in params if p in b.unobservable),
                    transcendence_degree=b.transcendence_degree,
                    verdict=b.verdict.value,
                )
            )
        table = cls(
            model=sig.name,
            fingerprint=sig.fingerprint,
            states=sig.states,
            parameters=params,
            inputs=sig.inputs,
            outputs=sig.outputs,
            switching=sig.switching,
            method=result.method,
            seed=result.seed,
            probability=result.probability,
            branches=tuple(entries),
            overall_observable=result.overall_observable,
            overall_unobservable=result.overall_unobservable,
            joint=(
                None
                if joint is None
                else {
                    "observable": joint.observable,
                    "unobservable": joint.unobservable,
                    "inconclusive": joint.inconclusive,
                }
            ),
            assumptions=result.assumptions,
        )
        return cls.from_dict(table.to_dict())

    # ------------------------------------------------------------------ use
    def entry(self, signs: Sequence[int]) -> BranchEntry:
        """The branch with this sign pattern."""
        key = tuple(int(s) for s in signs)
        for b in self.branches:
            if b.signs == key:
                return b
        raise TableError(f"no branch of the table has the sign pattern {list(key)}")

    def frozen_mask(self, signs: Sequence[int]) -> tuple[bool, ...]:
        """For the parameters in table order: True where the parameter is unidentifiable in that branch."""
        entry = self.entry(signs)
        frozen = set(entry.unidentifiable_parameters)
        return tuple(p in frozen for p in self.parameters)


def read_branch_table(path: str | Path) -> BranchTable:
    """Read and validate a branch table JSON file.

    Raises
    ------
    TableError
        Missing file, invalid JSON, schema violation or an inconsistent table.
    """
    from obsnl.errors import ParseError
    from obsnl.model.files import parse_text  # nesting, duplicate keys, NaN and huge integers refused

    refuse_non_path(path, "read_branch_table takes the path of a branch table")
    p = Path(path)
    where = f"branch table {quote(str(p), 100)}"
    # a regular file of a bounded size only: a FIFO would block the read, a device never end
    text = read_document(
        p,
        where=where,
        error=TableError,
        fix="give the .json file (`obsnl analyze MODEL --format json-table -o FILE.json` writes one)",
    )
    try:
        data = parse_text(text, kind="json", where=where)
    except ParseError as exc:
        raise TableError(str(exc)) from None
    return BranchTable.from_dict(data)
