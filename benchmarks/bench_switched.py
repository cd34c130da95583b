"""Switched (non-smooth) models: obsnl's joint verdict against symident 0.12's joint test, in one run.

Models (our own set, answers derived in ``EXPECTED`` below): bilinear spring, saturating (elastic-perfectly
plastic backbone) spring, contact gap, relay level only in a switching function, base-excited friction
oscillator, one Bouc-Wen storey, a switch whose effect never reaches the output; then the n-storey Bouc-Wen
shear building (every floor's absolute acceleration measured, unit masses) for n = 2..10 on both tools
(symident enumerates at most 4096 sign patterns: n <= 6) and n = 20 for obsnl alone.

Protocol: both tools warm (one untimed call first), then ``--repeat`` calls each, alternating obsnl and
symident, in this one process; the median wall time of each and the ratio symident/obsnl are printed, with
each tool's jointly unidentifiable set and whether it equals the expected one. Run:

    python benchmarks/bench_switched.py [--repeat 3] [--storeys 2,3,4,5,6,8,10,20] [--out reports/benchmarks/switched.md]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
import warnings
from pathlib import Path

import obsnl
from obsnl.studies.buildings import bouc_wen_building

ROOT = Path(__file__).resolve().parents[1]

# name: (states, parameters, inputs, equations, outputs, expected jointly unidentifiable set, derivation)
SWITCHED = {
    "bilinear": (["x", "v"], ["c", "k", "alpha", "x_y"], ["u"],
                 {"x": "v", "v": "u - c*v - k*x + (1 - alpha)*k*Max(x - x_y, 0)"}, {"y": "x"}, set(),
                 "elastic branch: c, k; yielded: alpha k, (1 - alpha) k x_y"),
    "saturating": (["x", "v"], ["c", "k", "F_y"], ["u"],
                   {"x": "v", "v": "u - c*v - k*x + Max(k*x - F_y, 0) - Max(-k*x - F_y, 0)"}, {"y": "x"}, set(),
                   "force clipped at +-F_y (k x - Max(k x - F_y, 0) + Max(-k x - F_y, 0)); elastic branch: k; "
                   "F_y from the clipped branches"),
    "gap": (["x", "v"], ["c", "k", "k_c", "g"], ["u"],
            {"x": "v", "v": "u - c*v - k*x - k_c*Max(x - g, 0)"}, {"y": "x"}, set(),
            "open gap: c, k; closed: k + k_c and k_c g"),
    "relay": (["x", "v"], ["c", "k", "s", "d"], ["u"],
              {"x": "v", "v": "u - c*v - k*x - s*sign(x - d)"}, {"y": "x"}, set(),
              "each branch: c, k, s; d only through the visible crossing x = d"),
    "friction": (["x", "v"], ["m", "c", "k", "F"], ["ag"],
                 {"x": "v", "v": "-ag - (c*v + k*x + F*sign(v))/m"}, {"y": "x"}, {"m", "c", "k", "F"},
                 "(m, c, k, F) -> lambda (m, c, k, F) in every branch, v = 0 kept"),
    "bouc_wen_storey": (["x", "v", "z"], ["c", "k", "kh", "beta", "gamma"], ["ag"],
                        {"x": "v", "v": "-ag - c*v - k*x - kh*z",
                         "z": "v - beta*Abs(v)*Abs(z)*z - gamma*v*z**2"}, {"a": "-c*v - k*x - kh*z"}, set(),
                        "branches see beta + gamma and gamma - beta"),
    "hidden_switch": (["x", "z"], ["a", "b", "e", "q"], ["u"],
                      {"x": "-a*x + u", "z": "-b*z + e*sign(z - q)"}, {"y": "x"}, {"z", "b", "e", "q"},
                      "z never reaches y"),
}


def _symident_expr(e) -> str:
    """A sympy expression of an obsnl model, sign/Abs/Max/Min written as symident's piecewise()."""
    import re

    import sympy as sp

    def conv(node):
        if not node.args:
            return str(node)
        args = [conv(a) for a in node.args]
        if isinstance(node, sp.sign):
            return f"piecewise(1, {args[0]} > 0, -1)"
        if isinstance(node, sp.Abs):
            return f"piecewise({args[0]}, {args[0]} > 0, -({args[0]}))"
        if isinstance(node, (sp.Max, sp.Min)) and len(args) == 2:
            a, b = args
            return f"piecewise({a}, {a} {'>' if isinstance(node, sp.Max) else '<'} {b}, {b})"
        if isinstance(node, (sp.Max, sp.Min)):
            first, rest = args[0], type(node)(*node.args[1:])
            r = conv(rest)
            return f"piecewise({first}, {first} {'>' if isinstance(node, sp.Max) else '<'} {r}, {r})"
        if isinstance(node, sp.Add):
            return "(" + " + ".join(args) + ")"
        if isinstance(node, sp.Mul):
            return "(" + "*".join(args) + ")"
        if isinstance(node, sp.Pow):
            return f"({args[0]})**({args[1]})"
        raise ValueError(f"cannot write {node.func} for symident")

    return re.sub(r"\s+", " ", conv(e))


def _symident_case(model):
    import symident

    return symident.Model(odes={s.name: _symident_expr(e) for s, e in model.equations.items()},
                          observables={k: _symident_expr(v) for k, v in model.outputs.items()},
                          known_inputs=[u.name for u in model.inputs], positive=[p.name for p in model.parameters])


def _symident_unidentifiable(res) -> set[str]:
    out: set[str] = set()
    for s in res.to_dict()["symmetries"]:
        out |= set(s.get("support") or [])
    return out


def _obsnl_unidentifiable(model) -> tuple[set[str], set[str]]:
    r = obsnl.analyze(model, seed=0)
    return set(r.joint.unobservable), set(r.joint.inconclusive)


def _time(fn, repeat: int) -> tuple[float, object]:
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return statistics.median(times), out


def _row(name, obs_fn, sym_fn, expected, repeat, note=""):
    obs_fn()  # warm
    sym_ok = sym_fn is not None
    if sym_ok:
        try:
            sym_fn()
        except Exception as exc:  # noqa: BLE001 - report, do not stop the benchmark
            sym_ok, sym_err = False, f"{type(exc).__name__}: {str(exc)[:60]}"
    t_o, t_s, res_o, res_s = [], [], None, None
    for _ in range(repeat):  # alternating
        a, res_o = _time(obs_fn, 1)
        t_o.append(a)
        if sym_ok:
            b, res_s = _time(sym_fn, 1)
            t_s.append(b)
    mo = statistics.median(t_o)
    un_o, inc_o = res_o
    ok_o = (un_o == expected and not inc_o) if expected is not None else None
    if sym_ok:
        ms = statistics.median(t_s)
        un_s = _symident_unidentifiable(res_s)
        ok_s = un_s == expected if expected is not None else None
        sym_cells = f"{ms:.3f} | {', '.join(sorted(un_s)) or 'none'} | {ok_s} | {ms / mo:.1f}"
    else:
        sym_cells = f"– | {sym_err if sym_fn is not None else 'not run'} | – | –"
    row = (f"| {name} | {mo:.3f} | {', '.join(sorted(un_o)) or 'none'}"
           f"{' (undecided: ' + ', '.join(sorted(inc_o)) + ')' if inc_o else ''} | {ok_o} | {sym_cells} | {note} |")
    print(row, flush=True)
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--storeys", default="2,3,4,5,6,8,10,20")
    ap.add_argument("--symident-max-storeys", type=int, default=6, help="symident's 4096-pattern limit")
    ap.add_argument("--models", default=",".join(SWITCHED), help="switched models to run (comma-separated; '' for none)")
    ap.add_argument("--symident-timeout", type=float, default=600.0,
                    help="a building symident has not answered within this many seconds (one call) is reported so")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    try:
        import symident
        version = symident.__version__
    except ImportError:
        symident, version = None, None
    head = ["| model | obsnl s | obsnl jointly unidentifiable | obsnl = expected | symident s | "
            "symident unidentifiable | symident = expected | ratio symident/obsnl | note |",
            "|---|---:|---|---|---:|---|---|---:|---|"]
    print("\n".join(head))
    rows = []
    chosen = [m for m in args.models.split(",") if m]
    for name, (states, params, inputs, eqs, outs, expected, why) in SWITCHED.items():
        if name not in chosen:
            continue
        model = obsnl.Model(name=name, states=states, parameters=params, inputs=inputs, equations=eqs, outputs=outs)
        sym = None
        if symident is not None:
            case = _symident_case(model)
            sym = (lambda c=case: symident.detect(c))
        rows.append(_row(name, lambda m=model: _obsnl_unidentifiable(m), sym, expected, args.repeat, why))
    for n in [int(x) for x in args.storeys.split(",") if x]:
        model = bouc_wen_building(n)
        sym = None
        if symident is not None and n <= args.symident_max_storeys:
            case = _symident_case(model)
            sym = (lambda c=case: symident.detect(c))
        rep = 1 if n >= 8 else args.repeat
        rows.append(_row(f"building n={n} ({3 * n} states, {5 * n} parameters, {2 * n} switching functions)",
                         lambda m=model: _obsnl_unidentifiable(m), sym, set(), rep,
                         "every parameter identifiable (derivation in tests/test_joint_analysis.py)"))
    if args.out:
        text = ["# Switched models: obsnl's joint verdict vs symident " + str(version), "",
                "Made by `python benchmarks/bench_switched.py` (both tools warm, alternating, median of the "
                "repeats; buildings with n >= 8 once). Expected sets derived by hand (the note column; "
                "tests/test_joint.py, tests/test_joint_analysis.py).", "", *head, *rows, ""]
        Path(args.out).write_text("\n".join(text), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
