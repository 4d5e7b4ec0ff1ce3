"""The HTML report: one self-contained, printable document per design or comparison.

:func:`report` loads the inputs (:func:`isodesign.reporting.inputs.load_case`), analyses
each (:func:`isodesign.reporting.analysis.analyse`), builds the sections and figures
(:func:`isodesign.reporting.sections.build_context`) and renders the Jinja2 template
``templates/report.html.j2``: styles inline, no script, no external resource, so the file
opens anywhere without network access and prints with its own print style sheet.
"""

from __future__ import annotations

import html
import time
from pathlib import Path

from isodesign.errors import InputError
from isodesign.reporting.analysis import analyse
from isodesign.reporting.inputs import Case, load_case, refuse_robust_job
from isodesign.reporting.sections import build_context

__all__ = ["render_html", "report", "timed_report"]

_TEMPLATE = "report.html.j2"


def render_html(context: dict, template: str = _TEMPLATE) -> str:
    """Render the report template with ``context`` (:func:`build_context`).

    Parameters
    ----------
    context : dict
    template : str
        The template's file name (``report.html.j2``; ``sweep.html.j2`` for a sweep).

    Returns
    -------
    str
    """
    import jinja2

    env = jinja2.Environment(
        loader=jinja2.PackageLoader("isodesign.reporting", "templates"),
        autoescape=jinja2.select_autoescape(["html", "j2"]),
        undefined=jinja2.StrictUndefined, trim_blocks=True, lstrip_blocks=True,
    )
    return env.get_template(template).render(**context, escape=html.escape)


def report(inputs, output=None, *, study=None, labels=None, command=None, title=None):
    """A self-contained HTML report of one design, or a comparison of several.

    Parameters
    ----------
    inputs : str, Path or sequence of them
        Design files, study files, ``isodesign optimize`` or ``isodesign pareto`` run
        directories. Several inputs give a comparison report: the candidates side by
        side in one band plot, one transmissibility plot and one table. A sweep
        directory (``isodesign sweep``), alone, gives the sweep's report: its design
        charts and the table of its points.
    output : str or Path, optional
        Where to write the HTML; default: return the text only.
    study : str or Path, optional
        The job (payload, floor, criterion, bands) of design-file inputs (default: the
        built-in vertical study).
    labels : sequence of str, optional
        Names of the candidates (default from the inputs).
    command : sequence of str, optional
        The command line recorded in the provenance.
    title : str, optional

    Returns
    -------
    str or Path
        The HTML text, or the written path when ``output`` is given.

    Examples
    --------
    >>> import isodesign
    >>> isodesign.report("out/optimize", "report.html")        # doctest: +SKIP
    >>> isodesign.report(["a.toml", "b.toml", "out/optimize"], "compare.html")  # doctest: +SKIP
    """
    if isinstance(inputs, str | Path):
        inputs = [inputs]
    if not isinstance(inputs, list | tuple) or not all(isinstance(p, str | Path)
                                                     for p in inputs):
        raise InputError("inputs: expected a design file, study file or run directory (a path) "
                         f"or a list of them, got {type(inputs).__name__} {inputs!r:.40}")
    inputs = list(inputs)
    if not inputs:

        raise InputError("inputs: give at least one design file, study file or run directory")
    from isodesign.reporting.sweep import is_sweep_dir

    if any(is_sweep_dir(p) for p in inputs):  # a sweep directory: charts and the table
        if len(inputs) != 1:
            raise InputError("inputs: a sweep directory is reported on its own (one input)")
        return _sweep_report(inputs[0], output, command=command, title=title)
    labels = list(labels) if labels is not None else [None] * len(inputs)
    cases = [load_case(p, study=study, label=lab) for p, lab in zip(inputs, labels, strict=True)]
    for c in cases:  # a robust question is not answered by a nominal response
        refuse_robust_job(c)
    seen: dict[str, int] = {}
    fixed = []
    for c in cases:  # candidates must be told apart in legends
        n = seen.get(c.label, 0)
        seen[c.label] = n + 1
        fixed.append(c if n == 0 else Case(**{**c.__dict__, "label": f"{c.label} ({n + 1})"}))
    analyses = [analyse(c) for c in fixed]
    if command is None:  # called from Python: record the call
        command = [f"isodesign.report({[str(p) for p in inputs]!r}"
                   + (f", {str(output)!r}" if output is not None else "")
                   + (f", study={str(study)!r}" if study is not None else "") + ")"]
    text = render_html(build_context(analyses, command=command, title=title))
    if output is None:
        return text
    out = Path(output)
    out.write_text(text, encoding="utf-8")
    return out


def _sweep_report(directory, output, *, command=None, title=None):
    from isodesign.reporting.sweep import sweep_context

    if command is None:
        command = [f"isodesign.report({str(directory)!r}"
                   + (f", {str(output)!r}" if output is not None else "") + ")"]
    text = render_html(sweep_context(directory, command=command, title=title),
                       "sweep.html.j2")
    if output is None:
        return text
    out = Path(output)
    out.write_text(text, encoding="utf-8")
    return out


def timed_report(inputs, output, **kw) -> tuple[Path, float]:
    """:func:`report` and its wall time, s (for the command's summary and benchmarks).

    Parameters
    ----------
    inputs, output
        As :func:`report`.
    **kw
        Passed to :func:`report`.

    Returns
    -------
    (Path, float)
    """
    t0 = time.perf_counter()
    p = report(inputs, output, **kw)
    return p, time.perf_counter() - t0
