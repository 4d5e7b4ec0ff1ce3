"""Issue 23's speed rows, measured interleaved in one run against d765a8c (the commit before
issue 23's work): the vertical study's optimize (target <= 1.1 x d765a8c's), the built-in
table study's optimize with the continuous peak refinement (target <= 1.5 x d765a8c's table
optimize), and the robust built-in table study (payload +-20 %, D_c +-5 %, CG offsets
+-50 mm; target <= 10 x the nominal table optimize of today's tree).

The old commit runs from a git worktree (``BENCH23_OLD_TREE``, default
``/tmp/bench23-old``, created with ``git worktree add --detach`` when missing), each arm in
a fresh process of the same Python (``PYTHONPATH`` pointing at its tree), the arms
interleaved round by round so that both trees see the same machine load; the rows quote
medians of the rounds and the load average before and after. The timed span is the
optimize call only (the package's import and the study's loading excluded; modules the
call imports lazily, e.g. python-control for the table's leveling-loop check, included).
The optimum of each pair is compared (margin and design variables); where the physics
changed since d765a8c (the tube end corrections, ``hardware.tube_end_correction``), the
new tree also runs with it switched off, to compare like with like. 5 rounds
(``BENCH23_ROUNDS``), about 10 min on an idle 2-core machine and 25 min at load 15: run it
alone with ``python benchmarks/run.py unify -o /tmp/b.md`` or
``python benchmarks/bench_unify.py``.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
#: The commit before issue 23's work started (``BENCH23_OLD_COMMIT`` measures against another,
#: e.g. the commit before one step of the issue, in a tree of its own: ``BENCH23_OLD_TREE``).
OLD_COMMIT = os.environ.get("BENCH23_OLD_COMMIT", "d765a8c")
#: The old tree's vertical call: d765a8c's default study was the vertical one; a later
#: tree names it ``vertical_study()`` (the child picks by the tree).
OLD_VERTICAL_CALL = ("driver.optimize(default_study())" if OLD_COMMIT == "d765a8c"
                     else "isodesign.optimize(vertical_study())")
#: Target: vertical optimize, new / old.
TARGET_VERTICAL = 1.1
#: Target: the built-in table optimize (with the continuous peak refinement), new / old.
TARGET_TABLE = 1.5
#: Target: the robust built-in table, robust / nominal (today's tree).
TARGET_ROBUST = 10.0
#: Rounds of the interleaved arms (each round runs every timed arm once).
ROUNDS = int(os.environ.get("BENCH23_ROUNDS", "5"))
#: The robust built-in table study's scenarios (docs/robust.md section 1).
SCENARIOS = {
    "payload_mass_kg": {"relative": 0.2},
    "capillary_diameter_m": {"relative": 0.05},
    "cg_offset_x_m": {"absolute": 0.05},
    "cg_offset_y_m": {"absolute": 0.05},
}
#: Relative agreement of two optima's design variables, and of their margins (dB).
VALUES_RTOL = 1e-3
MARGIN_TOL_DB = 1e-3

# The child process: builds the arm's study, times the optimize call, prints one JSON line.
_CHILD = r'''
import json, sys, time, warnings
warnings.simplefilter("ignore")
arm = sys.argv[1]
end = None if len(sys.argv) < 3 else sys.argv[2] == "on"
if arm.endswith("-old"):
    import isodesign.optimization.study as S
    vertical = getattr(S, "vertical_study", None)  # a tree after d765a8c names it
    if arm.startswith("vertical") and vertical is None:
        from isodesign.optimization.driver import optimize as run
        study = S.default_study()
    elif arm.startswith("vertical"):
        from isodesign import optimize as run
        study = vertical()
    else:
        try:  # the table's driver moved from table/ to optimization/ (issue 23)
            from isodesign.optimization.table_driver import optimize_table as run
        except ImportError:
            from isodesign.table.optimize import optimize_table as run
        study = S.table_study()
else:
    from isodesign import optimize as run
    from isodesign.optimization.study import table_study, vertical_study
    study = vertical_study() if arm.startswith("vertical") else table_study()
    # the old commit's question: it predates models.distortion (its physics is the key off)
    study = study.with_changes({"models.distortion": False})
    if end is False:
        study = study.with_changes({"hardware.tube_end_correction": False})
    if arm.startswith("robust"):
        study = study.with_changes(scenarios=json.loads(sys.argv[3]))
if "preimport" in sys.argv[2:]:
    import control  # noqa: F401  (python-control, imported lazily by the leveling check)
t0 = time.perf_counter()
r = run(study)
wall = time.perf_counter() - t0
out = {"arm": arm, "wall_s": wall, "feasible": bool(r.feasible), "status": str(r.status),
       "values": {k: float(v) for k, v in dict(r.values).items()}}
peak = getattr(r, "peak", None) or {}
if arm.startswith("robust"):
    ov = getattr(r, "objective_value", None)
    out["objective_value"] = None if ov is None else float(ov)
    out["rounds"] = len(getattr(r, "rounds", ()) or ())
    out["scenarios"] = len(getattr(r, "scenarios", ()) or ())
    nom = getattr(r, "nominal", None)
    out["nominal_wall_s"] = getattr(nom, "wall_s", None)
    out["nlp_builds"] = (getattr(r, "extra", None) or {}).get("nlp_builds")
    out["round_iterations"] = [rd.get("iterations") for rd in getattr(r, "rounds", ()) or ()]
else:
    out["objective_value"] = float(r.objective_value)
    out["starts"] = len(r.starts)
    out["peak_rounds"] = peak.get("rounds") if isinstance(peak, dict) else None
    pk = peak.get("peaks") if isinstance(peak, dict) else None
    out["peak_db"] = None if pk is None else float(pk.max_db)
    out["constraints"] = len(getattr(r, "constraints", ()) or ())
print("BENCH23 " + json.dumps(out))
'''


def _load() -> str:
    try:
        return "/".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "unknown"


def old_tree() -> Path:
    """The git worktree of :data:`OLD_COMMIT`, created (detached) when missing.

    Returns
    -------
    Path
    """
    path = Path(os.environ.get("BENCH23_OLD_TREE",
                               Path(tempfile.gettempdir()) / "bench23-old"))
    if not (path / "isodesign" / "__init__.py").exists():
        subprocess.run(["git", "worktree", "add", "--detach", str(path), OLD_COMMIT],
                       cwd=ROOT, check=True, capture_output=True, text=True)
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=path, check=True,
                          capture_output=True, text=True).stdout.strip()
    if not OLD_COMMIT.startswith(head[:7]) and not head.startswith(OLD_COMMIT):
        raise RuntimeError(f"{path} is at {head}, not {OLD_COMMIT}")
    return path


def run_arm(arm: str, tree: Path, *extra: str) -> dict:
    """One arm in a fresh process: the optimize call's wall time and its optimum.

    Parameters
    ----------
    arm : str
        ``vertical-old``, ``vertical-new``, ``table-old``, ``table-new`` or ``robust-new``.
    tree : Path
        The source tree put on ``PYTHONPATH``.
    *extra : str
        ``on``/``off`` (the tube end corrections, new tree), then the scenarios as JSON.

    Returns
    -------
    dict
        The child's JSON record plus ``process_s`` (the whole process) and ``load``.
    """
    env = {**os.environ, "PYTHONPATH": str(tree)}
    load = _load()
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", _CHILD, arm, *extra], cwd=tempfile.gettempdir(),
                       env=env, capture_output=True, text=True, timeout=3600)
    process_s = time.perf_counter() - t0
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("BENCH23 ")]
    if p.returncode or not lines:
        raise RuntimeError(f"arm {arm} failed ({p.returncode}): {p.stderr[-2000:]}")
    rec = json.loads(lines[-1].removeprefix("BENCH23 "))
    rec.update(process_s=process_s, load=load)
    return rec


def compare(a: dict, b: dict) -> tuple[bool, str]:
    """Whether two optima agree (margin within :data:`MARGIN_TOL_DB`, every design variable
    within :data:`VALUES_RTOL`), and a line saying how far apart they are.

    Parameters
    ----------
    a, b : dict
        Records of :func:`run_arm`.

    Returns
    -------
    (bool, str)
    """
    dm = abs(a["objective_value"] - b["objective_value"])
    keys = sorted(set(a["values"]) | set(b["values"]))
    rel = {}
    for k in keys:
        va, vb = a["values"].get(k), b["values"].get(k)
        rel[k] = float("inf") if va is None or vb is None else abs(va - vb) / max(abs(va), 1e-300)
    worst = max(rel, key=rel.get) if rel else ""
    same = dm <= MARGIN_TOL_DB and all(v <= VALUES_RTOL for v in rel.values())
    text = (f"margins {a['objective_value']:+.4f} / {b['objective_value']:+.4f} dB "
            f"(diff {dm:.2g} dB), design variables within {max(rel.values(), default=0):.2g} "
            f"relative (largest: {worst})")
    return same, text


def _num(v) -> str:
    return "n/a" if v is None else f"{v:.4g}"


def _values(rec: dict) -> str:
    return ", ".join(f"{k} {v:.5g}" for k, v in sorted(rec["values"].items()))


def measure(rounds: int = ROUNDS) -> dict:
    """Run the arms interleaved, ``rounds`` times (the order reversed every other round).

    Returns
    -------
    dict
        Arm name to the list of its records; ``load_before``/``load_after``.
    """
    old = old_tree()
    new = ROOT
    scen = json.dumps(SCENARIOS)
    plan = [("vertical-old", "vertical-old", old, ()), ("vertical-new", "vertical-new", new, ()),
            ("vertical-new-noend", "vertical-new", new, ("off",)),
            ("table-old", "table-old", old, ()), ("table-new", "table-new", new, ()),
            ("table-new-noend", "table-new", new, ("off",)),
            ("table-new-preimport", "table-new", new, ("on", "{}", "preimport")),
            ("robust-new", "robust-new", new, ("on", scen))]
    recs: dict[str, list] = {"load_before": _load()}
    for i in range(rounds):
        order = plan if i % 2 == 0 else plan[::-1]  # alternate the order within a round
        for name, arm, tree, extra in order:
            recs.setdefault(name, []).append(run_arm(arm, tree, *extra))
            print(f"  {name}: {recs[name][-1]['wall_s']:.3g} s (load {recs[name][-1]['load']})",
                  flush=True)
    recs["load_after"] = _load()
    return recs


def _stats(recs: list[dict]) -> dict:
    t = [r["wall_s"] for r in recs]
    return {"median": statistics.median(t), "min": min(t), "max": max(t), "repeats": len(t)}


def rows_from(recs: dict) -> list[dict]:
    """The report's rows from :func:`measure`'s records.

    Returns
    -------
    list of dict
    """
    load = (f"load average (1/5/15 min) {recs['load_before']} before, "
            f"{recs['load_after']} after")
    out = []
    arms = {}
    for arm in ("vertical-old", "vertical-new", "table-old", "table-new", "robust-new",
                "vertical-new-noend", "table-new-noend", "table-new-preimport"):
        arms[arm] = _stats(recs[arm])
    n = arms["vertical-old"]["repeats"]

    # vertical
    vo, vn, vx = recs["vertical-old"][0], recs["vertical-new"][0], recs["vertical-new-noend"][0]
    same_def, cmp_def = compare(vo, vn)
    same_like, cmp_like = compare(vo, vx)
    ratio = arms["vertical-new"]["median"] / arms["vertical-old"]["median"]
    out.append({
        "name": f"vertical study optimize: {OLD_COMMIT} ({OLD_VERTICAL_CALL})",
        "target": "", "unit": "s", **arms["vertical-old"],
        "notes": f"8 starts, the optimize call in a fresh process, {n} interleaved rounds; "
                 f"process {statistics.median(r['process_s'] for r in recs['vertical-old']):.3g}"
                 f" s; optimum {_values(vo)}"})
    out.append({
        "name": "vertical study optimize: today (isodesign.optimize(vertical_study()))",
        "target": "", "unit": "s", **arms["vertical-new"],
        "notes": f"process "
                 f"{statistics.median(r['process_s'] for r in recs['vertical-new']):.3g} s; "
                 f"optimum {_values(vn)}; with hardware.tube_end_correction = false "
                 f"(median, same rounds): {arms['vertical-new-noend']['median']:.3g} s"})
    out.append({
        "name": f"vertical optimize, today / {OLD_COMMIT}",
        "target": f"<= {TARGET_VERTICAL:g}", "unit": "ratio", "median": ratio,
        "ratio": ratio / TARGET_VERTICAL, "passed": ratio <= TARGET_VERTICAL,
        "notes": f"medians of the two rows above ({n} rounds each, interleaved); {load}. "
                 f"Same optimum: default physics {'yes' if same_def else 'no'} ({cmp_def}); "
                 f"today with the tube end corrections off (d3fcd31 added them, on by "
                 f"default) against {OLD_COMMIT}: {'yes' if same_like else 'no'} "
                 f"({cmp_like}); like-for-like time ratio "
                 f"{arms['vertical-new-noend']['median'] / arms['vertical-old']['median']:.2f}"})

    # table
    to, tn, tx = recs["table-old"][0], recs["table-new"][0], recs["table-new-noend"][0]
    same_def, cmp_def = compare(to, tn)
    same_like, cmp_like = compare(to, tx)
    ratio = arms["table-new"]["median"] / arms["table-old"]["median"]
    out.append({
        "name": f"built-in table optimize: {OLD_COMMIT} (optimize_table(table_study()))",
        "target": "", "unit": "s", **arms["table-old"],
        "notes": f"{to['starts']} starts, no peak refinement; process "
                 f"{statistics.median(r['process_s'] for r in recs['table-old']):.3g} s; "
                 f"optimum {_values(to)}"})
    out.append({
        "name": "built-in table optimize: today (isodesign.optimize(table_study()))",
        "target": "", "unit": "s", **arms["table-new"],
        "notes": f"{tn['starts']} starts, continuous peak refinement ({tn['peak_rounds']} "
                 f"rounds, continuous peak {tn['peak_db']:.3f} dB), {tn['constraints']} "
                 f"constraint rows; process "
                 f"{statistics.median(r['process_s'] for r in recs['table-new']):.3g} s; "
                 f"optimum {_values(tn)}; with the tube end corrections off (median, same "
                 f"rounds): "
                 f"{arms['table-new-noend']['median']:.3g} s"})
    out.append({
        "name": f"built-in table optimize, today / {OLD_COMMIT}",
        "target": f"<= {TARGET_TABLE:g}", "unit": "ratio", "median": ratio,
        "ratio": ratio / TARGET_TABLE, "passed": ratio <= TARGET_TABLE,
        "notes": f"medians of the two rows above ({n} rounds each, interleaved); {load}. "
                 f"Same optimum: default physics {'yes' if same_def else 'no'} ({cmp_def}); "
                 f"end corrections off: {'yes' if same_like else 'no'} ({cmp_like}); "
                 f"like-for-like time ratio "
                 f"{arms['table-new-noend']['median'] / arms['table-old']['median']:.2f}. "
                 f"Today's call with python-control imported before the clock starts (its "
                 f"one-time import inside the leveling-loop check, new since {OLD_COMMIT}, "
                 f"taken out; median, same rounds): "
                 f"{arms['table-new-preimport']['median']:.3g} s, ratio "
                 f"{arms['table-new-preimport']['median'] / arms['table-old']['median']:.2f}"})

    # robust table
    ro = recs["robust-new"][0]
    nom = [r["nominal_wall_s"] for r in recs["robust-new"] if r.get("nominal_wall_s")]
    nom_s = statistics.median(nom) if nom else None
    ratio = arms["robust-new"]["median"] / arms["table-new"]["median"]
    out.append({
        "name": "robust built-in table optimize: today (isodesign.optimize, payload +-20 %, "
                "D_c +-5 %, CG offsets +-50 mm)",
        "target": "", "unit": "s", **arms["robust-new"],
        "notes": f"nominal optimize included (inside it, median: {_num(nom_s)} s, "
                 f"analyze=False); {n} interleaved rounds; exchange rounds {ro.get('rounds')}, "
                 f"IPOPT iterations per round {ro.get('round_iterations')}, NLP builds "
                 f"{ro.get('nlp_builds')}, scenarios {ro.get('scenarios')}; worst case "
                 f"{_num(ro.get('objective_value'))} dB; feasible {ro['feasible']}; robust "
                 f"optimum {_values(ro)}"})
    out.append({
        "name": "robust / nominal built-in table optimize (today)",
        "target": f"<= {TARGET_ROBUST:g}", "unit": "ratio", "median": ratio,
        "ratio": ratio / TARGET_ROBUST, "passed": ratio <= TARGET_ROBUST,
        "notes": f"medians of the robust row and of today's table row ({n} rounds each, "
                 f"interleaved); {load}"})
    return out


def run() -> list[dict]:
    """All rows of this file.

    Returns
    -------
    list of dict
    """
    return rows_from(measure())


if __name__ == "__main__":
    for row in run():
        print(row)
