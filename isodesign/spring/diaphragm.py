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
``none`` (:class:`NoDiaphragm`)
    k_D* = 0 (the air alone).

Also, as an object only: :class:`PronyDiaphragm`, a linear (amplitude-independent)
generalized Maxwell element, the causal form the Monte Carlo verifier integrates in the
time domain (:mod:`isodesign.simulation.monte_carlo`).

The total stiffness is the parallel sum k*_{d+D} = k_d* + k_D* (Eq. 42).
"""

from __future__ import annotations

import math
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
    "NoDiaphragm",
    "PronyDiaphragm",
    "TableDiaphragm",
    "ViscoelasticDiaphragm",
    "diaphragm_model",
]

#: Diaphragm models: name -> how a user writes it (``diaphragm=...``, ``--diaphragm``).
DIAPHRAGM_SPECS = {
    "viscoelastic": "viscoelastic",
    "none": "none",
    "table": "table:PATH.csv",
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
        re = self.k_inf_n_per_m + 0.0 * omega * amplitude_m
        im = 0.0 * re
        for k, r in zip(self.branch_stiffness_n_per_m, self.branch_rate_1_per_s, strict=True):
            den = omega * omega + r * r
            re = re + k * omega * omega / den
            im = im + k * omega * r / den
        return Cx(re, im)

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


def diaphragm_model(spec):
    """Resolve a diaphragm model from a name, a CSV path or a model object.

    ``"viscoelastic"`` (default parameters), ``"none"``, ``"table:PATH"`` or a
    path ending in ``.csv`` (a :class:`TableDiaphragm`), or an instance.

    Parameters
    ----------
    spec : str, Path or model
        ``"viscoelastic"``, ``"none"`` (or None), ``"table:PATH"``, a ``.csv`` path, or
        a model instance (returned as is).
    """
    if isinstance(spec, NoDiaphragm | ViscoelasticDiaphragm | TableDiaphragm | PronyDiaphragm):
        return spec
    if spec is None or spec == "none":
        return NoDiaphragm()
    if spec == "viscoelastic":
        return ViscoelasticDiaphragm()
    if isinstance(spec, str | Path):
        s = str(spec)
        if s.startswith("table:"):
            return TableDiaphragm.from_csv(s[len("table:") :])
        if s.lower().endswith(".csv"):
            return TableDiaphragm.from_csv(s)
        if s == "table":
            raise InputError("diaphragm: 'table' needs a CSV file: use 'table:PATH' or 'PATH.csv'")
    raise InputError(
        f"diaphragm: unknown model {spec!r}; valid: {', '.join(DIAPHRAGM_SPECS.values())}"
    )
