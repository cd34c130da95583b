"""The analysis side's jobs as the command line runs them: from a model file to the text it prints.

Each job takes a command's options as keywords (``fmt`` the rendering's format, ``output`` a file that
takes the rendering instead of standard output, checked before any work), calls the library
(:mod:`obsnl.design.records` for the work under one time budget), renders the result with
:mod:`obsnl.report` and returns a :class:`~obsnl.report.printed.Printed`: the text and the one line that
names an undecided answer (an inconclusive branch, an undecided sensor set, an inconclusive design).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from obsnl.report.printed import Printed, printed

__all__ = [
    "show_printed",
    "branches_printed",
    "symmetries_printed",
    "analyze_printed",
    "sensors_printed",
    "design_printed",
]


def _read(model: Any, limits: bool = True) -> Any:
    """``model``, or the model file at that path (its size checked first with ``limits``)."""
    from obsnl.model.files import as_model
    from obsnl.observability.limits import check_file_limits

    return as_model(model, check=check_file_limits if limits else None)


def show_printed(model: Any, *, fmt: str = "text") -> Printed:
    """A model's equations and roles (:func:`obsnl.report.structure.render_model`).

    Parameters
    ----------
    model : Model, str or Path
        The model, its file or ``obsnl:NAME``.
    fmt : {"text", "json"}
        The format.

    Returns
    -------
    Printed

    Examples
    --------
    >>> show_printed("obsnl:coulomb_friction").text.splitlines()[:3]
    ['model coulomb_friction', '  d/dt x = v', '  d/dt v = (-F_c*sign(v) - c*v - k*x + u)/m']
    """
    from obsnl.report.structure import render_model

    return Printed(render_model(_read(model, False), fmt))


def branches_printed(model: Any, *, fmt: str = "text", equations: bool = False) -> Printed:
    """A model's smooth branches, each with its guard (and its equations), a branch of undecided
    feasibility with its reason (:func:`obsnl.model.branching.branches.split_branches`).

    Parameters
    ----------
    model : Model, str or Path
        The model, its file or ``obsnl:NAME``.
    fmt : {"text", "json"}
        The format.
    equations : bool
        Also each branch's smooth equations (text only).

    Returns
    -------
    Printed

    Examples
    --------
    >>> print(branches_printed("obsnl:coulomb_friction").text.splitlines()[0])
    coulomb_friction: 2 branches
    """
    from obsnl.model.branching.branches import split_branches
    from obsnl.report.structure import render_branches

    m = _read(model, False)
    return Printed(render_branches(m, split_branches(m, undecided=True), fmt, equations=equations))


def symmetries_printed(model: Any, *, fmt: str = "text", degree: int = 1, seed: int = 0) -> Printed:
    """The generators of the unobservable directions of each branch
    (:func:`obsnl.observability.certificates.symmetry.branch_symmetries`).

    Parameters
    ----------
    model : Model, str or Path
        The model or its file (its size checked first).
    fmt : {"text", "json"}
        The format.
    degree, seed : int
        As for :func:`~obsnl.observability.certificates.symmetry.branch_symmetries`.

    Returns
    -------
    Printed
    """
    from obsnl.observability.certificates.symmetry import branch_symmetries
    from obsnl.report.structure import render_symmetries

    return Printed(render_symmetries(branch_symmetries(_read(model), seed=seed, degree=degree), fmt))


def analyze_printed(
    model: Any,
    *,
    fmt: str = "text",
    output: str | Path | None = None,
    force: bool = False,
    branches: Sequence[str] | None = None,
    **options: Any,
) -> Printed:
    """The analysis of a model file (:func:`obsnl.design.records.analyze_file`), rendered
    (:func:`obsnl.report.tables.render`), with the line that names its first inconclusive branch.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    fmt : {"text", "json", "md", "tex", "json-table"}
        The format.
    output : str, Path or None
        A file for the rendering (None or ``"-"``: the text is returned), checked before any work.
    force : bool
        Overwrite ``output``.
    branches : sequence of str or None
        Only these branches (None or empty: every branch).
    **options : Any
        Passed to :func:`~obsnl.design.records.analyze_file` (record, method, seed, max_seconds, joint,
        unknown_input_derivatives).

    Returns
    -------
    Printed
    """
    from obsnl.design.records import analyze_file
    from obsnl.report.structure import inconclusive_line
    from obsnl.report.tables import render

    result = analyze_file(model, output=output, force=force, branches=branches or None, **options)
    return printed(render(result, fmt), output, force=force, undecided=inconclusive_line([result]))


def sensors_printed(
    model: Any, *, fmt: str = "text", output: str | Path | None = None, force: bool = False, **options: Any
) -> Printed:
    """The minimal sensor sets of a model file (:func:`obsnl.design.records.sensors_file`), rendered
    (:func:`obsnl.report.sensors.render_sensors`), with the line that names the sets left undecided.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    fmt : {"text", "json", "md", "tex"}
        The format.
    output : str, Path or None
        A file that takes the rendering instead of standard output (checked before any work).
    force : bool
        Overwrite ``output``.
    **options : Any
        Passed to :func:`~obsnl.design.records.sensors_file`.

    Returns
    -------
    Printed
    """
    from obsnl.design.records import sensors_file
    from obsnl.report.sensors import render_sensors, undecided_line

    result = sensors_file(model, output=output, force=force, **options)
    return printed(render_sensors(result, fmt), output, force=force, undecided=undecided_line(result))


def design_printed(
    model: Any,
    record: Sequence[str | Path] = (),
    *,
    fmt: str = "text",
    output: str | Path | None = None,
    force: bool = False,
    **options: Any,
) -> Printed:
    """The experiment design of a model file under records (:func:`obsnl.design.records.design_file`),
    rendered (:func:`obsnl.report.experiment.render_design`), with the line that says it is inconclusive.

    Parameters
    ----------
    model : Model, str or Path
        The model or its file.
    record : sequence of str or Path
        The record files (the option ``record=`` given once per record, as ``--record`` is).
    fmt : {"text", "json", "md", "tex"}
        The format.
    output : str, Path or None
        A file that takes the rendering instead of standard output (checked before any work).
    force : bool
        Overwrite ``output`` and the figure.
    **options : Any
        Passed to :func:`~obsnl.design.records.design_file` (figure, max_seconds, target, sensors,
        scales, seed).

    Returns
    -------
    Printed
    """
    from obsnl.design.records import design_file
    from obsnl.report.experiment import render_design, undecided_line

    result = design_file(model, record, output=output, force=force, **options)
    return printed(render_design(result, fmt), output, force=force, undecided=undecided_line(result))
