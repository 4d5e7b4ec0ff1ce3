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

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.response.model import TWO_PI, SpringModel
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import diaphragm_model
from isodesign.spring.flow_models import model_design
from isodesign.spring.gas import P_ATM
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
    flow: str
    amplitude_mode: str
    diaphragm: Any
    include_gravity: bool = True

    @functools.cached_property
    def geometry(self) -> Geometry:
        """The assembly's constant matrices (built on first use: a z-reducible table under
        a vertical floor never needs them)."""
        return geometry(self.table, self.leveling.load_n, include_gravity=self.include_gravity)

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

    #: Relative difference of two isolators' p0 below which they share one spring
    #: evaluation (the leveling's 3x3 solve leaves equal loads equal to about 1e-16).
    P0_SHARE_RTOL = 1e-12

    def unique_isolators(self) -> tuple[np.ndarray, np.ndarray]:
        """``(first, inverse)``: one representative per distinct p0 and spring (a leveling
        group's own spring, docs/table.md section 15), and each isolator's.

        p0 values within :attr:`P0_SHARE_RTOL` of each other are one (a symmetric table's
        isolators, leveled equal up to rounding, share one spring evaluation).
        """
        lv = self.leveling
        p = np.asarray(lv.pressure_pa, dtype=float)
        own = ([g if lv.group_springs[g] else -1 for g in lv.group_of]
               if any(lv.group_springs) else [-1] * p.size)
        first: list[int] = []
        inv = np.empty(p.size, dtype=int)
        for i, pi in enumerate(p):
            for j, r in enumerate(first):
                if own[i] == own[r] and abs(pi - p[r]) <= self.P0_SHARE_RTOL * abs(p[r]):
                    inv[i] = j
                    break
            else:
                inv[i] = len(first)
                first.append(i)
        return np.array(first, dtype=int), inv

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
        first, inv = self.unique_isolators()
        cache: dict = {}
        out = []
        for i in range(self.n_isolators):
            rep = int(first[inv[i]])
            key = (rep, float(amp[i]))
            if key not in cache:
                cache[key] = self.spring(rep).k(f, amp[i])
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

    @property
    def z_reducible(self) -> bool:
        """Every isolator has one p0 (hence one load and, with one state, one spring).

        The leveling's equilibrium then puts the isolators' centroid under the CG, so the
        stiffness and damping terms coupling z with rx and ry vanish and a vertical floor
        moves the table in z alone (docs/table.md, section 14).
        """
        return len(self.unique_isolators()[0]) == 1

    def outputs(self, k_vertical, omega, k_horizontal=None, *,
                strokes_only: bool = False, axes=None) -> TableOutputs:
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
        axes : sequence of int, optional
            With ``strokes_only``: the floor axes to solve for (0, 1, 2 for x, y, z; default
            all); the other axes' columns are zero (a closure whose floor does not move in
            them). ``(2,)`` on a :attr:`z_reducible` table with one vertical stiffness for
            every isolator solves the z DOF alone, ``z = n k / (n k - m w^2)`` (exact:
            docs/table.md, section 14).
        """
        w = np.asarray(omega, dtype=float)
        kv = [k if isinstance(k, Cx) else Cx.from_complex(k) for k in k_vertical]
        if strokes_only and axes is not None and tuple(axes) == (2,) and self.z_reducible \
                and all(k is kv[0] or (np.array_equal(k.re, kv[0].re)
                                       and np.array_equal(k.im, kv[0].im)) for k in kv):
            return self._z_outputs(kv[0], w)
        kh = self.horizontal_stiffness(w) if k_horizontal is None else k_horizontal
        d, b = dynamic_stiffness(self.geometry, kv, kh, w)
        cols = None if not strokes_only or axes is None else sorted({int(a) for a in axes})
        if cols is None or len(cols) == 3:
            q = solve_complex(d, b)
        else:
            bm = (np.asarray(b.re) + 1j * np.asarray(b.im)).reshape(-1, 6, 3)
            dm = (np.asarray(d.re) + 1j * np.asarray(d.im)).reshape(-1, 6, 6)
            q = np.zeros(bm.shape, dtype=complex)
            q[:, :, cols] = np.linalg.solve(dm, bm[:, :, cols])
        geo = self.geometry
        s = np.matmul(geo.gz, q)  # (f, n, 3)
        s[:, :, 2] -= 1.0
        if strokes_only:
            if cols is not None and 2 not in cols:
                s[:, :, 2] = 0.0
            return TableOutputs(body=q, points=None, strokes=s, horizontal_strokes=None)
        pts = np.matmul(geo.points[None], q[:, None])  # (f, k, 3, 3)
        n = self.n_isolators
        hs = np.matmul(geo.gh.reshape(2 * n, 6), q).reshape(-1, 2, n, 3)
        hs[:, 0, :, 0] -= 1.0
        hs[:, 1, :, 1] -= 1.0
        return TableOutputs(body=q, points=pts, strokes=s, horizontal_strokes=hs)

    def _z_outputs(self, k: Cx, w: np.ndarray) -> TableOutputs:
        """The strokes under a vertical floor of a z-reducible table: the z DOF alone."""
        n = self.n_isolators
        kz = k.to_complex() * n
        z = kz / (kz - self.table.mass_kg * w * w)
        q = np.zeros((w.size, 6, 3), dtype=complex)
        q[:, 2, 2] = z
        s = np.zeros((w.size, n, 3), dtype=complex)
        s[:, :, 2] = (z - 1.0)[:, None]
        return TableOutputs(body=q, points=None, strokes=s, horizontal_strokes=None)

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


@functools.lru_cache(maxsize=64)
def _leveled(table: Table, piston_area_m2: float, p_atm_pa: float) -> Leveling:
    """:func:`~isodesign.table.statics.level` once per table, piston and ambient (a Table
    and its Leveling are immutable; a design's analyses and a yield's draws reuse it)."""
    lv = level(table, piston_area_m2, p_atm_pa=p_atm_pa)
    lv.group_of.flags.writeable = False  # shared by every model of this table
    return lv


def table_model(design, table, *, flow: str = "quasi_steady",
                amplitude_mode: str = "self_consistent", diaphragm="viscoelastic",
                include_gravity: bool = True, p_atm_pa: float = P_ATM) -> TableModel:
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
    p_atm_pa : float
        Ambient pressure the leveling's gauge pressures are above (a scenario's
        ``ambient_pressure_pa``), Pa.

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
    lv = _leveled(table, float(design.piston_area_m2), float(p_atm_pa))
    tol = TableModel.P0_SHARE_RTOL
    own = [lv.group_springs[int(g)] for g in lv.group_of]  # a group's own spring fields
    designs: list = []  # one design per distinct (p0 within P0_SHARE_RTOL, group spring)
    for i, p in enumerate(lv.pressure_pa):
        same = [j for j in range(i) if own[j] == own[i]
                and abs(p - lv.pressure_pa[j]) <= tol * lv.pressure_pa[j]]
        if same:
            designs.append(designs[same[0]])
        elif not own[i] and abs(p - design.pressure_pa) <= tol * p:  # already at it
            designs.append(design)
        else:
            designs.append(design.replace(pressure_pa=float(p), **own[i]))
    return TableModel(table=table, design=design, leveling=lv, designs=tuple(designs), flow=flow,
                      amplitude_mode=amplitude_mode, diaphragm=diaphragm,
                      include_gravity=include_gravity)  # fmt: skip


def study_table_model(study, design, values: dict | None = None) -> TableModel:
    """The table model of a study for a design, with the study's spring models.

    A study with ``[table]`` is that table (its levers at ``values``); a study without it
    is the symmetric table of its ``[payload]``
    (:func:`~isodesign.table.symmetric.study_table`, docs/table.md section 14).

    Parameters
    ----------
    study : Study
        A study (its ``models``: flow, amplitude mode, diaphragm).
    design : SpringDesign
    values : dict, optional
        Lever values of a ``[table]`` study.

    Returns
    -------
    TableModel
    """
    from isodesign.table.symmetric import study_table

    m = study.models
    return table_model(design, study_table(study, values), flow=m["flow"],
                       amplitude_mode=m["amplitude_mode"], diaphragm=m["diaphragm"])
