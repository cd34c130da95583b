"""CLI: 'obsnl analyze --format md|tex|json-table' and 'obsnl report'."""

from __future__ import annotations

import json

import jsonschema

from obsnl.observability.contract.branch_table import schema
from obsnl.cli import main

from .conftest import MODELS


def test_analyze_formats(capsys, tmp_path):
    model = str(MODELS / "coulomb_friction.toml")
    assert main(["analyze", model, "--format", "md", "--seed", "0"]) == 0
    md = capsys.readouterr().out
    assert "| Branches | (a), (b) |" in md  # m, c, k, F_c all identifiable in both branches: one column
    assert main(["analyze", model, "--format", "tex", "--seed", "0"]) == 0
    assert "\\toprule" in capsys.readouterr().out
    out = tmp_path / "t.json"
    assert main(["analyze", model, "--format", "json-table", "--seed", "0", "-o", str(out)]) == 0
    doc = json.loads(out.read_text())
    jsonschema.validate(doc, schema())
    assert main(["analyze", model, "--format", "json-table", "-o", str(out)]) == 2  # exists, no --force
    assert "--force" in capsys.readouterr().err


def test_report_writes_tables_index_and_timings(capsys, tmp_path):
    models = [str(MODELS / "coulomb_friction.toml"), str(MODELS / "bouc_wen.toml")]
    assert main(["report", *models, "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted([f"{m}.{e}" for m in ("coulomb_friction", "bouc_wen") for e in ("md", "tex", "json")]
                           + ["index.md", "timings.md"])
    assert "| coulomb_friction |" in (tmp_path / "timings.md").read_text()
    # never overwrite without --force, and then write nothing at all
    before = (tmp_path / "index.md").read_text()
    (tmp_path / "index.md").write_text("mine")
    assert main(["report", *models, "--out", str(tmp_path)]) == 2
    assert "pass --force" in capsys.readouterr().err and (tmp_path / "index.md").read_text() == "mine"
    assert main(["report", *models, "--out", str(tmp_path), "--force"]) == 0
    assert (tmp_path / "index.md").read_text() == before


def test_identify_refuses_a_corrupted_table(tmp_path, capsys):
    """A branch table that fails its schema never reaches the DUKF (exit 2, one line)."""
    import glob

    from .test_branch_table import paper_table1

    record = sorted(glob.glob(str(MODELS.parent / "obsnl" / "studies" / "data" / "*LOS270*ngawest2*.csv")))[0]
    doc = paper_table1()
    doc["branches"][0]["signs"] = [1, 7]  # corrupt
    bad = tmp_path / "table.json"
    bad.write_text(json.dumps(doc))
    code = main(["identify", str(MODELS / "damage_healing_reparam.toml"), "--table", str(bad), "--record", record,
                 "--method", "dukf", "--samples", "50"])
    err = capsys.readouterr().err
    assert code == 2 and "schema" in err and len(err.strip().splitlines()) == 1
