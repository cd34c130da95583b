"""Time obsnl's observability engines on every peer case and both seed models, against symident.

Plain script (no pytest):

    python benchmarks/bench_engines.py [--out reports/benchmarks/engines.md] [--timeout 120] [--repeat 3]

For each model it times ``obsnl.observability.analyze`` (randomized test, the default fast path) and, when the
``symident`` package is importable, ``symident.detect`` on the same model in the same run (best of
``--repeat`` in-process runs for obsnl after one warm-up; symident in a fresh worker process per
call with a time limit, ``--seed-runs`` calls on the seed models). For the two seed models it also
times the stages of an analysis in fresh interpreters (import, first call, split, prepare, series),
next to those of an older checkout given with ``--before``. It prints and writes a Markdown table:
times, the ratio symident/obsnl, and each tool's agreement with the published answer (``expected``
of the peer case; the seed paper's 3.2 and Table 1 for the two seed models). symident's
unobservable set is the union of the supports of the non-identifiable directions it reports.
Non-smooth models are given to symident branch by branch (the smooth models obsnl analyses), so
both tools see the same equations.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import platform
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

PAPER_LOST = {"sigma", "eta", "E_h", "A_m", "L", "E", "sigma_y", "c_eta", "c", "h", "beta", "gamma"}
ENGINE_MODULES = ("analyze", "augment", "branches", "decompose", "exact", "lie", "modp", "problem", "sedoglavic",
                  "series", "slp", "taylor", "model", "parse")
SEED_EXPECTED = {  # seed paper 000_d24855f97fc8bdd4.txt: 3.2 (original, N unknown) and Table 1 (reparametrized)
    "damage_healing": {"a": PAPER_LOST, "b": PAPER_LOST | {"w_h"}, "c": PAPER_LOST, "d": PAPER_LOST | {"w_h"}},
    "damage_healing_reparam": {"a": {"Delta2"}, "b": {"Delta1", "w_h"}, "c": {"Delta2"}, "d": {"Delta1", "w_h"}},
}


def _cases() -> list[Path]:
    cases = sorted((ROOT / "tests" / "data" / "peer_cases").glob("*.json"))
    return cases + [ROOT / "obsnl" / "catalogue" / "damage_healing.toml", ROOT / "obsnl" / "catalogue" / "damage_healing_reparam.toml"]


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
    return {"seconds": min(times[1:]), "median": statistics.median(times[1:]), "branches": per_branch,
            "overall": set(res.overall_unobservable), "inconclusive": inconclusive}


# One fresh interpreter per measurement: import time, the first analyze call, then the stages of
# later calls (best of REPEAT). Self-contained, so that it also runs against an older checkout
# (PYTHONPATH=that checkout) for a before/after under the same machine load.
_STAGE_CODE = r"""
import json, time
t0 = time.perf_counter()
import obsnl
try:  # this tree: bound sizes in obsnl.algebra.bounds
    from obsnl.algebra.bounds import bound_sizes as _bound_args
except ImportError:  # older checkouts
    from obsnl.observability.analyze import _bound_args
from obsnl.algebra.augment import rationalize
from obsnl.observability.decompose import decompose
from obsnl.observability.sedoglavic import sedoglavic_block
from obsnl.algebra.series import make_problem
out = {"import": time.perf_counter() - t0}
model = obsnl.load_model(PATH)
t0 = time.perf_counter()
obsnl.analyze(model, method="sedoglavic", seed=0)
out["first"] = time.perf_counter() - t0
best = {"split": 1e9, "prepare": 1e9, "series": 1e9, "total": 1e9}
for rep in range(REPEAT):
    t = {"split": 0.0, "prepare": 0.0, "series": 0.0}
    t0 = time.perf_counter()
    branches = obsnl.split_branches(model)
    t["split"] = time.perf_counter() - t0
    for b in branches:
        t1 = time.perf_counter()
        problems = [make_problem(rationalize(blk)) for blk in decompose(b.model).blocks]
        bargs = [_bound_args(pr) for pr in problems]
        t2 = time.perf_counter()
        for i, (pr, ba) in enumerate(zip(problems, bargs)):
            sedoglavic_block(pr, seed=f"0:{b.label}:{i}", bound_args=ba, target=0.01 / len(branches))
        t["series"] += time.perf_counter() - t2
        t["prepare"] += t2 - t1
    t0 = time.perf_counter()
    obsnl.analyze(model, method="sedoglavic", seed=0)
    t["total"] = time.perf_counter() - t0
    best = {k: min(best[k], t[k]) for k in best}
out.update(best)
print(json.dumps(out))
"""


def stage_times(path: Path, repeat: int, checkout: Path = ROOT) -> dict[str, float]:
    """Seconds of the stages of ``analyze(method="sedoglavic")`` on one model, in a fresh interpreter.

    ``import`` (importing obsnl), ``first`` (the first call, imports excluded), then the best of
    ``repeat`` later calls of each stage: ``split`` (split_branches), ``prepare`` (per block:
    decomposition, rationalization, program compilation, bound sizes), ``series`` (the randomized
    runs with their confirmation) and ``total`` (one whole ``analyze``, timed separately).
    ``checkout`` is the source tree to import obsnl from (an older commit for a before/after).
    """
    import subprocess

    code = _STAGE_CODE.replace("PATH", repr(str(path))).replace("REPEAT", str(repeat))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PYTHONPATH"] = str(checkout)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=checkout,
                         env=env)
    return json.loads(out.stdout.strip().splitlines()[-1])


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


def _commit(checkout: Path) -> str:
    import subprocess

    out = subprocess.run(["git", "-C", str(checkout), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    engine = [f"obsnl/{m}.py" for m in ENGINE_MODULES]
    dirty = subprocess.run(["git", "-C", str(checkout), "status", "--porcelain", "--", *engine], capture_output=True,
                           text=True).stdout.strip()
    return (out.stdout.strip() or "?") + (" + uncommitted engine changes" if dirty else "")


def _stage_section(paths: list[Path], args) -> tuple[list[str], dict[str, dict]]:
    """Where the time goes on the seed models (fresh interpreters), with an older checkout if given.

    Returns the Markdown lines and this tree's stage times per model."""
    versions = [(f"this tree ({_commit(ROOT)})", ROOT)]
    if args.before:
        versions.insert(0, (f"before ({_commit(Path(args.before))})", Path(args.before)))
    lines = [
        "",
        "## Seed models: where the time goes",
        "",
        "Each row is one fresh interpreter: importing obsnl, the first `analyze` call (imports excluded), then "
        f"the best of {args.repeat} later calls of each stage: split (`split_branches`), prepare (per block: "
        "decomposition, rationalization, program compilation, bound sizes), series (the randomized runs and "
        "their confirmation runs) and the whole `analyze` call (timed on its own). Seconds.",
        "",
        "| model | version | import | first call | split | prepare | series | analyze |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    mine: dict[str, dict] = {}
    for path in paths:
        if args.only and args.only not in path.stem:
            continue
        for label, checkout in versions:
            t = stage_times(path, args.repeat, checkout)
            lines.append(f"| {path.stem} | {label} | {t['import']:.3f} | {t['first']:.3f} | {t['split']:.3f} | "
                         f"{t['prepare']:.3f} | {t['series']:.3f} | {t['total']:.3f} |")
            print(lines[-1], flush=True)
            if checkout == ROOT:
                mine[path.stem] = t
    return lines, mine


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "engines.md"))
    ap.add_argument("--timeout", type=float, default=120.0, help="time limit of one symident call (s)")
    ap.add_argument("--repeat", type=int, default=3, help="timed obsnl runs per model (best is kept)")
    ap.add_argument("--only", default=None, help="substring filter on model names")
    ap.add_argument("--seed-runs", type=int, default=2,
                    help="symident calls on each seed model (best is kept; the spread is reported)")
    ap.add_argument("--before", default=None,
                    help="a checkout of an older commit: its seed-model stages are timed next to this one's")
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
        runs = args.seed_runs if path.stem in SEED_EXPECTED else 1
        sis = [run_symident(path, args.timeout) if have_symident else {"error": "symident not installed"}
               for _ in range(max(1, runs))]
        good = [x for x in sis if "seconds" in x]
        si = min(good, key=lambda x: x["seconds"]) if good else sis[0]
        si_ok = None if "error" in si else agrees(path, si["branches"])
        ratio = si["seconds"] / ob["seconds"] if "seconds" in si else None
        note = si.get("error", "")
        if len(good) > 1:
            note = f"symident {len(good)} runs: " + ", ".join(f"{x['seconds']:.2f}" for x in good) + " s"
        rows.append(dict(model=path.stem, obsnl=ob["seconds"], obsnl_med=ob["median"], obsnl_ok=ob_ok,
                         symident=si.get("seconds"), symident_ok=si_ok, ratio=ratio, note=note))
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
        "obsnl: `analyze(model, method=\"sedoglavic\", seed=0)`, best (and median) of "
        f"{args.repeat} after a warm-up, including branch splitting. symident: `detect(Model(...))` per smooth "
        f"branch in a fresh process (time inside the process, imports excluded), limit {args.timeout:.0f} s; "
        f"the seed models are timed {args.seed_runs} times (best kept). "
        "Agreement: the published classes (peer cases: `expected`; seed models: seed paper 3.2 and Table 1, per "
        "branch). Ratio = symident time / obsnl time (best against best).",
        "",
        "| model | obsnl (s) | obsnl median (s) | obsnl agrees | symident (s) | symident agrees | ratio | note |",
        "|---|---:|---:|:---:|---:|:---:|---:|---|",
    ]
    for r in rows:
        si_t = "" if r["symident"] is None else f"{r['symident']:.3f}"
        si_a = "" if r["symident_ok"] is None else ("yes" if r["symident_ok"] else "NO")
        rt = "" if r["ratio"] is None else f"{r['ratio']:.1f}"
        lines.append(f"| {r['model']} | {r['obsnl']:.3f} | {r['obsnl_med']:.3f} | {'yes' if r['obsnl_ok'] else 'NO'} | "
                     f"{si_t} | {si_a} | {rt} | {r['note']} |")
    lines += [
        "",
        f"- obsnl agrees with the published answer on {sum(r['obsnl_ok'] for r in rows)} of {len(rows)} models; "
        f"symident on {sum(1 for r in rows if r['symident_ok'])} of {len(rows)} "
        f"({sum(1 for r in rows if r['symident_ok'] is None)} not analysed).",
        f"- median ratio over the {len(ratios)} models both tools analysed: "
        + ("-" if med is None else f"{med:.1f}"),
    ]
    stage_lines, stages = _stage_section([ROOT / "obsnl" / "catalogue" / f"{m}.toml" for m in SEED_EXPECTED], args)
    for r in seed_rows:
        rt = "-" if r["ratio"] is None else f"{r['ratio']:.1f}"
        first = stages.get(r["model"], {}).get("first")
        cold = "" if first is None else f"; first call in a fresh process {first:.3f} s" + (
            f" (ratio {r['symident'] / first:.1f})" if r["symident"] else "")
        lines.append(f"- {r['model']}: obsnl {r['obsnl']:.3f} s (median {r['obsnl_med']:.3f} s){cold}; "
                     f"ratio {rt}; {r['note']}")
    lines.append(f"- slowest obsnl case: {max(rows, key=lambda r: r['obsnl'])['model']} "
                 f"({max(r['obsnl'] for r in rows):.3f} s)")
    lines += stage_lines
    text = "\n".join(lines) + "\n"
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text, encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
