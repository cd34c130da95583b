"""Issue 25, item 6: every rendering of an analysis says the joint verdict first, in words ("jointly
identifiable: all; only jointly: alpha, x_y"), then the per-branch union (the seed paper's rule), then the
branches; ``index.md`` has the joint verdict as its first column after the model.

The expected words are derived here, not copied from obsnl's output. The bilinear spring
``v' = u - c v - k x + (1 - alpha) k Max(x - x_y, 0)``, ``y = x``: in the elastic branch (x < x_y) the
field is ``u - c v - k x``, so c and k are read off and alpha, x_y do not appear; in the yielded branch it
is ``u - c v - alpha k x - (1 - alpha) k x_y``: c, alpha k and (1 - alpha) k x_y only. No branch alone
gives alpha or x_y (the union misses them), while together k (elastic) then alpha and x_y (yielded)
follow: jointly every state and parameter, alpha and x_y only jointly.
"""

from __future__ import annotations

import json

import pytest

import obsnl
from obsnl import report
from obsnl.cli import main
from obsnl.observability.joint.result import JointResult
from obsnl.observability.results import AnalysisResult
from obsnl.observability.verdicts import BranchResult, Verdict
from obsnl.report.folders import write_tables

BILINEAR = obsnl.Model(
    name="bilinear", states=["x", "v"], parameters=["c", "k", "alpha", "x_y"], inputs=["u"],
    equations={"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"}, outputs={"y": "x"})
JOINT = "jointly identifiable: all; only jointly: alpha, x_y"
# a smooth decay y = x, x' = -(a + b) x: x and a + b are seen, a and b apart are not
SUM = obsnl.Model(name="sum", states=["x"], parameters=["a", "b"], equations={"x": "-(a + b)*x"},
                  outputs={"y": "x"})


@pytest.fixture(scope="module")
def bilinear() -> AnalysisResult:
    return obsnl.analyze(BILINEAR, seed=0)


def test_the_words_of_the_joint_verdict(bilinear):
    assert bilinear.only_jointly == ("alpha", "x_y")
    assert bilinear.joint_words() == JOINT
    assert set(bilinear.union_unobservable) == {"alpha", "x_y"}  # what the union alone would say
    r = obsnl.analyze(SUM, seed=1)
    assert r.joint_words() == "jointly identifiable: x; not identifiable: a, b" and r.only_jointly == ()


def test_text_says_the_joint_verdict_first(bilinear):
    lines = report.to_text(bilinear).splitlines()
    assert lines[0].startswith("bilinear: method")
    assert lines[1].strip().startswith(JOINT)
    text = "\n".join(lines)
    assert text.index(JOINT) < text.index("union unobservable:   alpha, x_y") < text.index("(a) x - x_y > 0")
    assert lines[-1].strip() == "verdict: observable (joint); unobservable (union over branches)"
    assert "verdict (union)" not in text


def test_markdown_says_the_joint_verdict_first(bilinear):
    md = report.to_markdown(bilinear)
    paragraphs = md.split("\n\n")
    assert paragraphs[0] == "### Observability of bilinear" and paragraphs[1].startswith("_method auto")
    assert paragraphs[2].startswith(f"**{JOINT}**")
    assert paragraphs[3] == ("Union over branches (each branch on its own, the seed paper's rule): unobservable in "
                             "every branch: alpha, x_y.")
    assert paragraphs[4].startswith("| Branches | (a) | (b) |")


def test_latex_caption_says_the_joint_verdict_first(bilinear):
    tex = report.to_latex(bilinear)
    caption = tex[tex.index("\\caption{"):tex.index("\\label")]
    joint = "jointly identifiable: all; only jointly: $\\alpha$, $x_{y}$"
    union = "Union over branches (each branch on its own, the seed paper's rule): unobservable in every branch: $\\alpha$"
    assert joint in caption and union in caption
    assert caption.index(joint) < caption.index(union) < caption.index("Verdict:")


def test_index_has_the_joint_verdict_first(bilinear, tmp_path):
    r = report.complete(bilinear, BILINEAR)
    s = report.complete(obsnl.analyze(SUM, seed=1), SUM)
    write_tables([r, s], tmp_path)
    lines = (tmp_path / "index.md").read_text().splitlines()
    head = [c.strip() for c in lines[2].strip("|").split("|")]
    assert head[:3] == ["Model", "Joint verdict", "Branches"] and head[3].startswith("Union over branches")
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.strip("|").split("|")] for line in lines[4:6]}
    assert rows["bilinear"][1:4] == [JOINT, "2", "unobservable in every branch: alpha, x_y"]
    assert rows["sum"][1:4] == ["jointly identifiable: x; not identifiable: a, b", "1",
                                "unobservable in every branch: a, b"]


def test_json_names_what_is_identifiable_only_jointly(tmp_path, capsys):
    f = tmp_path / "bilinear.toml"
    f.write_text(obsnl.model.model_to_toml(BILINEAR))
    assert main(["analyze", str(f), "--format", "json", "--seed", "0"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["overall"]["only_jointly"] == ["alpha", "x_y"] and doc["overall"]["unobservable"] == []


def _undecided() -> AnalysisResult:
    """A hand-built result whose joint verdict leaves w undecided and calls b unidentifiable."""
    joint = JointResult(model="m", observable=("x", "a"), unobservable=("b",), inconclusive=("w",),
                        unknown_inputs={}, visits=(), union_observable=("x",), parameter_rank=1, probability=0.99,
                        seed=0, runs=2, early_stop=False, reason="time limit of 1 s reached", assumptions=None,
                        seconds=1.0)
    branch = BranchResult(label="smooth", guard="true", observable=("x",), unobservable=("a", "b", "w"), absent=(),
                          rank=1, size=4, transcendence_degree=3, seconds=0.1)
    return AnalysisResult(model="m", method="sedoglavic", seed=0, probability=0.99, seconds=1.0, branches=(branch,),
                          variables=("x", "a", "b", "w"), parameters=("a", "b", "w"), joint=joint)


def test_undecided_and_unidentifiable_are_named_first_with_the_reason():
    r = _undecided()
    words = "jointly identifiable: x, a; not identifiable: b; undecided: w; only jointly: a"
    assert r.joint_words() == words
    lines = report.to_text(r).splitlines()
    assert lines[1].strip().startswith(words) and lines[2].strip() == "undecided because: time limit of 1 s reached"
    md = report.to_markdown(r).split("\n\n")
    assert md[2].startswith(f"**{words}**") and md[3] == "undecided because: time limit of 1 s reached."
    assert md[4].startswith("Union over branches")


def test_without_a_joint_verdict_the_renderings_say_so_and_give_the_union():
    r = obsnl.analyze(SUM, seed=1, joint=False)
    assert r.joint is None and r.joint_words() == "joint verdict not computed"
    lines = report.to_text(r).splitlines()
    assert lines[1].strip() == "joint verdict not computed" and lines[-1].strip() == (
        "verdict: unobservable (union over branches)")
    assert r.overall_verdict is Verdict.UNOBSERVABLE


def test_the_joint_verdict_alone_claims_nothing_only_jointly():
    # per_branch=False (the sensor search's call) analyses no branch on its own: no union, so nothing is
    # called "only jointly", although the joint verdict is the same
    r = obsnl.analyze(BILINEAR, seed=0, per_branch=False)
    assert r.branches == () and r.only_jointly == ()
    assert r.joint_words() == "jointly identifiable: all" and r.union_words() == "no branch analysed on its own"
    assert report.to_text(r).splitlines()[1].strip().startswith("jointly identifiable: all (")
