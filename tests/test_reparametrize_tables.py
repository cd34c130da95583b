"""``reparametrize`` keeps the user's tables, writes numbers as the user would, reads every table of the model it is
given, and never calls a model identifiable that is not (issue 41).

Expected answers are derived in each test: the textbook groups of a mass-spring-damper driven through a force
channel of unknown gain (k/m, c/m, g/m: Ewins, Modal Testing, 2000, ch. 2) evaluated by hand at the old numbers; a
model where only a**2 + b**2 enters (a rotation of (a, b) leaves every output unchanged, so neither a nor b is
identifiable).
"""

from __future__ import annotations

import sympy as sp

import obsnl
from obsnl import Model
from obsnl.cli import main
from obsnl.recombination.reparametrize import reparametrize

from .conftest import MODELS


def _msd() -> Model:
    base = obsnl.read_model(MODELS / "msd_force_accel.toml")
    return base.replace(values={"m": 0.1, "c": 0.3, "k": 30.0, "g": 0.7},
                        guess={"m": 0.2, "c": 0.5, "k": 25.0, "g": 1.1})


def _by_definition(r) -> dict[str, str]:
    """{new parameter: its definition with the symbols sorted}, to find each textbook group by its formula."""
    return {n: str(sp.sympify(r.model.definitions[n])) for n in (p.name for p in r.model.parameters)}


def test_guesses_are_mapped_through_the_new_parameters_and_numbers_written_as_typed(tmp_path):
    r = reparametrize(_msd())
    defs = {v: k for k, v in _by_definition(r).items()}
    assert set(defs) == {"k/m", "c/m", "g/m"}
    # by hand at the old numbers: values c/m = 0.3/0.1 = 3, g/m = 7, k/m = 300; guesses 25/0.2, 0.5/0.2, 1.1/0.2
    assert {n: r.model.values[defs[n]] for n in defs} == {"k/m": 300.0, "c/m": 3.0, "g/m": 7.0}
    assert {n: r.model.guess[defs[n]] for n in defs} == {"k/m": 125.0, "c/m": 2.5, "g/m": 5.5}
    text = r.to_toml()
    assert "2.9999999999999996" not in text and "6.999999999999999" not in text and "= 3.0" in text
    path = tmp_path / "new.toml"
    path.write_text(text, encoding="utf-8")
    assert dict(obsnl.read_model(path).guess) == dict(r.model.guess)


def test_a_parameter_absent_from_one_branch_with_a_guess_is_read(tmp_path):
    # fy1 acts only where v1 > 0 (Heaviside): the branch v1 < 0 is analysed without it; its [guess] entry was then
    # "undeclared symbol 'fy1'" and the command stopped
    m = Model(name="frame", states=["x1", "x2", "v1", "v2"], parameters=["m1", "m2", "c1", "k1", "fy1", "c2", "k2"],
              inputs=["xg_dd"],
              equations={"x1": "v1", "x2": "v2",
                         "v1": "-xg_dd + (-(c1*v1 + k1*x1 + fy1*Heaviside(v1)) + (c2*(v2 - v1) + k2*(x2 - x1)))/m1",
                         "v2": "-xg_dd - (c2*(v2 - v1) + k2*(x2 - x1))/m2"},
              outputs={"a2": "-(c2*(v2 - v1) + k2*(x2 - x1))/m2"},
              guess={"m1": 1.2, "m2": 1.0, "c1": 0.5, "k1": 30.0, "fy1": 2.0, "c2": 0.2, "k2": 25.0},
              bounds={"fy1": "positive", "m1": "positive"})
    r = reparametrize(m)
    # every force and both masses scale together (each equation is a force over a mass): none is identifiable
    assert not r.identifiable and {"m1", "m2", "c1", "k1", "fy1", "c2", "k2"} <= set(r.remaining)
    assert r.model.guess  # the guesses went through
    for name, phi in r.mapping.items():  # each guess is the definition at the old guesses
        if name in r.model.guess:
            assert abs(float(phi.subs({s: m.guess[s.name] for s in phi.free_symbols})) - r.model.guess[name]) \
                <= 1e-9 * abs(r.model.guess[name])


def test_a_model_that_stays_unidentifiable_is_never_called_identifiable(tmp_path, capsys):
    # only a**2 + b**2 enters: neither a nor b can be identified, whatever the reparametrization keeps
    path = tmp_path / "rot.toml"
    path.write_text('name = "rot"\nstates = ["x"]\nparameters = ["a", "b"]\ninputs = ["u"]\n[outputs]\ny = "x"\n'
                    '[equations]\nx = "u - (a**2 + b**2)*x"\n[guess]\na = 1.0\nb = 2.0\n', encoding="utf-8")
    assert main(["reparametrize", str(path)]) == 2
    out, err = capsys.readouterr()
    assert "Identifiable reparametrization" not in out and "NOT identifiable" in out.splitlines()[0]
    assert "NOT identifiable: a, b not identifiable" in err and len(err.strip().splitlines()) == 1
    r = reparametrize(obsnl.read_model(path))
    assert not r.identifiable and set(r.remaining) == {"a", "b"} and r.to_dict()["identifiable"] is False
    new = tmp_path / "new.toml"
    assert main(["reparametrize", str(path), "-o", str(new)]) == 2  # written, said, and not passed over
    assert "NOT identifiable" in capsys.readouterr().out and "NOT identifiable" in new.read_text(encoding="utf-8")


def test_an_identifiable_reparametrization_says_so_and_exits_0(tmp_path, capsys):
    # k/m, c/m, g/m and the states are identifiable from the accelerance (the model file's derivation)
    from obsnl.model.files import model_to_toml

    path = tmp_path / "msd.toml"
    path.write_text(model_to_toml(_msd()), encoding="utf-8")
    assert main(["reparametrize", str(path)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("# Identifiable reparametrization of 'msd_force_accel'") and "[guess]" in out
