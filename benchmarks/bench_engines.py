"""obsnl against symident on every peer case and catalogue model: both warm in one process,
alternating, one fresh interpreter per case; first calls reported separately.

Plain script (no pytest):

    python benchmarks/bench_engines.py [--out reports/benchmarks/engines.md] [--repeat 5] [--timeout 300]
                                       [--method auto]

For each model a fresh interpreter (``--case PATH``, a time limit per case) imports both tools
(import times reported), times each tool's first call (what a one-off command pays: caches, lazy
imports, JIT of the peer's kernel), then ``--repeat`` rounds that alternate obsnl and symident on
the same model and reports the medians (what a user running many analyses in one session sees).
obsnl: ``analyze(model, method=..., seed=0)`` including branch splitting. symident:
``detect(Model(...))`` on every smooth branch of the model (the same equations obsnl analyses; the
conversion of the equations to symident's input is not timed). Ratio = symident / obsnl (medians
of the warm rounds; first calls separately). Agreement: the published classes (peer cases:
``expected``; the seed models: the seed paper's 3.2 and Table 1, per branch); symident's
unobservable set is the union of the supports of the non-identifiable directions it reports.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PAPER_LOST = {"sigma", "eta", "E_h", "A_m", "L", "E", "sigma_y", "c_eta", "c", "h", "beta", "gamma"}
SEED_EXPECTED = {  # seed paper 000_d24855f97fc8bdd4.txt: 3.2 (original, N unknown) and Table 1 (reparametrized)
    "damage_healing": {"a": PAPER_LOST, "b": PAPER_LOST | {"w_h"}, "c": PAPER_LOST, "d": PAPER_LOST | {"w_h"}},
    "damage_healing_reparam": {"a": {"Delta2"}, "b": {"Delta1", "w_h"}, "c": {"Delta2"}, "d": {"Delta1", "w_h"}},
}


def _cases() -> list[Path]:
    return sorted((ROOT / "tests" / "data" / "peer_cases").glob("*.json")) + [
        ROOT / "models" / "damage_healing.toml", ROOT / "models" / "damage_healing_reparam.toml"]


# --------------------------------------------------------------------------- symident
def _symident_models(path: str) -> list[tuple[str, dict]]:
    """(branch label, keyword arguments of symident.Model) for every smooth branch."""
    import sympy as sp

    import obsnl

    model = obsnl.read_model(path)
    out = []
    for br in obsnl.model.split_branches(model):
        m = br.model
        kw = dict(
            odes={s.name: sp.sstr(m.equations[s]) for s in m.states},
            observables={k: sp.sstr(v) for k, v in m.outputs.items()},
            known_inputs=[u.name for u in m.inputs],
            unknown_inputs=[w.name for w in m.unknown_inputs],
            parameters=[p.name for p in m.parameters
                        if any(p in e.free_symbols for e in list(m.rhs) + list(m.output_exprs))],
        )
        fixed = [c.name for c in m.known_constants]
        trafo = {}
        for s in m.known_initial_conditions:
            if s in m.initial_condition_values:
                trafo[s.name] = sp.sstr(m.initial_condition_values[s])
            else:
                trafo[s.name] = f"{s.name}_known0"
                fixed.append(f"{s.name}_known0")
        if trafo:
            kw["trafo"] = trafo
        if fixed:
            kw["fixed"] = fixed
        absent = [p.name for p in m.parameters if p.name not in kw["parameters"]]
        out.append((br.label, kw, absent))
    return out


# --------------------------------------------------------------------------- agreement
def _expected(path: Path) -> tuple[dict[str, set] | None, set | None, set]:
    """(per-branch expected unobservable sets or None, overall expected set or None, classified names)."""
    name = path.stem
    if name in SEED_EXPECTED:
        exp = SEED_EXPECTED[name]
        return exp, None, set().union(*exp.values())
    data = json.loads(path.read_text())
    e = data["expected"]
    return None, set(e["nonidentifiable"]), set(e["identifiable"]) | set(e["nonidentifiable"])


def agrees(path: Path, branches: dict[str, set]) -> bool:
    per_branch, overall, listed = _expected(path)
    if per_branch is not None:
        return all(branches.get(k, None) is not None and branches[k] == v for k, v in per_branch.items())
    lost = set.intersection(*branches.values()) if branches else set()
    return lost & listed == overall and overall <= lost


# --------------------------------------------------------------------------- one case, one interpreter
def _lost_symident(res, absent) -> set:
    lost = set(absent)  # parameters absent from the branch are unidentifiable there
    for sym in res.to_dict().get("symmetries", []):
        lost |= set(sym.get("support") or sym.get("generator", {}).keys())
    return lost


def run_case(path: Path, repeat: int, method: str) -> dict:
    """Both tools in this interpreter: imports, first calls, then alternating warm rounds."""
    out: dict = {"model": path.stem}
    t0 = time.perf_counter()
    import obsnl
    out["import_obsnl"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    try:
        import symident
    except ImportError:
        symident = None
    out["import_symident"] = time.perf_counter() - t0
    model = obsnl.read_model(path)
    branches = _symident_models(str(path)) if symident is not None else []

    def call_obsnl():
        return obsnl.analyze(model, method=method, seed=0)

    def call_symident():
        return {label: _lost_symident(symident.detect(symident.Model(**kw)), absent) for label, kw, absent in branches}

    calls = {"obsnl": call_obsnl} | ({"symident": call_symident} if symident is not None else {})
    results = {}
    for name, f in calls.items():  # first calls
        t0 = time.perf_counter()
        try:
            results[name] = f()
        except Exception as exc:  # noqa: BLE001 - a peer tool's failure is data for the table
            out[f"{name}_error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0][:120] if str(exc) else ''}"
        out[f"{name}_first"] = time.perf_counter() - t0
    warm: dict[str, list[float]] = {k: [] for k in calls if k in results}
    for _ in range(repeat):
        for name in warm:
            t0 = time.perf_counter()
            calls[name]()
            warm[name].append(time.perf_counter() - t0)
    for name, ts in warm.items():
        out[f"{name}_warm"] = statistics.median(ts)
    res = results.get("obsnl")
    if res is not None:
        out["obsnl_ok"] = agrees(path, {b.label: set(b.unobservable) for b in res.branches})
        out["obsnl_engines"] = sorted({b.method for b in res.branches})
    if "symident" in results:
        out["symident_ok"] = agrees(path, results["symident"])
    return out


def _child(path: Path, args) -> dict:
    cmd = [sys.executable, str(Path(__file__).resolve()), "--case", str(path), "--repeat", str(args.repeat),
           "--method", args.method]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout,
                              env=dict(os.environ, PYTHONPATH=str(ROOT)))
    except subprocess.TimeoutExpired:
        return {"model": path.stem, "error": f"time limit {args.timeout:.0f} s for the case"}
    if proc.returncode != 0:
        return {"model": path.stem, "error": (proc.stderr.strip().splitlines() or ["?"])[-1][:160]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _f(x) -> str:
    return "" if x is None else f"{x:.3f}"


def _r(x) -> str:
    return "" if x is None else f"{x:.1f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="Markdown file to write (default: print only)")
    ap.add_argument("--repeat", type=int, default=5, help="warm rounds per case (alternating)")
    ap.add_argument("--timeout", type=float, default=300.0, help="time limit of one case's interpreter (s)")
    ap.add_argument("--method", default="auto", choices=("auto", "orc", "sedoglavic"), help="obsnl's engine")
    ap.add_argument("--case", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        print(json.dumps(run_case(Path(args.case), args.repeat, args.method)))
        return 0
    rows = []
    for path in _cases():
        r = _child(path, args)
        rows.append(r)
        w = r["symident_warm"] / r["obsnl_warm"] if r.get("obsnl_warm") and r.get("symident_warm") else None
        f = r["symident_first"] / r["obsnl_first"] if r.get("obsnl_first") and r.get("symident_warm") else None
        r["ratio_warm"], r["ratio_first"] = w, f
        print(f"{r['model']:32s} obsnl warm {_f(r.get('obsnl_warm')):>7s} first {_f(r.get('obsnl_first')):>7s} | "
              f"symident warm {_f(r.get('symident_warm')):>7s} first {_f(r.get('symident_first')):>7s} | "
              f"ratio warm {_r(w)} first {_r(f)} "
              f"{r.get('error', '') or r.get('symident_error', '')}", flush=True)
    warm = [r["ratio_warm"] for r in rows if r.get("ratio_warm")]
    first = [r["ratio_first"] for r in rows if r.get("ratio_first")]
    imp_o = [r["import_obsnl"] for r in rows if "import_obsnl" in r]
    imp_s = [r["import_symident"] for r in rows if "import_symident" in r]
    summary = [
        f"- median ratio symident/obsnl, warm (median of {args.repeat} alternating rounds): "
        + (f"**{statistics.median(warm):.1f}** over {len(warm)} models (range {min(warm):.1f} to {max(warm):.1f})" if warm else "-"),
        "- median ratio of the first calls in a fresh interpreter: " + (f"{statistics.median(first):.1f}" if first else "-"),
        "- median import time: obsnl " + (f"{statistics.median(imp_o):.2f} s" if imp_o else "-")
        + ", symident after obsnl " + (f"{statistics.median(imp_s):.2f} s" if imp_s else "-"),
        f"- obsnl agrees with the published answer on {sum(1 for r in rows if r.get('obsnl_ok'))} of {len(rows)} "
        f"models; symident on {sum(1 for r in rows if r.get('symident_ok'))}",
    ]
    print("\n".join(summary))
    if args.out:
        import obsnl
        try:
            import symident
            si_v = getattr(symident, "__version__", "?")
        except ImportError:
            si_v = "not installed"
        lines = [
            "# Observability engines: obsnl vs symident", "",
            f"Generated by `python benchmarks/bench_engines.py --repeat {args.repeat} --method {args.method}` on "
            f"{platform.machine()} ({os.cpu_count()} cores, shared with other developers' jobs during the run), "
            f"Python {platform.python_version()}, obsnl {obsnl.__version__}, symident {si_v}.", "",
            "One fresh interpreter per model; both tools imported first; each tool's first call timed; then "
            f"{args.repeat} rounds alternating obsnl and symident, medians reported. Ratio = symident / obsnl. "
            "An earlier version of this table timed symident's first call in a fresh process against obsnl's best "
            "warm call; the warm ratio below is what a user running many analyses in one session sees, the first-call "
            "ratio what a one-off command pays.", "",
            *summary, "",
            "| model | obsnl warm (s) | symident warm (s) | ratio warm | obsnl first (s) | symident first (s) | "
            "ratio first | obsnl agrees | symident agrees | note |",
            "|---|---:|---:|---:|---:|---:|---:|:---:|:---:|---|",
        ]
        yn = {True: "yes", False: "NO", None: ""}
        for r in rows:
            lines.append(
                f"| {r['model']} | {_f(r.get('obsnl_warm'))} | {_f(r.get('symident_warm'))} | "
                f"{_r(r.get('ratio_warm'))} | "
                f"{_f(r.get('obsnl_first'))} | {_f(r.get('symident_first'))} | "
                f"{_r(r.get('ratio_first'))} | "
                f"{yn[r.get('obsnl_ok')]} | {yn[r.get('symident_ok')]} | {r.get('error', '') or r.get('symident_error', '')} |")
        Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
