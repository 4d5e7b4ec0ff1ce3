"""Complex stiffness of the rolling diaphragm, k_D*(X_p, w) (paper Section 3.2).

The paper extracts k_D* from a single-chamber measurement (capillary blocked)
by subtracting the air stiffness k_s (Eq. 40) and uses the numbers of its
Fig. 8 directly; no values were published. Models, by name
(:data:`DIAPHRAGM_MODELS`):

``viscoelastic`` (:class:`ViscoelasticDiaphragm`)
    A smooth, passive parametric model: Kraus/Payne-type amplitude softening
    of the storage stiffness, a loss factor rising with amplitude, and weak
    power-law frequency dependence. The default parameters are ILLUSTRATIVE:
    they reproduce what the paper describes (stiffness of the same order as the
    air, about 8 kN/m at 0.05 mm softening to 5 kN/m at 0.5 mm, loss factor
    about 0.08 to 0.2, both rising slowly with frequency), not a measured part.
    Replace them with measured data.
``table`` (:class:`TableDiaphragm`)
    Measured or extracted values on a grid of frequency x amplitude, read from
    CSV, interpolated bilinearly in (log f, log X) as the paper uses its Fig. 8.
``fit`` (:class:`FittedDiaphragm`)
    Identified from rig data by :mod:`isodesign.calibration` (``isodesign fit
    diaphragm``): a generalized Maxwell (Prony) series with non-negative weights,
    a non-negative static term and a constant-loss term, whose coefficients vary
    with ln X as Bernstein polynomials with non-negative coefficients; passive at
    every frequency and amplitude by construction, smooth in (w, X). Read with
    ``fit:PATH.toml``.
``none`` (:class:`NoDiaphragm`)
    k_D* = 0 (the air alone).

Also, as an object only: :class:`PronyDiaphragm`, a linear (amplitude-independent)
generalized Maxwell element, the causal form the Monte Carlo verifier integrates in the
time domain (:mod:`isodesign.simulation.monte_carlo`).

A design file's ``[diaphragm]`` table (``model = "viscoelastic"`` with any of
its parameters, ``"none"``, ``"table:PATH.csv"`` or ``"fit:PATH.toml"``) is read
by :func:`diaphragm_from_dict`; ``diaphragm_model("PATH.toml")`` accepts a fit
file or a design file with such a table.

The total stiffness is the parallel sum k*_{d+D} = k_d* + k_D* (Eq. 42).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from isodesign.errors import InputError, check_positive, check_range
from isodesign.io.files import read_csv_columns
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx

__all__ = [
    "DIAPHRAGM_MODELS",
    "DIAPHRAGM_SPECS",
    "VISCOELASTIC_PARAMETERS",
    "FittedDiaphragm",
    "NoDiaphragm",
    "PronyDiaphragm",
    "TableDiaphragm",
    "ViscoelasticDiaphragm",
    "bernstein_basis",
    "diaphragm_from_dict",
    "diaphragm_model",
    "maxwell_series",
]

#: Diaphragm models: name -> how a user writes it (``diaphragm=...``, ``--diaphragm``).
DIAPHRAGM_SPECS = {
    "viscoelastic": "viscoelastic",
    "none": "none",
    "table": "table:PATH.csv",
    "fit": "fit:PATH.toml",
}
#: Names of the diaphragm models.
DIAPHRAGM_MODELS = tuple(DIAPHRAGM_SPECS)


@dataclass(frozen=True)
class NoDiaphragm:
    """No diaphragm: k_D* = 0."""

    name: str = field(default="none", init=False)

    def stiffness(self, omega, amplitude_m) -> Cx:
        """Complex stiffness (zero) in N/m."""
        z = 0.0 * omega * amplitude_m
        return Cx(z, z)

    def in_range(self, omega, amplitude_m) -> dict:
        """Validity checks (none apply)."""
        return {}


@dataclass(frozen=True)
class ViscoelasticDiaphragm:
    """Smooth passive diaphragm model with amplitude softening.

    ``k_D* = k'(X, f) (1 + j eta(X, f))`` with, writing ``s = (X/X_c)^p``::

        k'(X, f)  = [k_inf + (k_0 - k_inf) / (1 + s)] (f / f_ref)^beta
        eta(X, f) = [eta_0 + (eta_inf - eta_0) s / (1 + s)] (f / f_ref)^gamma

    The amplitude law is the Kraus (1963) form used for filled rubber (Payne
    effect); the frequency law is a weak power law, the fractional-derivative
    behaviour of rubber over a narrow band. Passive for every positive input
    (eta > 0) and infinitely differentiable, so it can enter an NLP.

    Defaults are illustrative (see the module docstring): k' = 8.03 kN/m at
    0.05 mm and 5.01 kN/m at 0.5 mm (at 1 Hz), eta = 0.084 at 0.05 mm and 0.198
    at 0.5 mm.
    """

    k0_n_per_m: float = 8400.0
    kinf_n_per_m: float = 4700.0
    eta0: float = 0.07
    etainf: float = 0.21
    critical_amplitude_m: float = 1.5e-4
    softening_exponent: float = 2.0
    reference_frequency_hz: float = 1.0
    stiffness_frequency_exponent: float = 0.02
    loss_frequency_exponent: float = 0.05
    name: str = field(default="viscoelastic", init=False)

    def __post_init__(self):
        check_positive("diaphragm.k0_n_per_m", self.k0_n_per_m, unit="N/m")
        check_range("diaphragm.kinf_n_per_m", self.kinf_n_per_m, 0.0, self.k0_n_per_m)
        check_range("diaphragm.eta0", self.eta0, 0.0, 2.0)
        check_range("diaphragm.etainf", self.etainf, 0.0, 2.0)
        check_positive("diaphragm.critical_amplitude_m", self.critical_amplitude_m, unit="m")
        check_range("diaphragm.softening_exponent", self.softening_exponent, 0.1, 10.0)
        check_positive("diaphragm.reference_frequency_hz", self.reference_frequency_hz)
        check_range(
            "diaphragm.stiffness_frequency_exponent", self.stiffness_frequency_exponent, 0.0, 0.5
        )
        check_range("diaphragm.loss_frequency_exponent", self.loss_frequency_exponent, 0.0, 0.5)

    def stiffness(self, omega, amplitude_m) -> Cx:
        """Complex stiffness k_D*(X, w) in N/m (any backend)."""
        s = bk.power(amplitude_m / self.critical_amplitude_m, self.softening_exponent)
        fr = omega / (2.0 * math.pi * self.reference_frequency_hz)
        k_amp = self.kinf_n_per_m + (self.k0_n_per_m - self.kinf_n_per_m) / (1.0 + s)
        eta_amp = self.eta0 + (self.etainf - self.eta0) * s / (1.0 + s)
        kp = k_amp * bk.power(fr, self.stiffness_frequency_exponent)
        eta = eta_amp * bk.power(fr, self.loss_frequency_exponent)
        return Cx(kp, kp * eta)

    def in_range(self, omega, amplitude_m) -> dict:
        """Validity checks (the parametric model has no data range)."""
        return {}


def maxwell_series(omega, static_n_per_m, hysteretic_n_per_m, branch_n_per_m, times_s) -> Cx:
    """Generalized Maxwell (Prony) series: the one formula of every Prony diaphragm model.

    ``k*(w) = k_st + j h + sum_i g_i j w tau_i / (1 + j w tau_i)``: a spring ``k_st`` in
    parallel with Maxwell branches (stiffness ``g_i``, relaxation time ``tau_i``) and a
    constant-loss term ``h``. Passive when every coefficient is >= 0.

    Parameters
    ----------
    omega : float, ndarray or CasADi symbol
        Angular frequency, rad/s.
    static_n_per_m, hysteretic_n_per_m : float, ndarray or CasADi symbol
        ``k_st`` and ``h``, N/m (broadcast against ``omega``).
    branch_n_per_m : sequence
        Branch stiffnesses ``g_i``, N/m (numbers, arrays or symbols).
    times_s : sequence of float
        Relaxation times ``tau_i``, s (same length as ``branch_n_per_m``).

    Returns
    -------
    Cx
        The complex stiffness, N/m.
    """
    re = static_n_per_m + 0.0 * omega
    im = hysteretic_n_per_m + 0.0 * omega
    for g, tau in zip(branch_n_per_m, times_s, strict=True):
        wt = omega * tau
        d = 1.0 + wt * wt
        re = re + g * (wt * wt) / d
        im = im + g * wt / d
    return Cx(re, im)


@dataclass(frozen=True)
class PronyDiaphragm:
    """Linear viscoelastic diaphragm: ``k_inf + sum k_i j w / (j w + r_i)`` (Prony series).

    A spring ``k_inf`` in parallel with Maxwell branches (stiffness ``k_i``, relaxation rate
    ``r_i = 1/tau_i``): passive and causal, independent of the amplitude, and realizable in
    the time domain (each branch force ``q_i`` obeys ``dq_i/dt = k_i dz/dt - r_i q_i``).

    Parameters
    ----------
    k_inf_n_per_m : float
        Static stiffness (>= 0).
    branch_stiffness_n_per_m, branch_rate_1_per_s : tuple of float
        ``k_i >= 0`` and ``r_i > 0``, same length.
    """

    k_inf_n_per_m: float
    branch_stiffness_n_per_m: tuple = ()
    branch_rate_1_per_s: tuple = ()
    name: str = field(default="prony", init=False)

    def __post_init__(self):
        check_range("diaphragm.k_inf_n_per_m", self.k_inf_n_per_m, 0.0, None)
        k = tuple(float(v) for v in self.branch_stiffness_n_per_m)
        r = tuple(float(v) for v in self.branch_rate_1_per_s)
        if len(k) != len(r):
            raise InputError("diaphragm: branch_stiffness_n_per_m and branch_rate_1_per_s "
                             f"differ in length ({len(k)} and {len(r)})")  # fmt: skip
        if any(not (v >= 0 and math.isfinite(v)) for v in k) or any(
            not (v > 0 and math.isfinite(v)) for v in r
        ):
            raise InputError("diaphragm: branch stiffnesses must be >= 0 and rates > 0")
        object.__setattr__(self, "branch_stiffness_n_per_m", k)
        object.__setattr__(self, "branch_rate_1_per_s", r)

    def stiffness(self, omega, amplitude_m) -> Cx:
        """Complex stiffness in N/m (any backend; independent of the amplitude)."""
        return maxwell_series(
            omega, self.k_inf_n_per_m + 0.0 * amplitude_m, 0.0,
            self.branch_stiffness_n_per_m, [1.0 / r for r in self.branch_rate_1_per_s],
        )

    def in_range(self, omega, amplitude_m) -> dict:
        """Validity checks (none apply)."""
        return {}


@dataclass(frozen=True, eq=False)
class TableDiaphragm:
    """Diaphragm stiffness from a table on a frequency x amplitude grid.

    Bilinear interpolation in (ln f, ln X) of the real and imaginary parts; the
    same piecewise-linear interpolant on both backends (CasADi ``interpolant``
    with the 'linear' method). Points outside the grid take the nearest edge
    value and are flagged ``diaphragm_table_range``.

    Parameters
    ----------
    frequency_hz : array, shape (nf,)
        Strictly increasing grid frequencies.
    amplitude_m : array, shape (na,)
        Strictly increasing grid amplitudes.
    k_real_n_per_m, k_imag_n_per_m : array, shape (nf, na)
        Storage and loss stiffness on the grid.
    source : str
        Where the data came from.
    """

    frequency_hz: np.ndarray
    amplitude_m: np.ndarray
    k_real_n_per_m: np.ndarray
    k_imag_n_per_m: np.ndarray
    source: str = ""
    name: str = field(default="table", init=False)

    def __post_init__(self):
        f = np.asarray(self.frequency_hz, dtype=float)
        a = np.asarray(self.amplitude_m, dtype=float)
        kr = np.asarray(self.k_real_n_per_m, dtype=float)
        ki = np.asarray(self.k_imag_n_per_m, dtype=float)
        where = f" ({self.source})" if self.source else ""
        for nm, g in (("frequency_hz", f), ("amplitude_m", a)):
            if g.ndim != 1 or g.size < 2:
                raise InputError(f"diaphragm table{where}: {nm} needs at least 2 grid values")
            if not np.all(np.isfinite(g)) or np.any(g <= 0):
                raise InputError(f"diaphragm table{where}: {nm} must be finite and > 0")
            if np.any(np.diff(g) <= 0):
                raise InputError(f"diaphragm table{where}: {nm} must be strictly increasing")
        for nm, v in (("k_real_n_per_m", kr), ("k_imag_n_per_m", ki)):
            if v.shape != (f.size, a.size):
                raise InputError(
                    f"diaphragm table{where}: {nm} must have shape (n_freq, n_amp) = "
                    f"({f.size}, {a.size}), got {v.shape}"
                )
            if not np.all(np.isfinite(v)):
                raise InputError(f"diaphragm table{where}: {nm} has NaN or infinite values")
        if np.any(ki < 0):
            raise InputError(
                f"diaphragm table{where}: k_imag_n_per_m must be >= 0 (a passive diaphragm)"
            )
        for nm, v in (
            ("frequency_hz", f),
            ("amplitude_m", a),
            ("k_real_n_per_m", kr),
            ("k_imag_n_per_m", ki),
        ):
            v = v.copy()
            v.flags.writeable = False
            object.__setattr__(self, nm, v)

    # -- IO -------------------------------------------------------------------
    @classmethod
    def from_csv(cls, path) -> TableDiaphragm:
        """Read a CSV with columns ``frequency_hz, amplitude_m, k_real_n_per_m,
        k_imag_n_per_m`` (one row per grid point, a full grid, any order;
        ``#`` comment lines allowed)."""

        cols = read_csv_columns(
            path,
            ("frequency_hz", "amplitude_m", "k_real_n_per_m", "k_imag_n_per_m"),
            what="diaphragm table",
        )
        f, a = cols["frequency_hz"], cols["amplitude_m"]
        fg, ag = np.unique(f), np.unique(a)
        if fg.size * ag.size != f.size:
            raise InputError(
                f"diaphragm table ({path}): rows must form a full frequency x amplitude grid "
                f"({fg.size} frequencies x {ag.size} amplitudes = {fg.size * ag.size} rows "
                f"expected, {f.size} found, or duplicates)"
            )
        i = np.searchsorted(fg, f)
        j = np.searchsorted(ag, a)
        kr = np.full((fg.size, ag.size), np.nan)
        ki = np.full((fg.size, ag.size), np.nan)
        kr[i, j] = cols["k_real_n_per_m"]
        ki[i, j] = cols["k_imag_n_per_m"]
        if np.isnan(kr).any():
            raise InputError(f"diaphragm table ({path}): duplicate grid points")
        return cls(fg, ag, kr, ki, source=str(Path(path)))

    def to_frame(self):
        """Long-format table (one row per grid point)."""
        import pandas as pd

        ff, aa = np.meshgrid(self.frequency_hz, self.amplitude_m, indexing="ij")
        return pd.DataFrame(
            {
                "frequency_hz": ff.ravel(),
                "amplitude_m": aa.ravel(),
                "k_real_n_per_m": self.k_real_n_per_m.ravel(),
                "k_imag_n_per_m": self.k_imag_n_per_m.ravel(),
            }
        )

    # -- evaluation -----------------------------------------------------------
    def _casadi_interpolants(self):
        cached = self.__dict__.get("_cs_interp")
        if cached is None:
            import casadi as ca

            grid = [np.log(self.frequency_hz).tolist(), np.log(self.amplitude_m).tolist()]
            # CasADi wants the first grid dimension to run fastest (Fortran order)
            cached = tuple(
                ca.interpolant(f"diaphragm_{nm}", "linear", grid, v.ravel(order="F").tolist())
                for nm, v in (("re", self.k_real_n_per_m), ("im", self.k_imag_n_per_m))
            )
            object.__setattr__(self, "_cs_interp", cached)
        return cached

    def stiffness(self, omega, amplitude_m) -> Cx:
        """Complex stiffness k_D*(X, w) in N/m, interpolated (any backend)."""
        lf = bk.log(omega / (2.0 * math.pi))
        lx = bk.log(amplitude_m)
        if bk.is_casadi(lf, lx):
            import casadi as ca

            re_i, im_i = self._casadi_interpolants()
            lf_c = ca.fmin(
                ca.fmax(lf, math.log(self.frequency_hz[0])), math.log(self.frequency_hz[-1])
            )
            lx_c = ca.fmin(
                ca.fmax(lx, math.log(self.amplitude_m[0])), math.log(self.amplitude_m[-1])
            )
            args = ca.horzcat(lf_c, lx_c).T if lf_c.shape == (1, 1) else None
            if args is None:
                raise InputError("TableDiaphragm on CasADi symbols expects scalar inputs")
            return Cx(re_i(args), im_i(args))
        lf, lx = np.broadcast_arrays(np.asarray(lf, float), np.asarray(lx, float))
        return Cx(
            _bilinear(
                np.log(self.frequency_hz), np.log(self.amplitude_m), self.k_real_n_per_m, lf, lx
            ),
            _bilinear(
                np.log(self.frequency_hz), np.log(self.amplitude_m), self.k_imag_n_per_m, lf, lx
            ),
        )

    def in_range(self, omega, amplitude_m) -> dict:
        """``diaphragm_table_range``: inside the table's frequency and amplitude grid."""
        f = np.asarray(omega, float) / (2.0 * math.pi)
        a = np.asarray(amplitude_m, float)
        tol = 1e-9
        ok = (
            (f >= self.frequency_hz[0] * (1 - tol))
            & (f <= self.frequency_hz[-1] * (1 + tol))
            & (a >= self.amplitude_m[0] * (1 - tol))
            & (a <= self.amplitude_m[-1] * (1 + tol))
        )
        return {"diaphragm_table_range": ok}


def bernstein_basis(t, degree: int) -> list:
    """Bernstein polynomials ``B_m(t) = C(M, m) t^m (1-t)^(M-m)``, m = 0..M (any backend).

    Non-negative on [0, 1] and summing to 1 there.

    Parameters
    ----------
    t : float, array or CasADi symbol
        The argument, in [0, 1].
    degree : int
        The degree M (>= 0).

    Returns
    -------
    list
        ``[B_0(t), ..., B_M(t)]``.
    """
    if degree == 0:
        return [1.0 + 0.0 * t]
    u = 1.0 - t
    return [
        math.comb(degree, m) * bk.ipow(t, m) * bk.ipow(u, degree - m) for m in range(degree + 1)
    ]


@dataclass(frozen=True, eq=False)
class FittedDiaphragm:
    """Diaphragm identified from measurements: passive, smooth, amplitude-softening.

    With ``t = (ln X - ln X_lo) / (ln X_hi - ln X_lo)`` clamped to [0, 1] and the
    Bernstein polynomials ``B_m(t)`` of degree ``M``::

        k_D*(w, X) = k_st(t) + sum_i g_i(t) j w tau_i / (1 + j w tau_i) + j h(t)
        k_st(t) = sum_m B_m(t) static[m],  g_i(t) = sum_m B_m(t) weights[m, i],
        h(t)    = sum_m B_m(t) hysteretic[m]

    a generalized Maxwell (Prony) series on fixed relaxation times ``tau_i``
    plus a static and a constant-loss (hysteretic) term. Every coefficient is
    >= 0, so ``Im k_D* >= 0`` at every frequency and amplitude (passive) and the
    storage part is >= 0; the fit (:func:`isodesign.calibration.fit_diaphragm`)
    also makes the storage stiffness non-increasing in X. Smooth in w and X
    inside the measured amplitude range (a polynomial in ln X); outside it the
    edge value is taken and the point is flagged ``diaphragm_fit_range``.

    Parameters
    ----------
    relaxation_times_s : array, shape (n,)
    static_n_per_m : array, shape (M+1,)
    weights_n_per_m : array, shape (M+1, n)
    hysteretic_n_per_m : array, shape (M+1,)
    amplitude_range_m : (float, float)
        Measured amplitude range ``(X_lo, X_hi)``; equal for a single amplitude (M = 0).
    frequency_range_hz : (float, float)
        Measured frequency range (validity).
    source : str
    """

    relaxation_times_s: np.ndarray
    static_n_per_m: np.ndarray
    weights_n_per_m: np.ndarray
    hysteretic_n_per_m: np.ndarray
    amplitude_range_m: tuple[float, float]
    frequency_range_hz: tuple[float, float]
    source: str = ""
    name: str = field(default="fit", init=False)

    def __post_init__(self):
        where = f" ({self.source})" if self.source else ""
        tau = np.asarray(self.relaxation_times_s, dtype=float).reshape(-1)
        st = np.asarray(self.static_n_per_m, dtype=float).reshape(-1)
        w = np.asarray(self.weights_n_per_m, dtype=float)
        h = np.asarray(self.hysteretic_n_per_m, dtype=float).reshape(-1)
        m1 = st.size
        if w.ndim != 2 or w.shape != (m1, tau.size) or h.size != m1 or m1 < 1:
            raise InputError(
                f"fitted diaphragm{where}: weights_n_per_m must have shape (degree+1, n_tau) = "
                f"({m1}, {tau.size}) and hysteretic_n_per_m {m1} values; got {w.shape} and "
                f"{h.size}"
            )
        for nm, v in (("relaxation_times_s", tau), ("static_n_per_m", st),
                      ("weights_n_per_m", w), ("hysteretic_n_per_m", h)):  # fmt: skip
            if not np.all(np.isfinite(v)):
                raise InputError(f"fitted diaphragm{where}: {nm} has NaN or infinite values")
            if np.any(v < 0):
                raise InputError(
                    f"fitted diaphragm{where}: {nm} must be >= 0 (a passive diaphragm)"
                )
        if np.any(tau <= 0):
            raise InputError(f"fitted diaphragm{where}: relaxation_times_s must be > 0")
        lo, hi = (float(v) for v in self.amplitude_range_m)
        flo, fhi = (float(v) for v in self.frequency_range_hz)
        if not (0 < lo <= hi and 0 < flo <= fhi):
            raise InputError(
                f"fitted diaphragm{where}: amplitude_range_m and frequency_range_hz must be "
                "positive (lo, hi) pairs with lo <= hi"
            )
        if m1 > 1 and hi <= lo:
            raise InputError(
                f"fitted diaphragm{where}: a degree {m1 - 1} fit needs amplitude_range_m with "
                "hi > lo"
            )
        for nm, v in (("relaxation_times_s", tau), ("static_n_per_m", st),
                      ("weights_n_per_m", w), ("hysteretic_n_per_m", h)):  # fmt: skip
            v = v.copy()
            v.flags.writeable = False
            object.__setattr__(self, nm, v)
        object.__setattr__(self, "amplitude_range_m", (lo, hi))
        object.__setattr__(self, "frequency_range_hz", (flo, fhi))

    @property
    def degree(self) -> int:
        """Degree M of the Bernstein polynomials in ln X."""
        return self.static_n_per_m.size - 1

    def _t(self, amplitude_m):
        lo, hi = self.amplitude_range_m
        if self.degree == 0:
            return 0.0 * amplitude_m
        t = (bk.log(amplitude_m) - math.log(lo)) / (math.log(hi) - math.log(lo))
        if bk.is_casadi(t):
            import casadi as ca

            return ca.fmin(ca.fmax(t, 0.0), 1.0)
        return np.clip(t, 0.0, 1.0)

    def coefficients(self, amplitude_m):
        """``(k_st, g_i (list), h)`` at amplitude X (any backend)."""
        b = bernstein_basis(self._t(amplitude_m), self.degree)
        k_st = sum(bm * float(c) for bm, c in zip(b, self.static_n_per_m, strict=True))
        h = sum(bm * float(c) for bm, c in zip(b, self.hysteretic_n_per_m, strict=True))
        g = [
            sum(bm * float(c) for bm, c in zip(b, self.weights_n_per_m[:, i], strict=True))
            for i in range(self.relaxation_times_s.size)
        ]
        return k_st, g, h

    def stiffness(self, omega, amplitude_m) -> Cx:
        """Complex stiffness k_D*(X, w) in N/m (any backend)."""
        k_st, g, h = self.coefficients(amplitude_m)
        return maxwell_series(omega, k_st, h, g, [float(t) for t in self.relaxation_times_s])

    def in_range(self, omega, amplitude_m) -> dict:
        """``diaphragm_fit_range``: inside the measured frequency and amplitude range."""
        f = np.asarray(omega, float) / (2.0 * math.pi)
        a = np.asarray(amplitude_m, float)
        tol = 1e-9
        (lo, hi), (flo, fhi) = self.amplitude_range_m, self.frequency_range_hz
        ok = (
            (f >= flo * (1 - tol)) & (f <= fhi * (1 + tol))
            & (a >= lo * (1 - tol)) & (a <= hi * (1 + tol))
        )  # fmt: skip
        return {"diaphragm_fit_range": ok}

    # -- IO -------------------------------------------------------------------
    def to_toml(self, *, header: str = "", extra: dict | None = None) -> str:
        """The ``[fitted_diaphragm]`` TOML document (read back by :meth:`from_toml`).

        ``extra`` (a flat dict of numbers and strings) is written as a
        ``[fit_report]`` table for the record; it is not read back.
        """

        def arr(v) -> str:
            return "[" + ", ".join(repr(float(x)) for x in np.ravel(v)) + "]"

        lines = [f"# {h}".rstrip() for h in header.splitlines()] if header else []
        lines += [
            "[fitted_diaphragm]",
            'model = "prony_bernstein"',
            f"relaxation_times_s = {arr(self.relaxation_times_s)}",
            f"amplitude_range_m = {arr(self.amplitude_range_m)}",
            f"frequency_range_hz = {arr(self.frequency_range_hz)}",
            f"static_n_per_m = {arr(self.static_n_per_m)}",
            f"hysteretic_n_per_m = {arr(self.hysteretic_n_per_m)}",
            "weights_n_per_m = [",
            *(f"    {arr(row)}," for row in self.weights_n_per_m),
            "]",
        ]
        if extra:
            lines += ["", "[fit_report]"]
            for k, v in extra.items():
                if isinstance(v, str):
                    lines.append(f"{k} = {_toml_str(v)}")
                elif isinstance(v, bool):
                    lines.append(f"{k} = {'true' if v else 'false'}")
                else:
                    lines.append(f"{k} = {float(v)!r}")
        return "\n".join(lines) + "\n"

    @classmethod
    def from_toml(cls, path) -> FittedDiaphragm:
        """Read a fit file written by :meth:`to_toml` (``isodesign fit diaphragm -o``)."""
        p = Path(path)
        data = _read_toml(p, "fitted diaphragm")
        t = data.get("fitted_diaphragm")
        if not isinstance(t, dict):
            raise InputError(
                f"fitted diaphragm ({p}): no [fitted_diaphragm] table (write one with "
                "'isodesign fit diaphragm MEASURED.csv -o FILE.toml')"
            )
        keys = ("relaxation_times_s", "amplitude_range_m", "frequency_range_hz",
                "static_n_per_m", "hysteretic_n_per_m", "weights_n_per_m")  # fmt: skip
        missing = [k for k in keys if k not in t]
        if missing:
            raise InputError(f"fitted diaphragm ({p}): missing key(s) {', '.join(missing)}")
        try:
            vals = {k: np.asarray(t[k], dtype=float) for k in keys}
        except (TypeError, ValueError):
            raise InputError(f"fitted diaphragm ({p}): values must be numbers") from None
        return cls(
            relaxation_times_s=vals["relaxation_times_s"],
            static_n_per_m=vals["static_n_per_m"],
            weights_n_per_m=np.atleast_2d(vals["weights_n_per_m"]),
            hysteretic_n_per_m=vals["hysteretic_n_per_m"],
            amplitude_range_m=tuple(vals["amplitude_range_m"].tolist()),
            frequency_range_hz=tuple(vals["frequency_range_hz"].tolist()),
            source=str(p),
        )


def _toml_str(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", " ") + '"'


def _read_toml(p: Path, what: str) -> dict:
    try:
        with p.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{what}: file {p} not found") from None
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise InputError(f"{what}: cannot read {p}: {exc}") from None


#: Parameters of :class:`ViscoelasticDiaphragm` settable in a design file's ``[diaphragm]``.
VISCOELASTIC_PARAMETERS = tuple(f.name for f in dataclasses.fields(ViscoelasticDiaphragm) if f.init)


def diaphragm_from_dict(d: dict, source: str = "diaphragm"):
    """A diaphragm model from a design file's ``[diaphragm]`` table.

    ``model = "viscoelastic"`` (default) with any of
    :data:`VISCOELASTIC_PARAMETERS`; ``"none"``; ``"table:PATH.csv"`` or
    ``"fit:PATH.toml"`` (paths relative to the design file's folder when
    ``source`` is a file path).

    Parameters
    ----------
    d : dict
        The table.
    source : str
        Where it came from (a design file path makes relative paths relative to it).
    """
    if not isinstance(d, dict):
        raise InputError(f"{source}: [diaphragm] must be a table")
    model = d.get("model", "viscoelastic")
    if not isinstance(model, str):
        raise InputError(f"{source}: diaphragm.model: expected a string, got {model!r}")
    params = {k: v for k, v in d.items() if k != "model"}
    if model == "viscoelastic":
        bad = [k for k in params if k not in VISCOELASTIC_PARAMETERS]
        if bad:
            raise InputError(
                f"{source}: unknown key(s) {', '.join('diaphragm.' + k for k in bad)}; "
                f"valid: model, {', '.join(VISCOELASTIC_PARAMETERS)}"
            )
        kw = {}
        for k, v in params.items():
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise InputError(f"{source}: diaphragm.{k}: expected a number, got {v!r}")
            kw[k] = float(v)
        try:
            return ViscoelasticDiaphragm(**kw)
        except InputError as exc:
            raise InputError(f"{source}: {exc}") from None
    if params:
        raise InputError(
            f"{source}: diaphragm model {model!r} takes no parameters (got "
            f"{', '.join(params)}); parameters apply to model = 'viscoelastic'"
        )
    base = Path(source).parent if Path(source).suffix == ".toml" else None
    for prefix in ("table:", "fit:"):
        if model.startswith(prefix) and base is not None:
            path = Path(model[len(prefix) :])
            if not path.is_absolute():
                model = prefix + str(base / path)
    return diaphragm_model(model)


def _bilinear(gx, gy, v, x, y):
    """Bilinear interpolation on a rectangular grid, clamped at the edges."""
    x = np.clip(x, gx[0], gx[-1])
    y = np.clip(y, gy[0], gy[-1])
    i = np.clip(np.searchsorted(gx, x, side="right") - 1, 0, gx.size - 2)
    j = np.clip(np.searchsorted(gy, y, side="right") - 1, 0, gy.size - 2)
    tx = (x - gx[i]) / (gx[i + 1] - gx[i])
    ty = (y - gy[j]) / (gy[j + 1] - gy[j])
    return (
        v[i, j] * (1 - tx) * (1 - ty)
        + v[i + 1, j] * tx * (1 - ty)
        + v[i, j + 1] * (1 - tx) * ty
        + v[i + 1, j + 1] * tx * ty
    )


def diaphragm_model(
    spec,
) -> NoDiaphragm | ViscoelasticDiaphragm | TableDiaphragm | FittedDiaphragm | PronyDiaphragm:
    """Resolve a diaphragm model from a name, a file or a model object.

    ``"viscoelastic"`` (default parameters), ``"none"``, ``"table:PATH"`` or a
    path ending in ``.csv`` (a :class:`TableDiaphragm`), ``"fit:PATH"`` (a
    :class:`FittedDiaphragm` written by ``isodesign fit diaphragm``), a path
    ending in ``.toml`` (a fit file, or a design file with a ``[diaphragm]``
    table), a ``[diaphragm]`` table as a dict, or an instance.

    Parameters
    ----------
    spec : str, Path, dict or model
        The specification (a model instance is returned as is).
    """
    if isinstance(spec, NoDiaphragm | ViscoelasticDiaphragm | TableDiaphragm | FittedDiaphragm
                  | PronyDiaphragm):
        return spec
    if isinstance(spec, dict):
        return diaphragm_from_dict(spec)
    if callable(getattr(spec, "stiffness", None)) and callable(getattr(spec, "in_range", None)):
        return spec  # any other model object (e.g. a scaled one of isodesign.optimization)
    if spec is None or spec == "none":
        return NoDiaphragm()
    if spec == "viscoelastic":
        return ViscoelasticDiaphragm()
    if isinstance(spec, str | Path):
        s = str(spec)
        if s.startswith("table:"):
            return TableDiaphragm.from_csv(s[len("table:") :])
        if s.startswith("fit:"):
            return FittedDiaphragm.from_toml(s[len("fit:") :])
        if s.lower().endswith(".csv"):
            return TableDiaphragm.from_csv(s)
        if s.lower().endswith(".toml"):
            data = _read_toml(Path(s), "diaphragm")
            if "fitted_diaphragm" in data:
                return FittedDiaphragm.from_toml(s)
            if "diaphragm" in data:
                return diaphragm_from_dict(data["diaphragm"], s)
            raise InputError(
                f"diaphragm: {s} has neither a [fitted_diaphragm] nor a [diaphragm] table"
            )
        if s == "table":
            raise InputError("diaphragm: 'table' needs a CSV file: use 'table:PATH' or 'PATH.csv'")
        if s == "fit":
            raise InputError("diaphragm: 'fit' needs a fit file: use 'fit:PATH.toml'")
    raise InputError(
        f"diaphragm: unknown model {spec!r}; valid: {', '.join(DIAPHRAGM_SPECS.values())}, "
        "DESIGN.toml with a [diaphragm] table"
    )
