"""The public API's shape: a small top level, every error class at the top, one verdict enum, one reader
verb, and the rest importable from its room (subpackage)."""

from __future__ import annotations

import ast
import enum
import importlib
import inspect
from pathlib import Path

import pytest

import obsnl
import obsnl.errors as errors

PKG = Path(obsnl.__file__).resolve().parent
ROOMS = ("model", "observability", "linear", "estimation", "identification", "recombination", "design", "studies")

#: Names that left the top level, and the room each is imported from now.
MOVED = {
    "Branch": "model", "split_branches": "model", "model_to_toml": "model",
    "orc": "observability", "sedoglavic": "observability", "decompose": "observability",
    "dependency_graph": "observability", "BranchResult": "observability", "BranchTable": "observability",
    "read_branch_table": "observability", "Symmetry": "observability", "Symmetries": "observability",
    "LinearSystem": "linear", "system_scaling": "linear", "integrator": "linear", "oscillator": "linear",
    "extend": "linear", "extended_observability": "linear", "riccati_gain": "linear", "place_gain": "linear",
    "simulate_observer": "linear", "ObserverBank": "linear", "calibrate_thresholds": "linear", "decide": "linear",
    "Detection": "linear",
    "to_casadi": "estimation", "NumericModel": "estimation", "ParameterMap": "estimation",
    "parameter_map": "estimation", "log_map": "estimation", "UKF": "estimation", "Estimate": "estimation",
    "Trajectory": "estimation", "DUKF": "estimation", "Record": "estimation", "add_noise": "estimation",
    "Measured": "estimation",
    "Setup": "identification", "Tuning": "identification", "make_data": "identification",
    "make_filter": "identification", "run_passes": "identification", "output_misfit": "identification",
    "practical_identifiability": "identification", "monte_carlo": "identification",
    "Reparametrization": "recombination", "IdentifiableFunctions": "recombination", "same_field": "recombination",
    "FieldComparison": "recombination",
    "SensorSearch": "design", "design": "design",
    "run_link_study": "studies", "build_cantilever": "studies", "read_link_spec": "studies",
    "BreathingCrack": "studies", "Reproduction": "studies",
}


def _classes_and_functions() -> list[tuple[str, ast.AST]]:
    """Every top-level class and function of every module of the package: (module path, node)."""
    out = []
    for path in sorted(PKG.rglob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, (ast.ClassDef, ast.FunctionDef)):
                out.append((path.relative_to(PKG.parent).as_posix(), node))
    return out


def test_the_top_level_is_small():
    assert len(obsnl.__all__) <= 35, len(obsnl.__all__)
    assert len(set(obsnl.__all__)) == len(obsnl.__all__)
    assert {"Model", "read_model", "analyze", "AnalysisResult", "Verdict", "identify", "Identification",
            "read_measured", "sensors", "symmetries", "reparametrize", "identifiable_functions",
            "kalman_rank", "hautus", "build_bank", "reproduce"} <= set(obsnl.__all__)
    assert not set(MOVED) & set(obsnl.__all__)


def test_every_error_class_is_at_the_top():
    classes = {n for n, c in vars(errors).items() if inspect.isclass(c) and issubclass(c, errors.ObsnlError)}
    assert len(classes) >= 10
    assert {n for n in obsnl.__all__ if n.endswith("Error")} == classes
    assert all(getattr(obsnl, n) is getattr(errors, n) for n in classes)


def test_one_verdict_enum():
    verdicts = [n for n in obsnl.__all__ if n.endswith("Verdict")]
    assert verdicts == ["Verdict"] and issubclass(obsnl.Verdict, enum.Enum)
    # and no other enum (or class) in the package calls itself a verdict
    named = [f"{path}:{node.name}" for path, node in _classes_and_functions()
             if isinstance(node, ast.ClassDef) and node.name.endswith("Verdict")]
    assert named == ["obsnl/observability/verdicts.py:Verdict"]
    # the linear tests answer with it; the observer bank's outcome is a detection, not a verdict
    assert {v.value for v in obsnl.Verdict} == {"observable", "weakly observable", "unobservable", "inconclusive"}
    assert obsnl.hautus([[-1, 0], [0, -2]], [[1, 0]]).verdict is obsnl.Verdict.UNOBSERVABLE
    from obsnl.linear import Detection

    assert not issubclass(Detection, obsnl.Verdict) and Detection("located") is Detection.LOCATED


def test_the_readers_share_one_verb():
    readers = [n for n in obsnl.__all__ if n.startswith(("load_", "read_"))]
    assert readers and all(n.startswith("read_") for n in readers), readers
    loaders = [f"{path}:{node.name}" for path, node in _classes_and_functions()
               if isinstance(node, ast.FunctionDef) and node.name.startswith("load_")]
    assert loaders == []


@pytest.mark.parametrize("room", ROOMS)
def test_each_room_exports_its_public_names(room):
    module = importlib.import_module(f"obsnl.{room}")
    for name in module.__all__:
        value = getattr(module, name)
        # a room never exports a name that is also one of its modules (importing the module would replace it)
        assert not (PKG / room / f"{name}.py").exists() and not (PKG / room / name).is_dir(), name
        if name in obsnl.__all__:
            assert value is getattr(obsnl, name), name
    moved_here = {n for n, r in MOVED.items() if r == room}
    assert moved_here <= set(module.__all__), moved_here - set(module.__all__)


def test_a_name_that_left_the_top_level_says_so():
    with pytest.raises(AttributeError, match="run_passes"):
        obsnl.run_passes  # noqa: B018
    from obsnl.identification import run_passes

    assert callable(run_passes)
