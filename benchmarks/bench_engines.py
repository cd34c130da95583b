"""Time obsnl's observability engines on every peer case and both seed models, against symident.

Plain script (no pytest):

    python benchmarks/bench_engines.py [--out reports/benchmarks/engines.md] [--timeout 120] [--repeat 3]

For each model it times ``obsnl.analyze`` (randomized test, the default fast path) and, when the
``symident`` package is importable, ``symident.detect`` on the same model in the same run, each in
a fresh worker process per call with a time limit (best of ``--repeat`` in-process runs for obsnl
after one warm-up). It prints and writes a Markdown table: times, the ratio symident/obsnl, and
each tool's agreement with the published answer (``expected`` of the peer case; the seed paper's
3.2 and Table 1 for the two seed models). symident's unobservable set is the union of the supports
of the non-identifiable directions it reports. Non-smooth models are given to symident branch by
branch (the smooth models obsnl analyses), so both tools see the same equations.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import platform
import statistics
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
    cases = sorted((ROOT / "tests" / "data" / "peer_cases").glob("*.json"))
    return cases + [ROOT / "models" / "damage_healing.toml", ROOT / "models" / "damage_healing_reparam.toml"]


# --------------------------------------------------------------------------- obsnl
def run_obsnl(path: Path, repeat: int) -> dict:
    import obsnl

    model = obsnl.load_model(path)
    times = []
    res = None
    for _ in range(repeat + 1):
        t0 = time.perf_counter()
        res = obsnl.analyze(model, method="sedoglavic", seed=0)
        times.append(time.perf_counter() - t0)
    per_branch = {b.label: set(b.unobservable) for b in res.branches}
    inconclusive = any(b.verdict.value == "inconclusive" for b in res.branches)
    return {"seconds": min(times[1:]), "branches": per_branch, "overall": set(res.overall_unobservable),
            "inconclusive": inconclusive}


# --------------------------------------------------------------------------- symident
def _symident_models(path: str) -> list[tuple[str, dict]]:
    """(branch label, keyword arguments of symident.Model) for every smooth branch."""
    import sympy as sp

    import obsnl

    model = obsnl.load_model(path)
    out = []
    for br in obsnl.split_branches(model):
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


def _symident_worker(path: str, queue) -> None:
    try:
        import symident

        t0 = time.perf_counter()
        branches = {}
        for label, kw, absent in _symident_models(path):
            res = symident.detect(symident.Model(**kw))
            d = res.to_dict()
            lost = set(absent)  # parameters absent from the branch are unidentifiable there
            for sym in d.get("symmetries", []):
                lost |= set(sym.get("support") or sym.get("generator", {}).keys())
            branches[label] = lost
        queue.put({"seconds": time.perf_counter() - t0, "branches": branches})
    except Exception as exc:  # noqa: BLE001 - a peer tool's failure is data for the table
        queue.put({"error": f"{type(exc).__name__}: {str(exc).splitlines()[0][:120] if str(exc) else ''}"})


def run_symident(path: Path, timeout: float) -> dict:
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_symident_worker, args=(str(path), q))
    t0 = time.perf_counter()
    p.start()
    p.join(timeout)
    if p.is_alive():
        p.terminate()
        p.join()
        return {"error": f"timeout after {timeout:.0f} s"}
    try:
        out = q.get(timeout=5)
    except Exception:  # noqa: BLE001
        return {"error": f"worker exited with code {p.exitcode}"}
    out.setdefault("wall", time.perf_counter() - t0)
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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "engines.md"))
    ap.add_argument("--timeout", type=float, default=120.0, help="time limit of one symident call (s)")
    ap.add_argument("--repeat", type=int, default=3, help="timed obsnl runs per model (best is kept)")
    ap.add_argument("--only", default=None, help="substring filter on model names")
    args = ap.parse_args(argv)
    try:
        import symident  # noqa: F401

        have_symident = True
        symident_version = getattr(sys.modules["symident"], "__version__", "?")
    except ImportError:
        have_symident = False
        symident_version = None
    import obsnl  # warm the imports before timing

    obsnl.analyze(obsnl.load_model(ROOT / "tests" / "data" / "peer_cases" / "si_if_chain.json"), seed=0)
    rows = []
    for path in _cases():
        if args.only and args.only not in path.stem:
            continue
        ob = run_obsnl(path, args.repeat)
        ob_ok = agrees(path, ob["branches"]) and not ob["inconclusive"]
        si = run_symident(path, args.timeout) if have_symident else {"error": "symident not installed"}
        si_ok = None if "error" in si else agrees(path, si["branches"])
        ratio = si["seconds"] / ob["seconds"] if "seconds" in si else None
        rows.append(dict(model=path.stem, obsnl=ob["seconds"], obsnl_ok=ob_ok, symident=si.get("seconds"),
                         symident_ok=si_ok, ratio=ratio, note=si.get("error", "")))
        r = rows[-1]
        si_t = "      -  " if r["symident"] is None else f"{r['symident']:7.3f} s"
        si_a = "ok " if si_ok else ("BAD" if si_ok is False else " - ")
        rt = "    -  " if not ratio else f"{ratio:7.1f}"
        print(f"{r['model']:32s} obsnl {r['obsnl']:7.3f} s {'ok ' if ob_ok else 'BAD'}  symident {si_t} {si_a} "
              f"ratio {rt} {r['note']}", flush=True)
    ratios = [r["ratio"] for r in rows if r["ratio"]]
    med = statistics.median(ratios) if ratios else None
    seed_rows = [r for r in rows if r["model"] in SEED_EXPECTED]
    lines = [
        "# Observability engines: obsnl vs symident",
        "",
        f"Generated by `python benchmarks/bench_engines.py` on {platform.machine()} ({mp.cpu_count()} cores), "
        f"Python {platform.python_version()}, obsnl {obsnl.__version__}, symident {symident_version}.",
        "obsnl: `analyze(model, method=\"sedoglavic\", seed=0)`, best of "
        f"{args.repeat} after a warm-up, including branch splitting. symident: `detect(Model(...))` per smooth "
        f"branch in a fresh process (time inside the process, imports excluded), limit {args.timeout:.0f} s. "
        "Agreement: the published classes (peer cases: `expected`; seed models: seed paper 3.2 and Table 1, per "
        "branch). Ratio = symident time / obsnl time.",
        "",
        "| model | obsnl (s) | obsnl agrees | symident (s) | symident agrees | ratio | note |",
        "|---|---:|:---:|---:|:---:|---:|---|",
    ]
    for r in rows:
        si_t = "" if r["symident"] is None else f"{r['symident']:.3f}"
        si_a = "" if r["symident_ok"] is None else ("yes" if r["symident_ok"] else "NO")
        rt = "" if r["ratio"] is None else f"{r['ratio']:.1f}"
        lines.append(f"| {r['model']} | {r['obsnl']:.3f} | {'yes' if r['obsnl_ok'] else 'NO'} | {si_t} | {si_a} | "
                     f"{rt} | {r['note']} |")
    lines += [
        "",
        f"- obsnl agrees with the published answer on {sum(r['obsnl_ok'] for r in rows)} of {len(rows)} models; "
        f"symident on {sum(1 for r in rows if r['symident_ok'])} of {len(rows)} "
        f"({sum(1 for r in rows if r['symident_ok'] is None)} not analysed).",
        f"- median ratio over the {len(ratios)} models both tools analysed: "
        + ("-" if med is None else f"{med:.1f}"),
    ]
    for r in seed_rows:
        rt = "-" if r["ratio"] is None else f"{r['ratio']:.1f}"
        lines.append(f"- {r['model']}: obsnl {r['obsnl']:.3f} s, ratio {rt} {r['note']}")
    lines.append(f"- slowest obsnl case: {max(rows, key=lambda r: r['obsnl'])['model']} "
                 f"({max(r['obsnl'] for r in rows):.3f} s)")
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
