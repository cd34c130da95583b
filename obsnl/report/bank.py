"""The observer-bank table (seed ``001_d0508a78c5399696.txt``; numbers from
:func:`obsnl.studies.link_study.run_link_study`), as Markdown, and the report folder: ``bank.json``,
``bank.md`` and one ``forces_<scenario>.png`` per scenario, each checked before anything is written and
written under the rule of :mod:`obsnl.report.files` (an existing file or link is refused without
``force``; with it, a link is replaced by the file, never written through).

The report room sits below the studies on the data flow and does not import them: what the table reads of the
study (:class:`obsnl.studies.link_study.LinkStudy`) is written down here as protocols (:class:`BankStudy` and the
values it holds), which the study's values satisfy as they are. ``bank.json`` is the study's ``to_dict()``, made
only where it is written."""

from __future__ import annotations

import json
import math
import re
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from obsnl.errors import OutputError
from obsnl.report.files import OutputFolder, check_folder

if TYPE_CHECKING:  # the bank's own values (obsnl.linear, below this room); loaded with the study, not here
    from obsnl.linear.bank import BankDecision, Thresholds
    from obsnl.linear.observer import ExtendedObservability

__all__ = [
    "BankStudy",
    "bank_table_markdown",
    "bank_file_names",
    "check_bank_output",
    "write_bank_report",
    "bank_written_line",
    "BANK_FILES",
]

#: The files of every bank report, besides one force plot per scenario.
BANK_FILES = ("bank.json", "bank.md")
_SCENARIO = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


# the members are read-only properties: the values read are frozen dataclasses
class _Settings(Protocol):
    @property
    def model(self) -> str: ...
    @property
    def sensors(self) -> str: ...
    @property
    def channels(self) -> Sequence[str]: ...
    @property
    def severity(self) -> float: ...
    @property
    def noise(self) -> float: ...
    @property
    def dt(self) -> float: ...
    @property
    def duration(self) -> float: ...
    @property
    def onset(self) -> float: ...
    @property
    def evaluation_window(self) -> float: ...
    @property
    def ratio_band(self) -> float: ...
    @property
    def q_x(self) -> float: ...
    @property
    def q_v(self) -> float: ...
    @property
    def fictitious_model(self) -> str: ...
    @property
    def evaluation_seeds(self) -> Sequence[int]: ...


class _Run(Protocol):
    @property
    def scenario(self) -> str: ...
    @property
    def crack_element(self) -> int | None: ...
    @property
    def truth_rms(self) -> float: ...
    @property
    def decision(self) -> BankDecision: ...


class _Gate(Protocol):
    @property
    def sensors(self) -> str: ...
    @property
    def channels(self) -> Sequence[str]: ...
    @property
    def element(self) -> int: ...
    @property
    def check(self) -> ExtendedObservability: ...
    @property
    def condition(self) -> float | None: ...


class BankStudy(Protocol):
    """What :func:`bank_table_markdown` reads of an observer-bank study
    (:class:`obsnl.studies.link_study.LinkStudy`): its settings, thresholds, scenario runs and gate checks."""

    @property
    def settings(self) -> _Settings: ...
    @property
    def thresholds(self) -> Thresholds: ...
    @property
    def gates(self) -> Sequence[_Gate]: ...
    @property
    def runs(self) -> Sequence[_Run]: ...


class _Report(BankStudy, Protocol):
    """What :func:`write_bank_report` reads besides: the traces of the force plots and the JSON document."""

    @property
    def traces(self) -> Mapping[str, Any]: ...
    def to_dict(self) -> Mapping[str, Any]: ...


def _stored(x: float | None) -> float | None:
    """The number as ``bank.json`` stores it: None for a missing or non-finite one (JSON has no infinity)."""
    return None if x is None or not math.isfinite(x) else float(x)


def _bank_num(x: Any, fmt: str = ".3f") -> str:
    return "–" if x is None else format(x, fmt)


def _bank_counts(values: Sequence[Any], n: int) -> str:
    c = Counter("–" if v is None else str(v) for v in values)
    if len(c) == 1 and "–" in c:
        return "–"
    return ", ".join(f"{k} ({v}/{n})" for k, v in c.most_common())


def _bank_span(values: Sequence[float | None], fmt: str = ".3f") -> str:
    v = [x for x in values if x is not None]
    if not v:
        return "–"
    lo, hi = min(v), max(v)
    return _bank_num(lo, fmt) if format(lo, fmt) == format(hi, fmt) else f"{_bank_num(lo, fmt)}–{_bank_num(hi, fmt)}"


def _gate_row(g: _Gate) -> str:
    """One row of the gate table: the largest static-gain condition number over the channels, "–" when there is no
    channel or it is infinite (a singular gain)."""
    chk = g.check
    sv = ", ".join(f"{x:.2e}" for x in chk.channels[0].singular_values)
    cond = _stored(g.condition)
    return (
        f"| {g.sensors} | {'+'.join(g.channels)} | {g.element} | {chk.n_outputs} | "
        f"{chk.n_channels} | {chk.verdict.value} | {sv} | {_bank_num(cond, '.3g')} | "
        f"{chk.reason or '–'} |"
    )


def bank_table_markdown(study: BankStudy) -> str:
    """The localisation table (one row per scenario, aggregated over seeds), thresholds and gates.

    Parameters
    ----------
    study : BankStudy
        A :class:`obsnl.studies.link_study.LinkStudy` (or a value with its attributes, :class:`BankStudy`).
        A number ``bank.json`` stores as null (not finite) is shown as "–" or left out of a span, as there.

    Returns
    -------
    str
        The Markdown of ``bank.md``.
    """
    st, thr = study.settings, study.thresholds
    labels = list(thr.labels)
    out = ["# Observer bank on the cantilever link", ""]
    out.append(
        f"Scenarios of docs/observer_bank.md section 2.5 (source: {st.model}). Sensors {st.sensors}, "
        f"force channels {', '.join(st.channels)} ({st.fictitious_model} model, q_x = {st.q_x:g}, "
        f"q_v = {st.q_v:g}), crack severity {st.severity:g}, noise {100 * st.noise:g} % of the healthy "
        f"RMS, dt = {st.dt:g} s, T = {st.duration:g} s, crack onset at {st.onset:g} s."
    )
    out.append("")
    out.append(
        f"Evaluation seeds {', '.join(map(str, st.evaluation_seeds))}; thresholds from healthy runs with the "
        f"other seeds {', '.join(map(str, thr.seeds))}: tau = {thr.factor:g} × the largest "
        f"{thr.window:g}-s sliding RMS. Location: RMS over the last {st.evaluation_window:g} s; "
        f"'inconclusive' when the two largest forces are within a ratio of {st.ratio_band:g} or the rules disagree. "
        f"'located' names the observer whose force wins, not the cracked element: the bank has observers at elements "
        f"{', '.join(labels)} only, so a crack between them is located at its nearest observer (a crack at element 1 "
        f"at observer 2, as the benchmark's scoring expects, docs/observer_bank.md section 2.6)."
    )
    out += ["", "| observer (element) | healthy floor [N·m] | tau [N·m] |", "|---|---|---|"]
    for lab, floor, tau in zip(labels, thr.floor, thr.tau):
        out.append(f"| {lab} | {floor:.4f} | {tau:.4f} |")
    out += ["", "## Localisation (mean RMS force over seeds)", ""]
    head = ["scenario", "crack element", "truth RMS [N·m]"] + [f"RMS n̂ obs {lab} [N·m]" for lab in labels]
    head += ["detected", "time to detection [s]", "magnitude rule", "residual rule", "margin", "verdict"]
    out += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    by_scn: dict[str, list[_Run]] = {}
    for r in study.runs:
        by_scn.setdefault(r.scenario, []).append(r)
    for name, rs in by_scn.items():
        n = len(rs)
        ds = [r.decision for r in rs]
        forces = [dict(zip(d.labels, d.rms_force)) for d in ds]
        row = [name, _bank_num(rs[0].crack_element, "d"), f"{rs[0].truth_rms:.3f}"]
        row += [f"{np.mean([f[lab] for f in forces]):.3f}" for lab in labels]
        row += [
            f"{sum(d.detected for d in ds)}/{n}",
            _bank_span([_stored(d.time_to_detection) for d in ds]),
            _bank_counts([d.by_magnitude for d in ds], n),
            _bank_counts([d.by_residual for d in ds], n),
            _bank_span([_stored(d.margin) for d in ds], ".2f"),
            _bank_counts([d.outcome.value for d in ds], n),
        ]
        out.append("| " + " | ".join(row) + " |")
    if study.gates:
        out += [
            "",
            "## Observability gate of the extended system (section 2.6.6)",
            "",
            "| sensors | channels | element | p | s | verdict | static-gain singular values | condition | reason |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        out += [_gate_row(g) for g in study.gates]
    return "\n".join(out) + "\n"


def bank_file_names(scenarios: Sequence[str]) -> list[str]:
    """The file names of a bank report with these scenarios: :data:`BANK_FILES`, then the force plots.

    Parameters
    ----------
    scenarios : sequence of str
        Scenario names (``"healthy"``, ``"crack3"``, ...); they become file names.

    Returns
    -------
    list of str

    Raises
    ------
    OutputError
        A scenario name that is not a plain file name.

    Examples
    --------
    >>> bank_file_names(["healthy", "crack2"])
    ['bank.json', 'bank.md', 'forces_healthy.png', 'forces_crack2.png']
    """
    from obsnl.report.figures import FIGURE_PREFIX

    bad = [s for s in scenarios if not isinstance(s, str) or not _SCENARIO.match(s)]
    if bad:
        raise OutputError(f"scenario name {bad[0]!r} cannot be part of a file name (letters, digits, '_', '-' only)")
    return [*BANK_FILES, *(f"{FIGURE_PREFIX}{s}.png" for s in scenarios)]


def check_bank_output(out: str | Path, scenarios: Sequence[str], *, force: bool) -> list[Path]:
    """Check, before any work, that a bank report may be written into the folder ``out``.

    Every file goes through :func:`obsnl.report.files.check_folder` (and so
    :func:`~obsnl.report.files.check_target`): without ``force`` an existing file or symbolic link is refused;
    a folder in a file's place, a parent that is a file, a path leaving ``out`` or a folder this process
    cannot write into is always refused. Nothing is created.

    Parameters
    ----------
    out : str or Path
        The report folder (created by :func:`write_bank_report` if missing).
    scenarios : sequence of str
        The scenario names (see :func:`bank_file_names`).
    force : bool
        Allow replacing existing files (links are replaced, never followed).

    Returns
    -------
    list of Path
        The files, in the order of :func:`bank_file_names`.

    Raises
    ------
    OutputError
        One line naming the path and the fix.
    """
    names = bank_file_names(scenarios)
    folder = check_folder(out, names, force=force)  # also refuses an out that is a file, or empty
    return [folder / name for name in names]


def write_bank_report(study: _Report, out: str | Path, *, force: bool = False) -> list[Path]:
    """Write ``bank.json``, ``bank.md`` and the force plots of a study into the folder ``out``.

    All files are checked (:func:`check_bank_output`) and go through the one output writer
    (:class:`obsnl.report.files.OutputFolder`): made in its staging folder, moved in together; without
    ``force`` an existing file is never replaced (also one another run wrote meanwhile), with ``force`` a
    link is replaced, never written through. On an error nothing is left behind.

    Parameters
    ----------
    study : LinkStudy
        A :class:`obsnl.studies.link_study.LinkStudy`; ``bank.json`` is its ``to_dict()``, ``bank.md``
        :func:`bank_table_markdown` of it.
    out : str or Path
        The report folder (created if missing).
    force : bool
        Replace existing files (and links).

    Returns
    -------
    list of Path
        The files written: ``bank.json``, ``bank.md``, then one ``forces_<scenario>.png`` per scenario.

    Raises
    ------
    OutputError
        A file exists (or is a link) without ``force``, a path is a folder or leaves ``out``, a value is
        not finite, or the folder cannot be written.
    """
    from obsnl.report.figures import plot_bank_forces

    scenarios = list(study.traces)
    targets = check_bank_output(out, scenarios, force=force)
    try:
        texts = {
            "bank.json": json.dumps(study.to_dict(), indent=2, allow_nan=False) + "\n",
            "bank.md": bank_table_markdown(study),
        }
    except ValueError as exc:
        raise OutputError(f"the bank results hold a number JSON cannot store ({exc}); nothing was written") from None
    with OutputFolder(out, bank_file_names(scenarios), force=force) as folder:  # all files or none, no link followed
        for name, text in texts.items():
            folder.write_text(name, text)
        plot_bank_forces(study, folder.staging)
        folder.commit()
    return targets


def bank_written_line(files: Sequence[Path]) -> str:
    """The line that says what :func:`write_bank_report` wrote: the two tables, then the number of force plots.

    Examples
    --------
    >>> bank_written_line([Path("b/bank.json"), Path("b/bank.md"), Path("b/forces_healthy.png")])
    'wrote b/bank.json, b/bank.md and 1 force plots'
    """
    return f"wrote {', '.join(str(f) for f in files[:2])} and {len(files) - 2} force plots"
