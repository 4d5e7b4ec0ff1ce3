"""The analyses a report shows for one case: bands, transmissibility, stiffness, flags."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from isodesign.optimization.analyze import vertical_band_response
from isodesign.plotting.response import judged_mask
from isodesign.reporting.inputs import Case
from isodesign.response.harmonic import harmonic_response
from isodesign.spring.diagnostics import CHECK_DESCRIPTIONS
from isodesign.spring.flow_models import FLOW_MODELS, flow_model
from isodesign.spring.stiffness import complex_stiffness

__all__ = [
    "DIAPHRAGM_CAVEATS",
    "FLOW_CAVEATS",
    "HARMONIC_AMPLITUDES_M",
    "STIFFNESS_AMPLITUDES_M",
    "CaseAnalysis",
    "analyse",
    "db",
    "model_caveats",
]

#: Floor displacement amplitudes of the harmonic transmissibility, m.
HARMONIC_AMPLITUDES_M = (1e-6, 1e-5, 1e-4)
#: Stroke amplitudes of the complex-stiffness figure, m.
STIFFNESS_AMPLITUDES_M = (1e-5, 5e-5, 2e-4, 5e-4)
#: Frequencies of the harmonic and stiffness figures: (start, stop, count), Hz.
HARMONIC_FREQUENCIES_HZ = (0.3, 60.0, 160)
STIFFNESS_FREQUENCIES_HZ = (0.2, 60.0, 40)

#: What each capillary flow model is, and its limits, in one sentence.
FLOW_CAVEATS = {
    "quasi_steady": "all-regime steady friction (Churchill, laminar to turbulent) with the "
                    "minor loss and the tube's air inertance, linearized by a describing "
                    "function; passive for every input",
    "womersley": "exact laminar oscillating flow in a rigid tube (Womersley) with the minor "
                 "loss; laminar only: points above the transition Reynolds number are flagged",
    "poiseuille": "steady laminar flow without minor loss or inertia: a linear model, "
                  "valid for small, slow tube flows only",
    "zhao": "the reference paper's oscillating-flow friction correlation as printed; "
            "singular and non-passive near Re_w = 3.67, for comparison only",
    "zhao_turbulent": "the reference paper's turbulent correlation; for comparison only",
}
#: What each diaphragm model is.
DIAPHRAGM_CAVEATS = {
    "viscoelastic": "ILLUSTRATIVE parameters (Kraus-type amplitude softening, loss factor "
                    "0.08-0.2), chosen to resemble the published behaviour, not a measured "
                    "part: replace with measured data (diaphragm = table:FILE.csv) before "
                    "relying on the damping",
    "none": "no diaphragm: the air spring alone (the diaphragm's stiffness and damping are "
            "left out)",
    "table": "measured or extracted values, interpolated in log frequency and log amplitude; "
             "points outside the table's range are flagged",
}
AMPLITUDE_CAVEATS = {
    "self_consistent": "tube velocity the chamber pressures really drive (harmonic balance)",
    "kinematic": "the paper's kinematic tube velocity (Eq. 37), which overestimates the "
                 "velocity once the tube blocks",
}
ACOUSTICS_CAVEATS = {
    "distributed": "tube as a lossy transmission line, chambers with their longitudinal "
                   "modes (docs/acoustics.md); flagged beyond the first transverse mode",
    "lumped": "uniform chamber pressures and an incompressible slug in the tube; valid "
              "while w l / c stays small (flagged beyond it)",
}
RANDOM_CAVEATS = {
    "equivalent_amplitude": "spring linearized at A* = 1.88 x the RMS stroke "
                            "(equivalent linearization of a random stroke)",
    "rayleigh": "spring averaged over a Rayleigh distribution of stroke amplitudes",
}


def model_caveats(models: dict, acoustics: str | None = None) -> list[tuple[str, str, str]]:
    """``(what, model, caveat)`` rows for the models in force.

    Parameters
    ----------
    models : dict
        ``flow``, ``amplitude_mode``, ``diaphragm``, ``random_method`` (and ``distortion``,
        ``models.distortion``, when true).
    acoustics : str, optional
        The design's acoustic model (:attr:`SpringDesign.acoustics`); a row is added when
        given. The paper's flow models are always evaluated lumped, and the row says so.
    """
    dia = str(models.get("diaphragm", ""))
    dia_key = "table" if dia.startswith("table:") or dia.lower().endswith(".csv") else dia
    rows = [
        ("capillary flow", models.get("flow", ""), FLOW_CAVEATS.get(models.get("flow"), "")),
        ("tube velocity amplitude", models.get("amplitude_mode", ""),
         AMPLITUDE_CAVEATS.get(models.get("amplitude_mode"), "")),
        ("diaphragm", dia, DIAPHRAGM_CAVEATS.get(dia_key, "")),
        ("random closure", models.get("random_method", "")
         + (" with the distortion power" if models.get("distortion") else ""),
         RANDOM_CAVEATS.get(models.get("random_method"), "")),
    ]
    if acoustics is not None:
        flow = models.get("flow")
        fm = flow_model(flow) if flow in FLOW_MODELS else None
        if acoustics != "lumped" and fm is not None and not fm.distributed:
            rows.append(("acoustics", "lumped", "the paper's flow models are evaluated "
                         "lumped (uniform chamber pressures, incompressible tube slug)"))
        else:
            rows.append(("acoustics", acoustics, ACOUSTICS_CAVEATS.get(acoustics, "")))
    return rows


@dataclass(frozen=True, eq=False)
class CaseAnalysis:
    """Everything a report shows for one case.

    ``judged`` is the band response on the judged bands (its verdict is the design's);
    ``all_bands`` on every band of the floor and the criterion, ``judged_mask`` marks the
    judged ones among them.
    """

    case: Case
    judged: object
    all_bands: object
    judged_mask: np.ndarray
    harmonic: object
    stiffness: object
    flags: tuple[tuple[str, str, int, int, str], ...]

    @property
    def passes(self) -> bool:
        """The verdict on the judged bands."""
        return bool(self.judged.passes)


_FLAG = re.compile(r"^\s*(?P<name>[a-z_0-9]+)\b\D*(?P<n>\d+)\s+of\s+(?P<tot>\d+)")


def _flag_rows(where: str, lines, total: int) -> list[tuple[str, str, int, int, str]]:
    """Validity flags as ``(where, check, points, of, meaning)``."""
    rows = []
    for line in lines:
        m = _FLAG.match(line)
        if m:
            name = m.group("name")
            rows.append((where, name, int(m.group("n")), int(m.group("tot")),
                         CHECK_DESCRIPTIONS.get(name, line)))
        else:
            rows.append((where, line.split(":")[0], -1, total, line))
    return rows


def analyse(case: Case) -> CaseAnalysis:
    """Band responses (judged and all bands), harmonic transmissibility, stiffness, flags.

    Parameters
    ----------
    case : Case

    Returns
    -------
    CaseAnalysis
    """
    st = case.study
    m = case.models
    kw = {"flow": m["flow"], "amplitude_mode": m["amplitude_mode"],
          "diaphragm": m["diaphragm"]}
    dist = bool(m.get("distortion", False))  # models.distortion: the random closure's
    judged = vertical_band_response(case.design, st.payload, st.floor, st.target,
                                    bands=st.bands, random_method=m["random_method"],
                                    derive_pressure=False, warn=False, distortion=dist, **kw)
    try:
        all_b = vertical_band_response(case.design, st.payload, st.floor, st.target,
                                       bands=None, random_method=m["random_method"],
                                       derive_pressure=False, warn=False, distortion=dist,
                                       **kw)
    except Exception:  # a floor narrower than the target's bands: the judged ones only
        all_b = judged
    lo, hi = case.judged_hz
    mask = judged_mask(all_b.bands, (lo, hi))
    f0, f1, n = HARMONIC_FREQUENCIES_HZ
    harm = harmonic_response(case.design, st.payload, np.geomspace(f0, f1, n),
                             list(HARMONIC_AMPLITUDES_M), derive_pressure=False, warn=False,
                             **kw)
    s0, s1, ns = STIFFNESS_FREQUENCIES_HZ
    stiff = complex_stiffness(case.design, np.geomspace(s0, s1, ns)[:, None],
                              np.asarray(STIFFNESS_AMPLITUDES_M)[None, :], warn=False, **kw)
    flags = (_flag_rows("band response at A*", judged.warnings, judged.grid.frequency_hz.size)
             + _flag_rows("harmonic transmissibility", harm.warnings, harm.stroke_m.size)
             + _flag_rows("complex stiffness", stiff.warnings, stiff.k.size))
    return CaseAnalysis(case, judged, all_b, mask, harm, stiff, tuple(flags))


def db(x) -> float:
    """``20 log10 x`` (NaN for x <= 0 or None).

    Parameters
    ----------
    x : float or None
    """
    return 20.0 * math.log10(x) if x is not None and x > 0 else float("nan")
