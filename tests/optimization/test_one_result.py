"""One result type (issue 23): every study kind's answer is a StudyResult with the same
interface, written once, and its figures agree with the kind's own data."""

from __future__ import annotations

import copy
import html

import pytest

import isodesign
from isodesign.optimization.dispatch import KINDS, study_kind
from isodesign.optimization.result import RobustStudyResult, StudyResult
from isodesign.optimization.study import study_from_dict, table_study, vertical_study

#: The common interface, owned by StudyResult (or RobustStudyResult for the robust parts):
#: no kind defines its own.
COMMON = ("kind", "success", "raise_for_status", "verdict", "worst_margin_db", "limited_by",
          "limiting_summary", "hessian_choice", "constraints_frame", "constraint_lines",
          "starts_frame", "to_frame", "plot", "__str__", "_repr_html_", "_summary_items",
          "_display_frame", "failure_message")


def _vertical(scenarios=None):
    kw = {"models": {"points_per_band": 3, "peak_points": 30},
          "solver": {"starts": 1, "workers": 1}}
    if scenarios:
        kw["scenarios"] = scenarios
    return vertical_study().with_changes(**kw)


def _table(scenarios=None):
    raw = copy.deepcopy(table_study().raw)
    raw["solver"].update(starts=1, workers=1)
    raw["models"]["points_per_band"] = 3
    raw["target"].update(band_min_hz=4.0, band_max_hz=20.0)
    if scenarios:
        raw["scenarios"] = scenarios
    return study_from_dict(raw, source="small_table.toml", fill_defaults=False)


STUDIES = {
    "vertical": lambda: _vertical(),
    "table": lambda: _table(),
    "robust": lambda: _vertical({"payload_mass_kg": {"min": 540.0, "max": 660.0}}),
    "robust table": lambda: _table({"payload_mass_kg": {"min": 560.0, "max": 640.0}}),
}
_CACHE: dict = {}


def answer(kind):
    if kind not in _CACHE:
        st = STUDIES[kind]()
        _CACHE[kind] = (st, isodesign.optimize(st))
    return _CACHE[kind]


def test_the_four_kinds_are_the_dispatchers():
    assert set(STUDIES) == set(KINDS)
    for kind, make in STUDIES.items():
        assert study_kind(make()) == kind


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_is_one_result_type_with_one_interface(kind):
    st, res = answer(kind)
    assert isinstance(res, StudyResult) and res.kind == kind
    assert res.robust == kind.startswith("robust")
    assert isinstance(res, RobustStudyResult) == res.robust
    for name in COMMON:  # the common parts are written once, in the base classes
        assert hasattr(res, name), name
        assert name not in vars(type(res)), f"{type(res).__name__} redefines {name}"
    assert res.feasible and res.success
    assert res.raise_for_status() is res
    assert repr(res).startswith(f"<{type(res).__name__}: study {st.name}")


@pytest.mark.parametrize("kind", KINDS)
def test_the_figures_agree_with_the_kinds_own_data(kind):
    st, res = answer(kind)
    w = res.worst_margin_db
    if res.robust:  # the worst over the final scenario set
        assert w == pytest.approx(min(r["margin_db"] for r in res.scenarios), abs=1e-12)
        worst = [r for r in res.scenarios if r["worst"]]
        assert worst and res.objective_value == pytest.approx(
            min(r["objective"] for r in res.scenarios), abs=st.scenarios.settings["tolerance_db"])
        assert res.starts_frame().equals(res.nominal.starts_frame())
    else:  # the fine-grid analysis's
        assert w == pytest.approx(res.analysis.worst_margin_db, abs=1e-12)
        assert len(res.starts_frame()) == len(res.starts) == 1
    assert f"{w:+.2f} dB" in res.verdict()
    assert res.verdict().startswith("PASS" if w >= 0 else "FAIL")
    # the frame: design variables, objective, the worst margin, the constraint table
    df = res.to_frame().set_index("quantity")
    assert df.loc["worst margin", "optimum"] == pytest.approx(w, abs=1e-12)
    for k, v in res.values.items():
        assert df.loc[k, "optimum"] == v
    obj = df.index[df.index.str.startswith("objective: ")]
    assert len(obj) == 1 and df.loc[obj[0], "optimum"] == res.objective_value
    h = res.hessian_choice()
    assert h["hessian"] in ("exact", "limited-memory") and h["reason"]
    assert df.attrs == {"kind": kind, "verdict": res.verdict(), "success": True,
                        "hessian": h["hessian"], "hessian_reason": h["reason"]}
    cf = res.constraints_frame()
    assert len(res.constraints) >= 3 and len(cf) == len(res.constraints)
    assert list(cf["binding"]) == [c.active for c in res.constraints]
    for c in res.constraints:
        assert df.loc[f"constraint: {c.name}", "optimum"] == c.value
        assert df.loc[f"constraint: {c.name}", "note"].startswith("BINDING") == c.active
    binding = [c.name for c in res.constraints if c.active]
    summary = res.limiting_summary()
    assert all(n in summary for n in binding)
    # the text and the HTML hold the same verdict, table and sentence
    text = str(res)
    assert res.verdict() in text and summary in text
    assert f"Hessian: {h['hessian']}" in text
    assert all(c.name in text for c in res.constraints)
    page = res._repr_html_()
    assert "<table" in page and html.escape(summary) in page
    assert html.escape(res.verdict()) in page


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_plots_a_figure_or_into_an_axes(kind):
    from isodesign.plotting.style import new_figure

    _, res = answer(kind)
    fig = res.plot()
    assert type(fig).__name__ == "Figure" and fig.axes
    fig2 = new_figure(5, 3)
    ax = fig2.add_subplot()
    assert res.plot(ax) is fig2 and (ax.lines or ax.patches)


def test_the_hessian_rule_by_model_and_size():
    from isodesign.optimization.hessian import VERTICAL_EXACT_MAX_VARIABLES, hessian_choice

    vert, table = _vertical(), _table()
    assert hessian_choice(table)["hessian"] == "limited-memory"
    assert hessian_choice(table, 10_000)["hessian"] == "limited-memory"
    assert hessian_choice(vert, 89)["hessian"] == "exact"
    assert hessian_choice(vert, VERTICAL_EXACT_MAX_VARIABLES)["hessian"] == "exact"
    assert hessian_choice(vert, 209)["hessian"] == "limited-memory"
    assert hessian_choice(vert, 209, scenarios=3)["hessian"] == "exact"
    for h in (hessian_choice(vert, 89), hessian_choice(vert, 209), hessian_choice(table)):
        assert "docs/optimization.md" in h["reason"]


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_states_the_hessian_its_nlp_used(kind):
    from isodesign.optimization.hessian import hessian_choice

    st, res = answer(kind)
    h = res.hessian_choice()
    if kind == "vertical":  # the small grid: the exact Hessian, by the NLP's size
        from isodesign.optimization.problem import Problem

        prob = Problem(st)
        assert prob.ipopt_options()["ipopt.hessian_approximation"] == h["hessian"] == "exact"
        assert h == hessian_choice(st, prob.nx)
    elif kind == "robust":  # the scenario stack keeps the exact Hessian
        assert h == res.problem.hessian_info and h["hessian"] == "exact"
        assert res.nominal.hessian_choice()["hessian"] == "exact"
    else:  # a table NLP, nominal or stacked
        assert h == hessian_choice(st) and h["hessian"] == "limited-memory"
        nominal = res if kind == "table" else res.nominal
        assert nominal.hessian == "limited-memory"


def test_the_robust_table_figure_names_how_its_sensitivities_were_found():
    from isodesign.plotting.robust import robustness_figure

    _, res = answer("robust table")
    sens = res.sensitivities()
    assert [s.parameter for s in sens] == ["payload_mass_kg"]
    fig = robustness_figure(res, sens=sens)
    assert "central differences" in fig.axes[1].get_title()


def test_design_json_states_the_hessian_and_why():
    from isodesign.io.record import optimization_design

    _, res = answer("vertical")
    d = optimization_design(res)
    assert (d["hessian"], d["hessian_reason"]) == (res.hessian_choice()["hessian"],
                                                   res.hessian_choice()["reason"])


@pytest.mark.parametrize("cls", [StudyResult, RobustStudyResult])
def test_the_common_interface_is_not_a_result(cls):
    """StudyResult() built an object whose str, verdict and to_frame raised AttributeError:
    the interface refuses to be built, naming where a result comes from."""
    with pytest.raises(isodesign.InputError, match=rf"{cls.__name__}: .*isodesign\.optimize"):
        cls()
