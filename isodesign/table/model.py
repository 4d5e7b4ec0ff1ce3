"""The table bound to its springs: per-isolator stiffness, transfer functions, outputs.

:class:`TableModel` joins a :class:`~isodesign.table.layout.Table`, its leveling
(each isolator's own p0, :func:`~isodesign.table.statics.level`), the spring models of
:mod:`isodesign.spring` and the 6x6 assembly of :mod:`isodesign.table.assembly`. The
vertical stiffness of isolator ``i`` is the spring model's ``k*`` at its own p0 (the same
function the 1-DOF payload uses); the horizontal one is its
:class:`~isodesign.table.layout.HorizontalElement`.

Outputs per floor axis ``a`` (unit floor displacement ``u_f = e_a``):

* body ``q = D^-1 B e_a`` (6 DOFs about the CG);
* instrument point ``p``: ``T_p = G_p q`` (3 axes), its absolute transmissibility;
* vertical stroke of isolator ``i``: ``gz_i . q - delta_{a z}``;
* horizontal strokes: ``gx_i . q - delta_{a x}`` and ``gy_i . q - delta_{a y}``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.response.model import TWO_PI, SpringModel
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import model_design
from isodesign.spring.stiffness import check_models
from isodesign.table.assembly import Geometry, dynamic_stiffness, geometry, solve_complex
from isodesign.table.layout import Table
from isodesign.table.statics import Leveling, level

__all__ = ["TableModel", "TableOutputs", "study_table_model", "table_model"]


@dataclass(frozen=True, eq=False)
class TableOutputs:
    """Transfer functions of a table per unit floor displacement, on a frequency grid.

    Attributes
    ----------
    body : ndarray (n_freq, 6, 3) complex
        Body DOFs ``(x, y, z, rx, ry, rz)`` per floor axis ``(x, y, z)``.
    points : ndarray (n_freq, k, 3, 3) complex
        Instrument-point translation ``[f, point, output axis, floor axis]``: the absolute
        transmissibility (displacement, velocity or acceleration alike).
    strokes : ndarray (n_freq, n, 3) complex
        Vertical stroke of each isolator per floor axis (relative motion).
    horizontal_strokes : ndarray (n_freq, 2, n, 3) complex
        x and y relative motion of each isolator's elastic centre per floor axis.
    """

    body: np.ndarray
    points: np.ndarray
    strokes: np.ndarray
    horizontal_strokes: np.ndarray


@dataclass(frozen=True, eq=False)
class TableModel:
    """A table, its leveling and its springs, bound together (NumPy face).

    Attributes
    ----------
    table : Table
    design : SpringDesign
        The isolators' spring (identical hardware; p0 from the leveling).
    leveling : Leveling
    designs : tuple of SpringDesign
        Each isolator's design at its own p0.
    geometry : Geometry
    flow, amplitude_mode : str
    diaphragm : str or model
        The vertical diaphragm (as given).
    include_gravity : bool
    """

    table: Table
    design: SpringDesign
    leveling: Leveling
    designs: tuple
    geometry: Geometry
    flow: str
    amplitude_mode: str
    diaphragm: Any
    include_gravity: bool = True

    @property
    def n_isolators(self) -> int:
        """Number of isolators."""
        return self.table.n_isolators

    def spring(self, i: int) -> SpringModel:
        """The 1-DOF :class:`~isodesign.response.model.SpringModel` of isolator ``i``.

        Parameters
        ----------
        i : int
            Isolator index (zero-based).
        """
        return SpringModel(self.designs[i], float(self.leveling.mass_per_isolator_kg[i]),
                           self.flow, self.amplitude_mode, self.diaphragm)  # fmt: skip

    def unique_isolators(self) -> tuple[np.ndarray, np.ndarray]:
        """``(first, inverse)``: one representative per distinct p0 (and spring: a leveling
        group's own spring, docs/table.md section 14), and each isolator's."""
        lv = self.leveling
        if any(lv.group_springs):
            own = [g if lv.group_springs[g] else -1 for g in lv.group_of]
            key = np.column_stack([lv.pressure_pa, np.asarray(own, float)])
            _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
            return first, np.asarray(inv).ravel()
        _, first, inv = np.unique(self.leveling.pressure_pa, return_index=True,
                                  return_inverse=True)  # fmt: skip
        return first, inv

    def vertical_stiffness(self, frequency_hz, amplitude_m) -> list[np.ndarray]:
        """Each isolator's harmonic ``k*(X, f)`` (complex arrays), one evaluation per p0.

        Parameters
        ----------
        frequency_hz : ndarray
            Frequencies, Hz.
        amplitude_m : float or sequence of float
            Stroke amplitude (one for all, or one per isolator), m.
        """
        f = np.asarray(frequency_hz, dtype=float)
        amp = np.broadcast_to(np.asarray(amplitude_m, dtype=float), (self.n_isolators,))
        cache: dict = {}
        out = []
        for i in range(self.n_isolators):
            key = (float(self.leveling.pressure_pa[i]), float(amp[i]))
            if key not in cache:
                cache[key] = self.spring(i).k(f, amp[i])
            out.append(cache[key])
        return out

    def horizontal_stiffness(self, omega) -> list[Cx]:
        """Each isolator's horizontal ``W_i/L_p + k_lat(w)`` (Cx).

        Parameters
        ----------
        omega : ndarray
            Angular frequency, rad/s.
        """
        w = np.asarray(omega, dtype=float)
        h = self.table.horizontal
        return [h.stiffness(w, float(load)) for load in self.leveling.load_n]

    def outputs(self, k_vertical, omega, k_horizontal=None, *,
                strokes_only: bool = False) -> TableOutputs:
        """Transfer functions for given vertical (and horizontal) isolator stiffnesses.

        Parameters
        ----------
        k_vertical : list of complex ndarray or Cx
            Vertical stiffness of each isolator at ``omega``.
        omega : ndarray
            Angular frequency, rad/s.
        k_horizontal : list of Cx, optional
            Default :meth:`horizontal_stiffness`.
        strokes_only : bool
            Compute the vertical strokes only (``points`` and ``horizontal_strokes`` are
            ``None``): what the closure iterates on.
        """
        w = np.asarray(omega, dtype=float)
        kv = [k if isinstance(k, Cx) else Cx.from_complex(k) for k in k_vertical]
        kh = self.horizontal_stiffness(w) if k_horizontal is None else k_horizontal
        d, b = dynamic_stiffness(self.geometry, kv, kh, w)
        q = solve_complex(d, b)
        geo = self.geometry
        s = np.matmul(geo.gz, q)  # (f, n, 3)
        s[:, :, 2] -= 1.0
        if strokes_only:
            return TableOutputs(body=q, points=None, strokes=s, horizontal_strokes=None)
        pts = np.matmul(geo.points[None], q[:, None])  # (f, k, 3, 3)
        n = self.n_isolators
        hs = np.matmul(geo.gh.reshape(2 * n, 6), q).reshape(-1, 2, n, 3)
        hs[:, 0, :, 0] -= 1.0
        hs[:, 1, :, 1] -= 1.0
        return TableOutputs(body=q, points=pts, strokes=s, horizontal_strokes=hs)

    def linear_outputs(self, frequency_hz, amplitude_m: float = 1e-6) -> TableOutputs:
        """Transfer functions with every spring at one fixed amplitude (linear regime).

        Parameters
        ----------
        frequency_hz : ndarray
            Frequencies, Hz.
        amplitude_m : float
            Stroke amplitude of the springs, m (default 1 um).
        """
        f = np.asarray(frequency_hz, dtype=float)
        return self.outputs(self.vertical_stiffness(f, amplitude_m), TWO_PI * f)


def table_model(design, table, *, flow: str = "quasi_steady",
                amplitude_mode: str = "self_consistent", diaphragm="viscoelastic",
                include_gravity: bool = True) -> TableModel:
    """Level the table and bind its springs.

    Parameters
    ----------
    design : SpringDesign
        The isolators' spring (its ``pressure_pa`` is replaced by each isolator's p0).
    table : Table
    flow, amplitude_mode : str
        Spring models (:func:`~isodesign.spring.stiffness.complex_stiffness`).
    diaphragm : str or model
        The vertical diaphragm.
    include_gravity : bool
        The overturning term (default on).

    Returns
    -------
    TableModel
    """
    if not isinstance(design, SpringDesign):
        raise InputError(f"design: expected a SpringDesign, got {type(design).__name__}")
    if not isinstance(table, Table):
        raise InputError(f"table: expected an isodesign Table, got {type(table).__name__}")
    check_models(flow, amplitude_mode)
    diaphragm_model(diaphragm)
    design = model_design(flow, design)  # the paper's flow models are lumped by definition
    lv = level(table, design.piston_area_m2)
    geo = geometry(table, lv.load_n, include_gravity=include_gravity)
    return TableModel(table=table, design=design, leveling=lv, designs=lv.designs(design),
                      geometry=geo, flow=flow, amplitude_mode=amplitude_mode,
                      diaphragm=diaphragm, include_gravity=include_gravity)  # fmt: skip


def study_table_model(study, design) -> TableModel:
    """The table model of a study's ``[table]`` for a design, with the study's spring models.

    Parameters
    ----------
    study : Study
        A study with ``[table]`` (its ``models``: flow, amplitude mode, diaphragm).
    design : SpringDesign

    Returns
    -------
    TableModel
    """
    m = study.models
    return table_model(design, study.table, flow=m["flow"], amplitude_mode=m["amplitude_mode"],
                       diaphragm=m["diaphragm"])
