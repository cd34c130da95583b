"""The executor: the same results in this process, in local processes and on a Dask cluster.

Every task's noise is fixed by its own seeds, so the seed experiment's estimates (the content of
table2.json) and a report's tables must not depend on where the tasks ran; the expected values here
are those of the serial run, computed in the same test (the property tested is that equality).
"""

from __future__ import annotations

import pytest

import obsnl
import obsnl.batch
from obsnl.errors import OptionError
from obsnl.executor import Executor, spawn_seeds

from .conftest import PEER_CASE_FILES


def _estimates(rep) -> list:
    doc = rep.to_dict()
    return [(r["method"], r["passes"], r["seed"], r["tuning"],
             {p: v["estimate"] for p, v in r["parameters"].items()}, r["output_misfit"],
             r["practical_identifiability"]) for r in doc["runs"]] + [doc["tuning"]] + [
        {k: v for k, v in r.items() if k != "seconds"} for r in doc["refinements"]]


def _short_reproduction(executor):
    from obsnl.identification.setup import DEFAULT_GRID
    from obsnl.studies.seed_paper import reproduce

    return reproduce(samples=120, seeds=1, tuning_seeds=1, passes=1, grid=DEFAULT_GRID[:2], replicates=3,
                     jit=False, executor=executor)


@pytest.mark.slow
def test_reproduce_on_a_local_dask_cluster_equals_the_serial_run():
    distributed = pytest.importorskip("distributed")
    serial = _short_reproduction(Executor(workers=1))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        on_dask = _short_reproduction(Executor(scheduler=client))
    assert _estimates(on_dask) == _estimates(serial)
    assert len(serial.runs) == 3 and all(r.practical.spread is not None for r in serial.runs[:2])
    assert len(serial.refinements) == 1  # the refinement ran, so the equality above covers it


def test_report_in_local_processes_equals_the_serial_report(tmp_path):
    models = [obsnl.read_model(p) for p in PEER_CASE_FILES[:4]]
    serial = obsnl.batch.report_models(models, tmp_path / "a", seed=3)
    parallel = obsnl.batch.report_models(models, tmp_path / "b", seed=3, executor=Executor(workers=2))
    for m in models:
        for ext in ("md", "tex", "json"):
            assert (tmp_path / "a" / f"{m.name}.{ext}").read_text() == (tmp_path / "b" / f"{m.name}.{ext}").read_text()
    assert [r.overall_unobservable for r in serial] == [r.overall_unobservable for r in parallel]


def test_seeds_from_one_root_do_not_depend_on_how_many_are_drawn():
    assert spawn_seeds(7, 4) == spawn_seeds(7, 9)[:4]
    assert len(set(spawn_seeds(7, 100))) == 100 and spawn_seeds(7, 2) != spawn_seeds(8, 2)


def test_bad_executor_options_are_one_line_errors():
    with pytest.raises(OptionError, match="workers must be"):
        Executor(workers=0)
    with pytest.raises(OptionError, match="scheduler must be"):
        Executor(scheduler=42)
    pytest.importorskip("distributed")
    with pytest.raises(OptionError, match="cannot reach the Dask scheduler 'bogus'.*tcp://HOST:8786"):
        Executor(scheduler="bogus").map(abs, [1])  # not an address: a one-line error, not a ValueError


def test_cli_bad_scheduler_address_exits_2(capsys, tmp_path):
    from obsnl.cli import main

    pytest.importorskip("distributed")
    assert main(["report", "obsnl:coulomb_friction", "--out", str(tmp_path / "r"), "--scheduler", "bogus"]) == 2
    err = capsys.readouterr().err
    assert "cannot reach the Dask scheduler 'bogus'" in err and "Traceback" not in err and len(err.splitlines()) == 1


def _leaky_identification(executor):
    """A one-state model identified from scipy data with 4 Monte-Carlo replicates on ``executor``."""
    import numpy as np

    from obsnl.identification.experiments import Tuning

    from .radau_data import noisy
    from .test_identify_measured import _leaky

    t = np.arange(200) * 0.02
    u = 0.05 * np.sin(2 * np.pi * 0.3 * t) + 0.03 * np.sin(2 * np.pi * 1.1 * t)
    y = noisy(_leaky(t, u, 2.0, 0.0), 0.01, np.random.default_rng(1))
    m = obsnl.Model(name="leaky", states=["x"], parameters=["a"], inputs=["u"], equations={"x": "u - a*x"},
                    outputs={"y": "x"})
    ticks = []
    res = obsnl.identify(m, {"t": t, "u": u, "y": y}, guess={"a": 2.8}, noise={"u": 1e-3, "y": 0.01}, passes=1,
                         replicates=4, seed=5, tuning=Tuning(0.3, 0.0, 1.0), executor=executor,
                         progress=lambda: ticks.append(1))
    # one pass, one step per replicate, the likelihood refinement and one profile per parameter (the bar's total)
    assert len(ticks) == 1 + 4 + 1 + 1
    return res.to_dict()["practical_identifiability"]["monte_carlo"]


@pytest.mark.slow
def test_identify_replicates_in_processes_and_on_dask_equal_the_serial_run():
    serial = _leaky_identification(Executor(workers=1))
    assert serial["replicates"] == 4 and serial["relative_std"][0] > 0  # four replicates that converged
    assert _leaky_identification(Executor(workers=2)) == serial
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        assert _leaky_identification(Executor(scheduler=client)) == serial


def test_a_model_travels_to_workers_as_its_model_file_dictionary():
    """Pickling a model pickles its model-file dictionary (plain data): the copy has the same fingerprint
    and dictionary, for every packaged model and published case that loads."""
    import pickle

    from .conftest import MODELS

    models = [obsnl.read_model(p) for p in list(PEER_CASE_FILES) + sorted(MODELS.glob("*.toml"))
              if "cantilever_link" not in str(p)]  # the link study's file is a structure, not a model
    assert len(models) > 50
    for m in models:
        blob = pickle.dumps(m)
        assert b"sympy" not in blob  # no symbolic objects travel, only text
        copy = pickle.loads(blob)
        assert copy.fingerprint == m.fingerprint and copy.to_dict() == m.to_dict()


def test_a_shallow_copy_of_a_model_does_not_parse_it_again():
    # derived_model (branches, blocks) copies a validated model and swaps fields: a copy must share the
    # validated parts, not go through the model-file dictionary that pickling uses
    import copy

    m = obsnl.read_model("obsnl:damage_healing_reparam")
    c = copy.copy(m)
    assert c is not m and c.equations is m.equations and c.fingerprint == m.fingerprint
