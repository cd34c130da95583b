"""Commands of the estimation side and the studies: identify, reproduce, bank."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from obsnl.cli.common import (_Exit, _add_executor, _at_least, _executor, _load, _passes, _progress,  # noqa: F401
                              _replicates, _seed, write_output)


def _add_bank(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "bank",
        help="run the observer-bank crack benchmark on the cantilever link",
        description="Run the observer-bank scenarios (healthy link, a breathing crack in each element) with "
        "several noise seeds; write a localisation table (bank.md), force plots (forces_*.png) and bank.json.",
    )
    p.add_argument("--seeds", type=_at_least(1), default=3, help="noise seeds per scenario (default: 3); thresholds use as many other seeds")
    p.add_argument("--out", default="reports/bank", help="output folder (default: reports/bank)")
    p.add_argument("--model", default=None, help="link model file (default: obsnl:cantilever_link, the packaged "
                   "models/cantilever_link.toml)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=_cmd_bank)


def _cmd_bank(args: argparse.Namespace) -> int:
    from obsnl.report.bank import check_bank_output, write_bank_report
    from obsnl.studies.link_model import read_link_spec
    from obsnl.studies.link_study import check_bank_settings, run_link_study

    spec = read_link_spec(args.model)  # the model file and its [bank] table are checked before any work
    scenarios = ["healthy"] + [f"crack{c}" for c in check_bank_settings(spec)["crack_elements"]]
    check_bank_output(args.out, scenarios, force=args.force)
    study = run_link_study(seeds=args.seeds, spec=spec)
    files = write_bank_report(study, args.out, force=args.force)  # all files or none
    print(f"wrote {', '.join(str(f) for f in files[:2])} and {len(files) - 2} force plots")
    return 0


# --------------------------------------------------------------------------- identify, reproduce
def _add_identify(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "identify", help="identify a model's parameters from measured data (or a simulated study) with a UKF/DUKF",
        description="Analyse MODEL (a structurally unidentifiable parameter stops the run), then estimate its "
        "parameters with the UKF or the DUKF from --data (CSV: time_s or t, one column per model input and output) "
        "or, as a simulation study, from the model's [values] driven by --record. Guesses: the model's [guess] table, "
        "then --guess. The filter is refined by maximum likelihood (--no-refine: the filter alone). Writes "
        "DIR/identify.json, fit.png, traces.png and profiles.png with --out.")
    p.add_argument("model", help="model file (.toml or .json)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", help="measured inputs and outputs (.csv)")
    src.add_argument("--record", help="simulation study: ground motion (.csv or PEER .AT2) driving the [values]")
    p.add_argument("--table", help="branch table JSON (required for --method dukf)")
    p.add_argument("--method", choices=("ukf", "dukf"), default="ukf", help="filter (default: ukf)")
    p.add_argument("--guess", action="append", default=[], metavar="P=V", help="initial guess (repeatable)")
    p.add_argument("--noise", action="append", default=[], metavar="NAME=RATIO",
                   help="noise-to-signal RMS ratio of a channel (repeatable) or RATIO for all; measured channels not "
                   "named are estimated from their high-frequency residual (default in a study: 0.001)")
    p.add_argument("--passes", type=_passes, default=3, help="passes over the record (default: 3)")
    p.add_argument("--allow-unidentifiable", action="store_true", help="run despite the structural verdict")
    p.add_argument("--hold", action="store_true", help="hold poorly informed parameters at their guess (default: "
                   "nothing is held)")
    p.add_argument("--no-refine", action="store_true", help="skip the maximum-likelihood refinement after the filter "
                   "(no profile-likelihood intervals; convergence is then not checked)")
    p.add_argument("--seed", type=_seed, default=0, help="noise seed of a study and the Monte-Carlo (default: 0)")
    for flag, what in (("--s0", "prior std of log-parameters"), ("--q-theta", "random walk of log-parameters"),
                       ("--q-x", "factor on the state noise"), ("--gate", "innovation gate")):
        p.add_argument(flag, type=float, default=None, help=f"{what} (default: tuned by the output misfit)")
    p.add_argument("--samples", type=_at_least(2), default=None, help="use only the first samples of a --record")
    p.add_argument("--jit", action="store_true", help="compile the filter to C (needs a C compiler)")
    p.add_argument("--replicates", type=_replicates, default=0, help="Monte-Carlo replicates (0: off, else >= 3)")
    _add_executor(p)
    p.add_argument("--out", default=None, metavar="DIR", help="output folder (default: print only)")
    p.add_argument("--force", action="store_true", help="overwrite existing output files")
    p.set_defaults(func=_cmd_identify)


def _cmd_identify(args: argparse.Namespace) -> int:
    from obsnl.identification.experiments import Tuning
    from obsnl.report.identification import identify_text
    from obsnl.identification.identify import IDENTIFY_FILES, identify, study, write_identification
    from obsnl.identification.structural import parse_assignments

    for given, option, needs in ((args.samples is not None and args.data, "--samples", "a --record study; cut the "
                                  "data file instead"),
                                 ((args.workers is not None or args.scheduler) and args.replicates == 0,
                                  "--workers/--scheduler", "the Monte-Carlo replicates: add --replicates N (nothing "
                                  "else of identify runs in parallel)")):
        if given:  # an option that would be ignored is refused, not dropped silently
            raise _Exit(2, f"{option} applies to {needs}")
    if args.out:  # refused before any work: an output folder that cannot take the files
        from obsnl.report.files import check_folder

        check_folder(args.out, IDENTIFY_FILES, force=args.force)
    model = _load(args.model)
    names = [s.name for s in model.parameters]
    guess = parse_assignments(args.guess, names, option="--guess", what="parameter")
    channels = [s.name for s in model.inputs] + list(model.outputs)
    plain = [v for v in args.noise if "=" not in v]
    try:
        noise = {c: float(plain[-1]) for c in channels} if plain else {}
    except ValueError:
        raise _Exit(2, f"--noise {plain[-1]!r}: give NAME=RATIO or one RATIO for every channel") from None
    named = [v for v in args.noise if "=" in v]
    noise.update(parse_assignments(named, channels, option="--noise", what="model input or output"))
    if args.record and named:
        raise _Exit(2, "a simulation study (--record) takes one --noise RATIO for every channel")
    t = (args.s0, args.q_theta, args.q_x, args.gate)
    tuning = None if t == (None,) * 4 else Tuning(*(d if v is None else v for v, d in zip(t, (0.2, 0.0, 1.0, float("inf")))))
    opts = dict(guess=guess, method=args.method, table=args.table, passes=args.passes, replicates=args.replicates,
                seed=args.seed, allow_unidentifiable=args.allow_unidentifiable, jit=args.jit, executor=_executor(args))
    # the bar (the library's) starts with the first pass, after the checks: a refusal prints one line only
    if args.data:
        res = identify(model, args.data, noise=noise, tuning=tuning, hold=args.hold, progress=True,
                       refine=not args.no_refine, **opts)
    else:
        res = study(model, args.record, noise=float(plain[-1]) if plain else 1e-3, samples=args.samples,
                    tuning=tuning, hold=args.hold, progress=True, refine=not args.no_refine, **opts)
    write_output(identify_text(res.to_dict()), None, force=False)
    if args.out:
        files = write_identification(res, args.out, force=args.force)
        print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def _add_reproduce(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "reproduce",
        help="reproduce the seed paper's Table 2 and Figures 2-3 (analysis -> tables -> UKF and DUKF)",
        description="The whole seed pipeline: analyse the damage-healing model, write its branch table, tune the "
        "UKF and the DUKF on noise seeds that are not reported, run both on --seeds noise seeds and write "
        "table2.json/.md/.tex and fig2_*.png, fig3_*.png into --out. The default output folder "
        "reports/identification (or reports/identification/RECORD with --record) is REGENERATED on every run; "
        "another --out is never overwritten without --force.",
    )
    p.add_argument("--record", default=None, help="another ground motion (.csv or .AT2); resampled to 100 Hz, first 2000 samples")
    p.add_argument("--seeds", type=_at_least(1), default=5, help="reported noise seeds 0..K-1 (default: 5)")
    p.add_argument("--tuning-seeds", type=_at_least(1), default=5, help="noise seeds used for tuning only (default: 5)")
    p.add_argument("--passes", type=_passes, default=3, help="passes of the refined protocol (default: 3)")
    p.add_argument("--samples", type=_at_least(2), default=None, help="use only the first samples (quick runs)")
    p.add_argument("--no-jit", action="store_true", help="do not compile the filters to C (slower runs)")
    p.add_argument("--replicates", type=_replicates, default=None,
                   help="Monte-Carlo replicates of the practical-identifiability check per reported run "
                        "(default: 32; 0: off)")
    p.add_argument("--out", default=None, help="output folder (default: reports/identification)")
    p.add_argument("--force", action="store_true", help="overwrite files in a non-default --out")
    _add_executor(p)
    p.set_defaults(func=_cmd_reproduce)


def _cmd_reproduce(args: argparse.Namespace) -> int:
    from obsnl.identification.runs import check_replicates
    from obsnl.estimation.records import read_record
    from obsnl.studies.seed_paper import reproduce, write_reproduction

    if args.replicates is not None:
        check_replicates(args.replicates)
    executor = _executor(args)  # a bad --workers or --scheduler is refused here, before the bar starts
    record = read_record(args.record) if args.record else None
    if record is not None:  # a step that cannot be resampled to 100 Hz is refused before the bar starts
        from obsnl.studies.seed_tasks import seed_record

        seed_record(record, args.samples)
    default = Path("reports/identification") / (record.name if record is not None else "")
    out = Path(args.out) if args.out else default
    from obsnl.report.files import check_folder
    from obsnl.studies.seed_paper import REPRODUCTION_FILES

    regenerate = args.out is None  # the default folder holds the committed results and is regenerated on purpose
    figures = [f.name for f in sorted(out.glob("fig[23]_*.png"))] if out.is_dir() and not out.is_symlink() else []
    check_folder(out, [*REPRODUCTION_FILES, *figures], force=args.force or regenerate)
    if regenerate:
        print(f"obsnl reproduce: regenerating the default folder {out} (committed results); pass --out DIR to "
              f"keep them", file=sys.stderr)
    bar = _progress("reproduce", None, "run")
    try:
        rep = reproduce(record=record, seeds=args.seeds, tuning_seeds=args.tuning_seeds, passes=args.passes,
                        jit=not args.no_jit, samples=args.samples, progress=bar, executor=executor,
                        **({} if args.replicates is None else {"replicates": args.replicates}))
    finally:
        if bar is not None:
            bar.close()
    files = write_reproduction(rep, out, force=args.force or regenerate)
    print(f"wrote {len(files)} files to {out}: " + ", ".join(f.name for f in files))
    return 0


#: Subcommands in the order ``obsnl --help`` lists them.
