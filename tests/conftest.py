"""Shared fixtures: paths of the model catalogue and of the published peer cases, the Coulomb model's table."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

import obsnl

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
PEER_CASES = Path(__file__).resolve().parent / "data" / "peer_cases"
#: A C compiler is on PATH: long identification tests compile the filter and the likelihood fit (``jit``; the same
#: numbers to rounding, several times faster).
HAVE_CC = any(shutil.which(c) for c in ("cc", "gcc", "clang"))
#: Skips a test that compiles C code where no compiler is on PATH.
needs_cc = pytest.mark.skipif(not HAVE_CC, reason="needs a C compiler")

def _is_ode_model(path: Path) -> bool:
    import tomllib

    return "states" in tomllib.loads(path.read_text(encoding="utf-8"))


#: ODE model files of the catalogue (models/ also holds structure data such as the cantilever link).
MODEL_FILES = sorted(p for p in MODELS.glob("*.toml") if _is_ode_model(p))
PEER_CASE_FILES = sorted(PEER_CASES.glob("*.json"))


@pytest.fixture
def models_dir() -> Path:
    return MODELS


@pytest.fixture
def peer_dir() -> Path:
    return PEER_CASES


@pytest.fixture(scope="module")
def coulomb_table():
    """The Coulomb-friction model and its branch table (a dictionary), analysed with seed 0."""
    from obsnl.observability.analyze import analyze
    from obsnl.observability.contract.branch_table import BranchTable

    model = obsnl.read_model("obsnl:coulomb_friction")
    return model, BranchTable.from_result(analyze(model, seed=0)).to_dict()
