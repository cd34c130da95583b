"""Benchmark: the identifiable reparametrization of the seed model, obsnl vs symident, in one run.

For each case: obsnl's ``reparametrize`` (branches, symmetries, invariants, the new model, its
symbolic verification and identifiability check) and, where ``symident`` is installed, its
``detect(model, reconstruct=True)`` followed by ``reduce()`` on the same equations, each in a child
process with a time limit. Reported: wall times, and whether each tool found every unobservable
direction in closed form and removed it.

Cases: the seed model as written (``N`` unknown, 4 branches); the same with ``N = 2`` known (the
setting of the paper's Table 1, which makes the powers integer); the classic Bouc-Wen oscillator.
symident is run with its defaults (``positive=True``, which assumes positive states and thereby
keeps a single regime) and with the switches kept (``positive`` = the parameters).

Usage: ``python benchmarks/bench_reparam.py [--symident-seconds 300] [--out reports/benchmarks/reparam.md]``
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import platform
import sys
import time
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _models():
    import obsnl

    seed = obsnl.read_model(ROOT / "models" / "damage_healing.toml")
    N = seed.symbol("N")
    fixed = seed.replace(
        name="damage_healing_N2", parameters=[p.name for p in seed.parameters if p != N],
        equations={s.name: e.subs(N, 2) for s, e in seed.equations.items()},
        values={k: v for k, v in seed.values.items() if k != "N"}, latex={k: v for k, v in seed.latex.items() if k != "N"})
    bw = obsnl.read_model(ROOT / "models" / "bouc_wen.toml")
    return [("seed model (N unknown)", seed), ("seed model, N = 2 known", fixed), ("Bouc-Wen (n unknown)", bw)]


def run_obsnl(model) -> dict:
    from obsnl import reparametrize

    t = time.perf_counter()
    r = reparametrize(model, seed=0)
    dt = time.perf_counter() - t
    closed = all(s.complete for s in r.branches)
    return {"seconds": dt, "directions": [s.dimension for s in r.branches], "closed_form": closed,
            "reduced": r.complete and r.observable, "variables": len(r.mapping),
            "mapping": {k: str(v) for k, v in r.mapping.items()}, "verified": r.verified}


def _message(exc: Exception) -> str:
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    key = [ln for ln in lines[1:] if "unsupported" in ln or "not" in ln][:1]
    head = lines[0] if lines else ""
    head = head if len(head) <= 90 else head[:87] + "..."
    return f"{type(exc).__name__}: {head}" + (f" ({key[0]})" if key else "")


def _symident_child(model_dict: dict, positive: str, queue) -> None:
    warnings.simplefilter("ignore")
    import sympy as sp
    import symident

    from obsnl import Model

    m = Model.from_dict(model_dict)
    txt = lambda e: sp.sstr(e).replace("Abs(", "abs(")  # noqa: E731
    sm = symident.Model({s.name: txt(m.equations[s]) for s in m.states}, {k: txt(v) for k, v in m.outputs.items()},
                        known_inputs=[u.name for u in m.inputs], parameters=[p.name for p in m.parameters])
    out: dict = {"status": "ok"}
    kw = {} if positive == "default" else {"positive": [p.name for p in m.parameters]}
    t = time.perf_counter()
    try:
        res = symident.detect(sm, reconstruct=True, **kw)
    except Exception as exc:  # noqa: BLE001 - a peer's failure is a result
        queue.put({"status": "error", "stage": "detect", "seconds": time.perf_counter() - t,
                   "message": _message(exc)})
        return
    out["detect_seconds"] = time.perf_counter() - t
    syms = list(res.symmetries)
    out["directions"] = len(syms)
    out["closed_form"] = all(s.explicit and s.level in ("exact", "verified") for s in syms)
    out["switching"] = bool(res.info.get("switching"))
    queue.put(dict(out, partial=True))
    t = time.perf_counter()
    try:
        red = symident.reduce(res)
        out["reduce_seconds"] = time.perf_counter() - t
        out["reduced"] = not red.remaining
        out["removed"], out["remaining"] = list(red.removed), list(red.remaining)
        out["invariants"] = [i for b in red.blocks for i in (b.get("invariants") or [])]
    except Exception as exc:  # noqa: BLE001
        out.update(status="error", stage="reduce", reduce_seconds=time.perf_counter() - t,
                   message=_message(exc))
    queue.put(out)


def run_symident(model, positive: str, limit: float) -> dict:
    try:
        import symident  # noqa: F401
    except ImportError:
        return {"status": "not installed"}
    ctx = mp.get_context("spawn")
    q = ctx.Queue()
    p = ctx.Process(target=_symident_child, args=(model.to_dict(), positive, q))
    t = time.perf_counter()
    p.start()
    last: dict = {}
    done = False
    while time.perf_counter() - t < limit:
        try:
            last = q.get(timeout=1.0)
            if not last.get("partial"):
                done = True
                break
        except Exception:  # noqa: BLE001 - queue.Empty
            if not p.is_alive():
                break
    if not done:
        stage = "reduce" if last else "detect"
        last = dict(last, status="timeout" if p.is_alive() else "crashed",
                    message=f"{stage} stopped after {limit:.0f} s" if p.is_alive() else f"{stage} ended without a result")
    p.join(timeout=10)
    if p.is_alive():
        p.kill()
        p.join()
    last["seconds"] = time.perf_counter() - t
    return last


def catalogue(out: Path) -> None:
    """Every peer case with ``expected_identifiable_functions``: method, completeness, field check."""
    import json

    import obsnl
    from obsnl import reparametrize
    from obsnl.recombination import same_field

    lines = ["# Identifiable functions of the peer catalogue (obsnl.reparametrize)", "",
             "Cases of `tests/data/peer_cases` that state `expected_identifiable_functions` (generating sets of "
             "StructuralIdentifiability.jl). *same field*: our functions and the stated ones generate the same field "
             "(Jacobian rank test mod p); *contains*: the file states only some functions (its rank grows when the "
             "identifiable variables of `expected` are added) and ours contain them. *method*: the sources that "
             "were needed (symmetries = invariants of the generators found and identifiable variables; invariant "
             "pairs = products, ratios, sums of two invariants; polynomial invariants of degree <= 2; output "
             "derivatives split into identifiable terms).", "",
             "| case | seconds | directions with no closed form | method | stated set | agrees |",
             "|---|---|---|---|---|---|"]
    for p in sorted((ROOT / "tests" / "data" / "peer_cases").glob("*.json")):
        data = json.loads(p.read_text())
        if "expected_identifiable_functions" not in data:
            continue
        m = obsnl.read_model(p)
        t = time.perf_counter()
        r = reparametrize(m, seed=0)
        dt = time.perf_counter() - t
        v = list(m.states) + list(m.parameters)
        stated = data["expected_identifiable_functions"]
        full = same_field(stated, stated + list(data["expected"]["identifiable"]), v).same
        cmp = same_field(list(r.functions), stated, v)
        ok = cmp.same if full else cmp.a_contains_b
        missing = sum(s.missing for s in r.branches)
        lines.append(f"| {p.stem} | {dt:.2f} | {missing} | {r.method} | {'full' if full else 'partial'} "
                     f"| {('same field' if full else 'contains') if ok else 'NO'} |")
        print(f"{p.stem}: {dt:.2f} s {r.method} {'ok' if ok else 'MISMATCH'}", flush=True)
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {out}")


def _fmt(x) -> str:
    return "-" if x is None else (f"{x:.2f}" if isinstance(x, float) else str(x))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--symident-seconds", type=float, default=300.0, help="time limit per symident run")
    ap.add_argument("--out", default=str(ROOT / "reports" / "benchmarks" / "reparam.md"))
    ap.add_argument("--catalogue-only", action="store_true", help="only write reparam_catalogue.md")
    args = ap.parse_args(argv)
    catalogue(Path(args.out).with_name("reparam_catalogue.md"))
    if args.catalogue_only:
        return 0
    t = time.perf_counter()
    import obsnl  # noqa: F401
    import scipy.optimize  # noqa: F401 - imported by the branch splitter; counted apart
    import_s = time.perf_counter() - t
    load0 = os.getloadavg()[0]
    rows = []
    for label, model in _models():
        ours = run_obsnl(model)
        print(f"{label}: obsnl {ours['seconds']:.2f} s, closed form {ours['closed_form']}", flush=True)
        peers = {pos: run_symident(model, pos, args.symident_seconds) for pos in ("default", "switches")}
        for pos, s in peers.items():
            print(f"  symident ({pos}): {s.get('status')} {s.get('seconds', 0):.1f} s {s.get('message', '')}", flush=True)
        rows.append((label, ours, peers))
    lines = [
        "# Identifiable reparametrization: obsnl vs symident",
        "",
        f"Generated by `benchmarks/bench_reparam.py` ({time.strftime('%Y-%m-%d')}, Python {platform.python_version()}, "
        f"{platform.machine()}). One run, same machine; times are wall-clock seconds (obsnl after its imports, "
        f"which took {import_s:.2f} s; symident in a child process, limit {args.symident_seconds:.0f} s per run). "
        f"The machine is shared: 1-minute load average {load0:.1f} at the start and {os.getloadavg()[0]:.1f} at the "
        f"end on {os.cpu_count()} cores, so absolute times are inflated; compare within a row.",
        "",
        "obsnl: `reparametrize(model)` = branches, symmetries per branch, invariants, new model, symbolic "
        "verification and identifiability check of the new model. symident: `detect(model, reconstruct=True)` "
        "then `reduce()`; *default* = its defaults (`positive=True`: states assumed positive, which decides the "
        "switches and keeps one regime), *switches* = `positive` set to the parameters so that the switches stay.",
        "",
        "| case | tool | seconds | directions | all in closed form | all removed | notes |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, ours, peers in rows:
        lines.append(f"| {label} | obsnl | {ours['seconds']:.2f} | {'/'.join(map(str, ours['directions']))} per branch "
                     f"| {'yes' if ours['closed_form'] else 'no'} | {'yes' if ours['reduced'] else 'no'} "
                     f"| {ours['variables']} variables, verified {'yes' if ours['verified'] else 'no'} |")
        for pos, s in peers.items():
            if s.get("status") == "not installed":
                lines.append(f"| {label} | symident ({pos}) | - | - | - | - | not installed |")
                continue
            note = s.get("message", "")
            if s.get("invariants"):
                note = (note + "; " if note else "") + "invariants: " + ", ".join(s["invariants"])
            if s.get("status") == "ok" and not s.get("reduced", False):
                note = (note + "; " if note else "") + f"remaining {', '.join(s.get('remaining', []))}"
            lines.append(f"| {label} | symident ({pos}) | {_fmt(s.get('seconds'))} | {_fmt(s.get('directions'))} "
                         f"| {('yes' if s['closed_form'] else 'no') if 'closed_form' in s else '-'} "
                         f"| {('yes' if s['reduced'] else 'no') if 'reduced' in s else '-'} "
                         f"| {s.get('status')}{': ' + note if note else ''} |")
    lines += ["", "obsnl's proposal for the seed model (N unknown):", ""]
    lines += [f"- `{k} = {v}`" for k, v in rows[0][1]["mapping"].items()]
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
