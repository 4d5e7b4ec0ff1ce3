"""What a report (or ``response``/``transmissibility``) is about: a design and its job.

An input is one of

* a design file (TOML with ``volume_ratio`` ...): the spring; its ``[models]`` table (the
  models it was made with) and ``[load]`` table are used; the job (payload, floor,
  criterion, judged bands) is the built-in vertical study's unless a study is given;
* a study file (TOML with ``[payload]``, ``[floor]``, ``[target]`` ...): the job, and the
  study's start design;
* an ``isodesign optimize`` run directory (``record.json`` of kind ``isodesign optimize``,
  ``design.toml``, ``study_resolved.toml``): the optimum and the resolved study, plus the
  run record (constraints, start design, flat direction, provenance);
* an ``isodesign pareto`` run directory (``record.json`` of kind ``isodesign pareto``): the
  front, and its best point in objective A as the design.

:func:`load_case` turns each into a :class:`Case`.
"""

from __future__ import annotations

import inspect
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from isodesign.errors import InputError
from isodesign.io.designfile import design_from_dict, load_design_models
from isodesign.io.files import read_toml
from isodesign.optimization.objectives import OBJECTIVES
from isodesign.optimization.study import Study, load_study, study_from_dict, vertical_study
from isodesign.response.random_input import band_response

__all__ = ["MODEL_DEFAULTS", "Case", "best_pareto_point", "input_kind", "load_case"]

#: Models of the response when neither a study, a run nor a design file states them:
#: the defaults of :func:`isodesign.response.band_response`, read from its signature.
MODEL_DEFAULTS = {
    k: inspect.signature(band_response).parameters[k].default
    for k in ("flow", "amplitude_mode", "diaphragm", "random_method")
}
_MODEL_NAMES = tuple(MODEL_DEFAULTS)


@dataclass(frozen=True, eq=False)
class Case:
    """A design with its job: payload, floor, criterion, judged bands and models.

    Attributes
    ----------
    kind : {'design', 'study', 'optimize', 'pareto', 'reference'}
    label : str
        Short name for tables and legends.
    source : str
        The input path.
    design : SpringDesign
        With p0 derived from the payload.
    study : Study
        The job (payload, floor, target, judged bands, constraints); for a design file
        the built-in vertical study (or the one given).
    models : dict
        ``flow``, ``amplitude_mode``, ``diaphragm``, ``random_method`` in force.
    models_source : str
        Where the models come from.
    job_source : str
        Where the job comes from.
    record : dict or None
        ``record.json`` of a run.
    design_json : dict or None
        ``design.json`` of an optimize run.
    pareto : dict or None
        ``pareto.json`` of a Pareto run.
    """

    kind: str
    label: str
    source: str
    design: Any
    study: Study
    models: dict
    models_source: str
    job_source: str
    record: dict | None = None
    design_json: dict | None = None
    pareto: dict | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    #: ``robust.json`` of a robust optimize run (a study with ``[scenarios]``).
    robust: dict | None = None

    @property
    def payload(self):
        """The study's payload."""
        return self.study.payload

    @property
    def judged_hz(self) -> tuple[float, float]:
        """Nominal range of the judged bands, Hz."""
        tg = self.study.raw["target"]
        return float(tg["band_min_hz"]), float(tg["band_max_hz"])


def _read_json(path: Path) -> dict:
    try:
        rec = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:
        raise InputError(f"{path}: cannot read the run record ({exc})") from None
    if not isinstance(rec, dict):
        raise InputError(f"{path}: not a run record (a JSON object expected, got "
                         f"{type(rec).__name__})")
    return rec


def input_kind(path) -> str:
    """``design``, ``study``, ``optimize`` or ``pareto`` for an input path (InputError else).

    Parameters
    ----------
    path : str or Path
    """
    p = Path(path)
    if p.is_dir():
        rec = p / "record.json"
        if not rec.is_file():
            raise InputError(f"{p}: not a run directory of isodesign optimize or pareto "
                             "(no record.json)")
        kind = _read_json(rec).get("kind", "")
        if kind == "isodesign optimize":
            return "optimize"
        if kind == "isodesign pareto":
            return "pareto"
        raise InputError(f"{rec}: a run of {kind or 'an unknown kind'!s:.40}, not of isodesign "
                         "optimize or pareto (the runs that hold a design and its study)")
    if not p.exists():
        raise InputError(f"{p}: no such file or directory")
    d = read_toml(p, what="design or study")
    if "volume_ratio" in d or "top_volume_m3" in d:
        return "design"
    if any(k in d for k in ("payload", "floor", "target", "variables", "objective", "models",
                            "hardware", "constraints", "solver", "name", "table")):
        return "study"
    raise InputError(f"{p}: neither a design file (volume_ratio, ...) nor a study file "
                     "([payload], [floor], [target], ...)")


def _study_models(study: Study) -> dict:
    out = {k: str(study.models.get(k, MODEL_DEFAULTS[k])) for k in _MODEL_NAMES}
    if study.models.get("distortion"):  # models.distortion: the closure with its distortion
        out["distortion"] = True
    return out


def _design_case(p: Path, study: Study | None, label: str | None) -> Case:
    d = read_toml(p, what="design")
    job = study or vertical_study()
    job_source = (f"study {study.source}" if study is not None and study.source
                  else "the built-in vertical study (no study given)")
    load = d.get("load") if isinstance(d, dict) else None
    if isinstance(load, dict) and study is None:
        job = job.with_changes(payload={k: load[k] for k in ("mass_kg", "isolators")
                                        if k in load})
        job_source += "; payload from the design file's [load]"
    design = design_from_dict(d, source=f"design file {p}")
    design = design.with_load(job.payload.mass_kg, job.payload.isolators,
                              g_m_s2=job.payload.g_m_s2)
    recorded = load_design_models(p)
    models = _study_models(job) if study is not None else dict(MODEL_DEFAULTS)
    models.update(recorded)
    msrc = ("the design file's [models]" if recorded else
            ("the study" if study is not None else "the response defaults"))
    return Case("design", label or p.stem, str(p), design, job, models, msrc, job_source)


def _study_case(p: Path, label: str | None) -> Case:
    st = load_study(p)
    return Case("study", label or st.name, str(p), st.start_design(), st, _study_models(st),
                f"study {p}", f"study {p}",
                notes=("the design is the study's start design (variables' start values)",))


def _robust_case(p: Path, rec: dict, label: str | None) -> Case:
    """A robust optimize run: its robust design, with robust.json."""
    rob = _read_json(p / "robust.json")
    st = load_study(p / "study_resolved.toml") if (p / "study_resolved.toml").is_file() \
        else _study_from_record(rec, p)
    if not rob.get("feasible"):
        raise InputError(f"{p}: the robust optimize run found no robust design; nothing to "
                         "report (see its robust.json)")
    models = _study_models(st)
    return Case("optimize", label or f"{st.name} robust optimum", str(p),
                st.design_at(rob["values"]), st, models, "the run's resolved study",
                f"the run's resolved study ({p / 'study_resolved.toml'})", robust=rob)


def _optimize_case(p: Path, label: str | None) -> Case:
    rec = _read_json(p / "record.json")
    status = rec.get("run_status")
    if status in ("interrupted", "failed", "running"):  # not "found no feasible design"
        what = "did not finish" if status == "running" else f"was {status}"
        raise InputError(f"{p}: the optimize run {what} (run_status {status}); nothing to "
                         "report: rerun it (see its record.json)")
    if rec.get("robust") and (p / "robust.json").is_file():
        return _robust_case(p, rec, label)
    st = load_study(p / "study_resolved.toml") if (p / "study_resolved.toml").is_file() \
        else _study_from_record(rec, p)
    if not rec.get("feasible", False) or not (p / "design.toml").is_file():
        raise InputError(f"{p}: the optimize run found no feasible design; nothing to report "
                         "(see its record.json)")
    values = rec["design"]
    st = st.with_levers_fixed(values)  # a co-designed table: the optimum's levers
    design = st.design_at(values)
    dj = _read_json(p / "design.json") if (p / "design.json").is_file() else None
    models = _study_models(st)
    recorded = load_design_models(p / "design.toml")
    models.update(recorded)
    return Case("optimize", label or f"{st.name} optimum", str(p), design, st, models,
                "the run's resolved study" + (" and design.toml [models]" if recorded else ""),
                f"the run's resolved study ({p / 'study_resolved.toml'})", record=rec,
                design_json=dj)


def _study_from_record(rec: dict, p: Path) -> Study:

    if "study" not in rec:
        raise InputError(f"{p}: record.json holds no study and study_resolved.toml is missing")
    return study_from_dict(rec["study"], source=str(p / "record.json"), fill_defaults=False)


def best_pareto_point(rec: dict) -> int:
    """Index of the non-dominated point best in objective A (the front's anchor).

    Parameters
    ----------
    rec : dict
        ``record.json`` of a Pareto run.
    """
    a = rec["objectives"][0]
    best, arg = None, None
    for i, pt in enumerate(rec["points"]):
        v = pt.get(a)
        if v is None or not pt.get("nondominated") or not math.isfinite(v):
            continue
        key = v if OBJECTIVES[a].maximized else -v
        if best is None or key > best:
            best, arg = key, i
    if arg is None:
        raise InputError("the Pareto run has no solved point")
    return arg


def _pareto_case(p: Path, label: str | None) -> Case:
    rec = _read_json(p / "record.json")
    st = load_study(p / "study_resolved.toml") if (p / "study_resolved.toml").is_file() \
        else _study_from_record(rec, p)
    i = best_pareto_point(rec)
    design = st.design_at(rec["points"][i]["design"])
    pj = _read_json(p / "pareto.json") if (p / "pareto.json").is_file() else {}
    pj = {**pj, "chosen_point": i}
    return Case("pareto", label or f"{st.name} front, best {rec['objectives'][0]}", str(p),
                design, st, _study_models(st), "the run's resolved study",
                f"the run's resolved study ({p / 'study_resolved.toml'})", record=rec, pareto=pj,
                notes=(f"the design analysed is front point {i}, the best in "
                       f"{rec['objectives'][0]}",))


def refuse_robust_job(case: Case) -> None:
    """A design or study file whose study has ``[scenarios]`` asks for the robust verdict,
    which its report (one nominal response) does not give: refused naming the key, never
    answered nominal (a robust run's report has its robustness section).

    Parameters
    ----------
    case : Case
        A loaded report input.

    Raises
    ------
    InputError
        Naming ``--study`` (a design file's job) or the study file, and ``[scenarios]``.
    """
    if case.kind not in ("design", "study") or case.study.scenarios is None:
        return
    where = "--study" if case.kind == "design" else case.source
    raise InputError(f"{where}: [scenarios]: the report of a design or study file is its "
                     "nominal response, not the robust answer the study asks; use isodesign "
                     "optimize STUDY -o RUN then isodesign report RUN (robustness "
                     "section), or isodesign yield, or remove [scenarios]")


def load_case(path, *, study=None, label: str | None = None) -> Case:
    """The :class:`Case` of one input (design file, study file, optimize or pareto run).

    Parameters
    ----------
    path : str or Path
    study : str, Path or Study, optional
        The job of a design file (default: the built-in vertical study).
    label : str, optional
        Name in tables and legends (default from the input).

    Raises
    ------
    InputError
        An unreadable or unrecognized input (the message names it).
    """
    p = Path(path)
    kind = input_kind(p)
    if study is not None and kind != "design":  # not silently another job than the run's
        art = "an" if kind[0] in "aeiou" else "a"
        raise InputError(f"--study: the job of a design file only; {p} is {art} {kind} input "
                         "with its own study (drop --study, or report a design file with it)")
    if kind == "design":
        st = study if isinstance(study, Study) or study is None else load_study(study)
        return _design_case(p, st, label)
    if kind == "study":
        return _study_case(p, label)
    if kind == "optimize":
        return _optimize_case(p, label)
    return _pareto_case(p, label)
