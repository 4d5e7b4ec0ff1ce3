"""What an answer covers and what it leaves out: the scope every result states.

One place decides the scope text, so the CLI (``optimize``, ``response``, ``pareto``),
``str()`` of the results, the run record and the HTML report all say the same, and a
richer payload model changes it here only.

The scope has two parts:

* the model's reach: which motions, loads and floor inputs the answer includes and which
  it leaves out (today: vertical motion of a point-mass payload on identical, equally
  loaded isolators; no rocking or horizontal modes; a rigid floor moving vertically);
* the share of the static stiffness ``K0`` that comes from parameters marked
  illustrative (the built-in ``viscoelastic`` diaphragm is not a measured part): when
  that share is large, the answer rests on numbers nobody measured.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ILLUSTRATIVE_DIAPHRAGMS", "SHORT_VERTICAL", "Scope", "response_scope", "study_scope"]

#: The short scope of the vertical model (``repr`` of results, table cells).
SHORT_VERTICAL = "vertical only, equal loads, no rocking/horizontal modes"

#: Diaphragm models whose parameters are illustrative, not measured.
ILLUSTRATIVE_DIAPHRAGMS = frozenset({"viscoelastic"})


@dataclass(frozen=True)
class Scope:
    """The scope of an answer: what it includes, what it leaves out, what is illustrative.

    Attributes
    ----------
    covers : str
        One sentence: the motion and loads the answer includes.
    leaves_out : tuple of str
        What the answer does not model (each a short phrase).
    illustrative_share : float or None
        Fraction (0..1) of the static stiffness ``K0`` supplied by parameters marked
        illustrative; ``None`` when no illustrative parameter is used.
    illustrative_what : str
        Which parameters are illustrative (empty when none).
    headline : str
        The scope in a few words (:meth:`short`), e.g. :data:`SHORT_VERTICAL`.
    """

    covers: str
    leaves_out: tuple[str, ...]
    illustrative_share: float | None = None
    illustrative_what: str = ""
    headline: str = SHORT_VERTICAL

    def lines(self) -> list[str]:
        """The scope as short lines of text (for the CLI and ``str`` of results).

        Returns
        -------
        list of str
            ``scope: ...``, ``not modelled: ...`` and, when illustrative parameters are
            used, ``illustrative: ...``.
        """
        out = [f"scope: {self.covers}", "not modelled: " + "; ".join(self.leaves_out)]
        if self.illustrative_share is not None:
            out.append(f"illustrative: {self.illustrative_what} supplies "
                       f"{100.0 * self.illustrative_share:.0f} % of the static stiffness K0 "
                       "(calibrate it from rig data: isodesign fit diaphragm)")
        elif self.illustrative_what:
            out.append(f"illustrative: {self.illustrative_what} supplies part of the static "
                       "stiffness K0 of every design (its share per design: isodesign response "
                       "RUN; calibrate it from rig data: isodesign fit diaphragm)")
        return out

    def short(self) -> str:
        """One short phrase for a ``repr`` or a table cell.

        Returns
        -------
        str
        """
        s = self.headline
        if self.illustrative_share is not None:
            s += f"; {100.0 * self.illustrative_share:.0f} % of K0 illustrative"
        return s

    def to_dict(self) -> dict:
        """JSON-ready form (for run records).

        Returns
        -------
        dict
        """
        return {"headline": self.headline, "covers": self.covers,
                "leaves_out": list(self.leaves_out),
                "illustrative_share_of_static_stiffness": self.illustrative_share,
                "illustrative": self.illustrative_what or None}


def response_scope(payload, diaphragm: str, static_stiffness_n_per_m: float | None,
                   air_static_stiffness_n_per_m: float | None, floor_name: str = "") -> Scope:
    """The scope of a vertical band response or optimization of ``payload``.

    Parameters
    ----------
    payload : Payload
        Mass and number of isolators.
    diaphragm : str
        The diaphragm model's name (``viscoelastic``, ``none``, ``table``, ``fit``, ...).
    static_stiffness_n_per_m : float or None
        ``K0`` of one isolator (air plus diaphragm), N/m.
    air_static_stiffness_n_per_m : float or None
        The air spring's static stiffness ``k_s / (N + 1)``, N/m.
    floor_name : str
        The floor spectrum's name (a survey's names the axis used); named in ``covers``.

    Returns
    -------
    Scope
    """
    n = payload.isolators
    covers = (f"vertical motion of a {payload.mass_kg:g} kg point-mass payload on {n} "
              f"identical isolator{'s' if n != 1 else ''} sharing its weight equally; "
              "vertical floor input, the same under every isolator (rigid floor)"
              + (f": {floor_name}" if floor_name else ""))
    leaves_out = ("horizontal and rocking modes (the tilt margin is a static check only)",
                  "unequal isolator loads (CG off the isolators' centroid)",
                  "horizontal floor motion, floor rotation and differential floor motion",
                  "leveling-valve dynamics")
    share = None
    what = ""
    if (str(diaphragm).split(":")[0] in ILLUSTRATIVE_DIAPHRAGMS
            and static_stiffness_n_per_m and air_static_stiffness_n_per_m is not None):
        share = max(0.0, 1.0 - float(air_static_stiffness_n_per_m)
                    / float(static_stiffness_n_per_m))
        what = f"the {diaphragm} diaphragm (illustrative parameters, not measured)"
    return Scope(covers=covers, leaves_out=leaves_out, illustrative_share=share,
                 illustrative_what=what)


def study_scope(study) -> Scope:
    """The scope of every answer about a (vertical) study, before any design is chosen.

    For results that span many designs (a Pareto front): the model's reach and, for an
    illustrative diaphragm, that it is illustrative (its share of ``K0`` is per design).

    Parameters
    ----------
    study : Study
        Its payload, ``models["diaphragm"]`` and floor.

    Returns
    -------
    Scope
    """
    sc = response_scope(study.payload, study.models["diaphragm"], None, None,
                        getattr(study.floor, "name", ""))
    dia = str(study.models["diaphragm"])
    if dia.split(":")[0] in ILLUSTRATIVE_DIAPHRAGMS:
        sc = Scope(covers=sc.covers, leaves_out=sc.leaves_out, illustrative_share=None,
                   illustrative_what=f"the {dia} diaphragm (illustrative parameters, not "
                                     "measured)", headline=sc.headline)
    return sc
