"""The table NLP's frozen-mode rows: damping and rocking frequencies (split from
:mod:`isodesign.optimization.table_problem`).

``min_damping_ratio`` on every mode below :data:`DAMPED_MODE_LIMIT_HZ`:
``phi^H K'' phi >= 2 zeta_min phi^H K' phi`` with the mode's shape ``phi`` and frequency
frozen (NLP parameters) at the last solution of the nonlinear eigenproblem, a Rayleigh
quotient, stationary in the shape; ``min_rocking_frequency_hz``/``max_rocking_frequency_hz``
on every rocking mode (rx + ry energy >= :data:`ROCKING_ENERGY_FRACTION`): the quotient
``phi^H K' phi`` (``phi^H M phi = 1``) of the frozen mode (docs/table.md, section 11). And
the top of the peak rows (:data:`PEAK_ROWS_MAX_HZ`). :class:`TableModeRows` is a mixin of
:class:`~isodesign.optimization.table_problem.TableProblem`; it imports nothing of it.
"""

from __future__ import annotations

import math

import numpy as np

from isodesign.errors import InputError
from isodesign.numerics.cplx import Cx
from isodesign.optimization import lever_nlp
from isodesign.response.isolator import static_stiffness

__all__ = ["DAMPED_MODE_LIMIT_HZ", "PEAK_ROWS_MAX_HZ", "ROCKING_ENERGY_FRACTION",
           "TableModeRows", "mode_row_quantities"]


#: Modes below this frequency carry the damping constraint.
DAMPED_MODE_LIMIT_HZ = 5.0
#: The peak-|T| rows of the NLP cover the grid up to this frequency, or twice the start
#: design's highest rigid-body frequency if higher (the analysis checks every frequency).
PEAK_ROWS_MAX_HZ = 10.0
#: A mode is a rocking mode when its kinetic energy in rx and ry reaches this fraction.
ROCKING_ENERGY_FRACTION = 0.3


class TableModeRows:
    """The frozen modes' rows and their parameters (:meth:`set_modes`), and the top of
    the peak rows (:meth:`_peak_cut_hz`), of :class:`~.table_problem.TableProblem`."""

    def _peak_cut_hz(self) -> float:
        """Top of the peak rows: :data:`PEAK_ROWS_MAX_HZ`, or twice the highest rigid-body
        frequency of the start design (static stiffness) if that is higher."""
        from scipy.linalg import eigh

        from isodesign.table.assembly import static_stiffness_matrix

        st, lv = self.study, self.leveling
        d0 = st.start_design()
        k0 = [float(static_stiffness(d0.replace(pressure_pa=float(p)), self.dia, float(mi)))
              for p, mi in zip(lv.pressure_pa, lv.mass_per_isolator_kg, strict=True)]
        kh = [float(np.asarray(self.table.horizontal.stiffness(2 * math.pi * 0.1, ld).re))
              for ld in lv.load_n]
        ks = static_stiffness_matrix(self.geo, k0, kh)
        lam = eigh(0.5 * (ks + ks.T), self.geo.mass, eigvals_only=True)
        f_max = math.sqrt(max(lam[-1], 0.0)) / (2 * math.pi)
        return max(PEAK_ROWS_MAX_HZ, 2.0 * f_max)

    def _frozen_quotients(self, ca, kfn, v, s, y, blk):
        """``(active, q', q'')``: ``phi^H K' phi`` and ``phi^H K'' phi`` of a frozen mode."""
        h = self.table.horizontal
        act, w = blk[0], blk[1]
        phr, phi = blk[2:8], blk[8:14]
        # horizontal stiffness at the (parametric) mode frequency: pendulum + lateral
        pend = [float(h.pendulum_stiffness(ld)) for ld in self.leveling.load_n]
        if self.n_levers:  # the levers' part is symbolic (_kh): a lateral model's here
            lat = h.lateral_stiffness(w) if h.lateral_model is not None else Cx(0.0, 0.0)
            khr = ca.vertcat(*[lat.re for _ in range(self.n)])
            khi = ca.vertcat(*[lat.im for _ in range(self.n)])
        elif h.lateral_model is not None:
            lat = h.lateral_stiffness(w)
            khr = ca.vertcat(*[pk + lat.re for pk in pend])
            khi = ca.vertcat(*[lat.im for _ in range(self.n)])
        else:
            khr = ca.DM([pk + h.lateral_stiffness_n_per_m for pk in pend])
            khi = ca.DM([h.lateral_stiffness_n_per_m * h.lateral_loss_factor] * self.n)
        kr, ki = kfn(v, s, y, w, khr, khi)
        kr, ki = ca.reshape(kr, 6, 6), ca.reshape(ki, 6, 6)
        # phi^H K phi for a real symmetric K: phr^T K phr + phi^T K phi
        q_r = ca.mtimes([phr.T, kr, phr]) + ca.mtimes([phi.T, kr, phi])
        q_i = ca.mtimes([phr.T, ki, phr]) + ca.mtimes([phi.T, ki, phi])
        return act, q_r, q_i

    def _damping(self, ca, v, s, y, p_modes) -> list:
        """The frozen modes' rows (damping, rocking frequencies; the registry's entries)."""
        c = self.study.constraints
        zmin = c.get("min_damping_ratio")
        f_lo, f_hi = c.get("min_rocking_frequency_hz"), c.get("max_rocking_frequency_hz")
        if not (zmin or f_lo or f_hi):
            return []
        kfn = self._stiffness_function(ca)
        damping, rocking = [], []
        if zmin:
            for j in range(self.n_modes):
                damping.append(self._frozen_quotients(ca, kfn, v, s, y,
                                                      p_modes[14 * j: 14 * (j + 1)]))
        if f_lo or f_hi:  # Rayleigh quotient w^2 = phi^H K' phi (phi^H M phi = 1)
            off = 14 * self.n_modes
            for j in range(self.n_modes):
                blk = p_modes[off + 14 * j: off + 14 * (j + 1)]
                act, q_r, _ = self._frozen_quotients(ca, kfn, v, s, y, blk)
                q_r = lever_nlp.live_mass_quotient(self, ca, v, blk, q_r)  # a free slab's M
                rocking.append((act, q_r))
        q = mode_row_quantities(c, damping, rocking, fmax=ca.fmax,
                                stack=lambda r: ca.vertcat(*r))
        return self._rows(q)

    def set_modes(self, modes) -> None:
        """Freeze the mode constraints at a solution's modes: the damping constraint on the
        modes below 5 Hz, the rocking-frequency constraints on the rocking modes (kinetic
        energy in rx and ry >= :data:`ROCKING_ENERGY_FRACTION`).

        Parameters
        ----------
        modes : TableModes
        """
        p = np.tile(np.r_[0.0, 2 * math.pi, np.zeros(12)], 2 * self.n_modes)
        zmin = self.study.constraints.get("min_damping_ratio") or 0.0
        kz = self.geo.g[: self.n]  # vertical element vectors
        off = 14 * self.n_modes
        for j in range(6):
            f = modes.frequency_hz[j]
            if not np.isfinite(f):
                continue
            phi = modes.shapes[:, j]
            phi = phi / np.sqrt(np.real(np.vdot(phi, self.geo.mass @ phi)))
            blk = np.concatenate([[1.0, 2 * math.pi * f], phi.real, phi.imag])
            if modes.energy_fraction[j, 3:5].sum() >= ROCKING_ENERGY_FRACTION:
                p[off + 14 * j: off + 14 * (j + 1)] = blk
            if f >= DAMPED_MODE_LIMIT_HZ:
                continue
            if np.max(np.abs(kz @ phi)) <= 1e-9 * np.max(np.abs(phi)) and not any(
                    self._lever_free(k) for k in ("pendulum_length_m", "lateral_loss_factor",
                                                  "lateral_stiffness_n_per_m",
                                                  "inertia_base_mass_kg")):
                # no vertical spring moves: the horizontal element alone damps this mode
                # (a free lever of its stiffness is a design variable: the mode keeps its row)
                if modes.damping_ratio[j] < zmin:
                    raise InputError(
                        f"constraints.min_damping_ratio: mode {j + 1} ({modes.names[j]}, "
                        f"{f:.3g} Hz) moves no vertical spring; its damping ratio "
                        f"{modes.damping_ratio[j]:.3g} comes from the horizontal element alone "
                        "and no design variable changes it: raise "
                        "table.horizontal.lateral_loss_factor or lower min_damping_ratio")
                continue
            p[14 * j: 14 * (j + 1)] = blk
        self.mode_params = p


def mode_row_quantities(constraints: dict, damping: list, rocking: list, *, fmax,
                        stack) -> dict:
    """The frozen modes' row quantities from their Rayleigh quotients, either backend (the
    NLP's rows, :meth:`TableModeRows._damping`, and the robust search's NumPy scorer,
    :func:`.table_search.score_table_scenario`).

    Parameters
    ----------
    constraints : dict
        The study's ``constraints`` (``min_damping_ratio``, ``min_rocking_frequency_hz``,
        ``max_rocking_frequency_hz``).
    damping : list of (act, q_r, q_i)
        Each damped mode's weight (0 or 1) and ``phi^H K' phi``, ``phi^H K'' phi``.
    rocking : list of (act, q_r)
        Each rocking mode's weight and ``phi^H K' phi`` (``w^2``, ``phi^H M phi = 1``).
    fmax : callable
        ``fmax(a, b)`` of the backend (``ca.fmax``, ``max``).
    stack : callable
        Rows to a column (``ca.vertcat(*rows)``, ``np.array``).

    Returns
    -------
    dict
        ``damping_rows`` (``act (q_i - 2 zeta_min q_r) / q_r >= 0``), ``rocking_lo_rows``,
        ``rocking_hi_rows`` (``act (q_r - w_lo^2) / w_lo^2``, ``act (w_hi^2 - q_r) /
        w_hi^2``), those the constraints ask for.
    """
    zmin = constraints.get("min_damping_ratio")
    f_lo = constraints.get("min_rocking_frequency_hz")
    f_hi = constraints.get("max_rocking_frequency_hz")
    q = {}
    if zmin:
        q["damping_rows"] = stack([act * (q_i - 2.0 * zmin * q_r) / fmax(q_r, 1e-30)
                                   for act, q_r, q_i in damping])
    if f_lo:
        w2 = (2 * math.pi * f_lo) ** 2
        q["rocking_lo_rows"] = stack([act * (q_r - w2) / w2 for act, q_r in rocking])
    if f_hi:
        w2 = (2 * math.pi * f_hi) ** 2
        q["rocking_hi_rows"] = stack([act * (w2 - q_r) / w2 for act, q_r in rocking])
    return q
