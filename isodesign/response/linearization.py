"""Random-input linearization and the frequency quadratures of the payload response.

Everything the closure of the amplitude dependence needs that is not a solver:

* :data:`EQUIVALENT_AMPLITUDE_FACTOR`, ``A* = 3 sqrt(pi/8) sigma = 1.880 sigma``: the
  harmonic amplitude whose describing function equals the Gaussian-input (random)
  describing function of a quadratic damper (docs/physics.md, section 7).
* :func:`rayleigh_rule` and :func:`rayleigh_average`: the exact Rayleigh average of a
  harmonic describing function over the amplitude distribution of a narrow-band Gaussian
  stroke, ``k_R(sigma) = integral k*(A) A^3/(2 sigma^4) exp(-A^2/(2 sigma^2)) dA``, by a
  Gauss rule that is exact for every polynomial in ``A`` up to degree ``2n - 1``.
* :class:`ResponseGrid` (built once in NumPy by :func:`response_grid`) and the
  backend-agnostic quadratures :func:`stroke_variance` and :func:`band_mean_square`. They
  use only ``+ - * /`` on :class:`~isodesign.numerics.cplx.Cx` pairs and a weighted sum with
  precomputed NumPy weights, so the same functions evaluate NumPy arrays (the analysis
  path, :mod:`isodesign.response`) and CasADi ``SX``/``MX`` column vectors (the optimizer).

The quadratures
---------------
Frequencies ``f_j`` (Hz, strictly increasing, one evaluation of the spring each) carry:

* ``stroke_weight[j]``: trapezoid weight in ``f`` times the floor *displacement* PSD
  ``S_x = S_v / w^2`` over the whole frequency range of the floor spectrum, so that the
  stroke variance is ``sigma^2 = sum_j stroke_weight[j] |T_j - 1|^2``;
* ``band_weight[b, j]``: trapezoid weight in ``f`` within band ``b`` (``points_per_band``
  log-spaced points from the lower to the upper edge, both included) times the floor
  *velocity* PSD evaluated band-aware (a band-constant floor takes its band's own constant
  at both edges), so that the payload's band mean-square velocity is
  ``sum_j band_weight[b, j] |T_j|^2``. This is exactly the rule of
  :meth:`isodesign.floor.FloorSpectrum.band_rms` (trapezoid in ``f`` on
  :meth:`~isodesign.floor.FloorSpectrum.band_grid`): points shared by two adjacent bands,
  or by the bands and the stroke grid, are evaluated once and their weights added.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from isodesign.errors import InputError, check_choice
from isodesign.floor import FloorSpectrum
from isodesign.floor.bands import Bands, third_octave_bands
from isodesign.numerics import backend as bk
from isodesign.numerics.cplx import Cx, as_cx
from isodesign.spring.equations import tube_velocity_gain2

__all__ = [
    "EQUIVALENT_AMPLITUDE_FACTOR",
    "RAYLEIGH_NODES",
    "STROKE_POINTS_PER_THIRD_OCTAVE",
    "ResponseGrid",
    "band_margin_db",
    "band_mean_square",
    "equivalent_amplitude",
    "rayleigh_average",
    "rayleigh_rule",
    "response_grid",
    "stroke_variance",
    "stroke_weighted_sum",
    "tube_velocity_variance",
    "velocity_margin_db",
]

#: ``A* / sigma = 3 sqrt(pi/8) = 1.8800``: the harmonic amplitude whose describing function
#: equals the Gaussian-input describing function for quadratic damping
#: (docs/physics.md, section 7). The Rayleigh average of ``8 A c/(3 pi)`` is
#: ``c sqrt(8/pi) sigma`` = ``8 (A*) c/(3 pi)`` with ``A* = 3 sqrt(pi/8) sigma``; exact for
#: any describing function linear in the amplitude.
EQUIVALENT_AMPLITUDE_FACTOR = 3.0 * math.sqrt(math.pi / 8.0)

#: Default number of nodes of the Rayleigh-average Gauss rule (exact for polynomials in the
#: amplitude up to degree 31).
RAYLEIGH_NODES = 16

#: Density of the stroke-variance grid of a point-wise floor spectrum, in points per
#: one-third octave (a band-constant floor uses its own band grid instead).
STROKE_POINTS_PER_THIRD_OCTAVE = 50

_REL_TOL = 1e-9
_QUANTITY_POWER = {"displacement": -2, "velocity": 0, "acceleration": 2}


# ---------------------------------------------------------------------------
# equivalent amplitude and the Rayleigh average
# ---------------------------------------------------------------------------
def equivalent_amplitude(sigma):
    """Equivalent harmonic amplitude ``A* = EQUIVALENT_AMPLITUDE_FACTOR * sigma`` (any backend).

    Parameters
    ----------
    sigma : float, array or CasADi symbol
        RMS stroke, m.

    Returns
    -------
    float, array or CasADi symbol
        ``A*`` in m.
    """
    return EQUIVALENT_AMPLITUDE_FACTOR * sigma


def _decimal_pi(prec: int):
    """pi to ``prec`` digits with :mod:`decimal` (the recipe of the decimal docs)."""
    from decimal import Decimal, localcontext

    with localcontext() as ctx:
        ctx.prec = prec + 5
        three = Decimal(3)
        lasts, t, s, n, na, d, da = 0, three, 3, 1, 0, 0, 24
        while s != lasts:
            lasts = s
            n, na = n + na, na + 8
            d, da = d + da, da + 32
            t = (t * n) / d
            s += t
    return +s


@lru_cache(maxsize=8)
def rayleigh_rule(n: int = RAYLEIGH_NODES) -> tuple[np.ndarray, np.ndarray]:
    """Gauss rule of the Rayleigh average of a describing function.

    For a narrow-band Gaussian stroke of RMS ``sigma`` the amplitude envelope is
    Rayleigh-distributed, and the Gaussian-input describing function is the average of
    the harmonic one (docs/physics.md, section 7)::

        k_R(sigma) = integral_0^inf k*(A) A^3 / (2 sigma^4) exp(-A^2 / (2 sigma^2)) dA
                   = integral_0^inf k*(sigma sqrt(2) u) 2 u^3 exp(-u^2) du   (A = sigma sqrt(2) u)
                   ~ sum_i w_i k*(a_i sigma)

    The nodes and weights are those of the Gauss rule for the weight ``2 u^3 exp(-u^2)`` on
    ``[0, inf)`` (total mass 1), computed once by the Golub-Welsch method from the exact
    moments ``Gamma(k/2 + 2)`` in 100-digit decimal arithmetic. The rule is exact for every
    polynomial in ``A`` up to degree ``2n - 1``, odd powers included: ``k*`` linear in ``A``
    gives exactly ``3 sqrt(pi/8) sigma`` (:data:`EQUIVALENT_AMPLITUDE_FACTOR`), and the
    quadratic-damping describing function ``8 A c/(3 pi)`` gives ``c sqrt(8/pi) sigma``.
    (The generalized Gauss-Laguerre rule in ``t = u^2``, weight ``t exp(-t)``, is the same
    integral but treats ``A ~ sqrt(t)`` as non-polynomial: with 16 nodes it is off by 1e-4
    for ``k*`` linear in ``A``.)

    Parameters
    ----------
    n : int
        Number of nodes, 2 to 40.

    Returns
    -------
    amplitude_factors : ndarray, shape (n,)
        ``a_i = sqrt(2) u_i``: the node amplitudes are ``A_i = a_i sigma``.
    weights : ndarray, shape (n,)
        ``w_i > 0``, summing to 1.
    """
    from decimal import Decimal, localcontext

    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 2 <= n <= 40:
        raise InputError(f"rayleigh_nodes: expected an integer in [2, 40], got {n!r}")
    n = int(n)
    with localcontext() as ctx:
        ctx.prec = 100
        sqrt_pi = _decimal_pi(110).sqrt()

        def moment(k: int) -> Decimal:  # Gamma(k/2 + 2)
            if k % 2 == 0:
                return Decimal(math.factorial(k // 2 + 1))
            j = (k + 3) // 2  # Gamma(j + 1/2) = (2j)! sqrt(pi) / (4^j j!)
            return Decimal(math.factorial(2 * j)) * sqrt_pi / (Decimal(4**j * math.factorial(j)))

        m = [moment(k) for k in range(2 * n + 1)]
        size = n + 1
        r = [[Decimal(0)] * size for _ in range(size)]
        for i in range(size):  # Cholesky H = R^T R of the Hankel matrix H_ij = m_(i+j)
            s = m[2 * i] - sum(r[k][i] * r[k][i] for k in range(i))
            r[i][i] = s.sqrt()
            for j in range(i + 1, size):
                r[i][j] = (m[i + j] - sum(r[k][i] * r[k][j] for k in range(i))) / r[i][i]
        alpha, beta = [], []
        for j in range(n):
            a = r[j][j + 1] / r[j][j]
            if j > 0:
                a -= r[j - 1][j] / r[j - 1][j - 1]
            alpha.append(float(a))
            if j < n - 1:
                beta.append(float(r[j + 1][j + 1] / r[j][j]))
    jac = np.diag(alpha) + np.diag(beta, 1) + np.diag(beta, -1)
    u, vec = np.linalg.eigh(jac)
    w = vec[0, :] ** 2  # times the total mass m_0 = Gamma(2) = 1
    a = math.sqrt(2.0) * u
    a.flags.writeable = False
    w = w / np.sum(w)
    w.flags.writeable = False
    return a, w


def rayleigh_average(describing_function, sigma, n: int = RAYLEIGH_NODES):
    """Rayleigh average of a harmonic describing function at stroke RMS ``sigma``.

    Parameters
    ----------
    describing_function : callable
        ``A -> k*(A)`` vectorized over a trailing axis of amplitudes: it is called once
        with the array ``a_i * sigma`` of shape ``np.shape(sigma) + (n,)``.
    sigma : float or ndarray
        RMS of the (Gaussian) stroke, > 0.
    n : int
        Nodes of :func:`rayleigh_rule`.

    Returns
    -------
    ndarray or float
        ``sum_i w_i k*(a_i sigma)`` (real or complex, shape of ``sigma`` plus whatever
        leading axes ``describing_function`` returns).
    """
    a, w = rayleigh_rule(n)
    amps = np.asarray(sigma, dtype=float)[..., None] * a
    return np.asarray(describing_function(amps)) @ w


# ---------------------------------------------------------------------------
# the response grid
# ---------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class ResponseGrid:
    """Frequencies and quadrature weights of a payload response (built once, NumPy).

    Attributes
    ----------
    frequency_hz : ndarray, shape (n,)
        Strictly increasing evaluation frequencies (Hz): the union of the band grids and of
        the stroke grid, each point once.
    omega : ndarray, shape (n,)
        ``2 pi frequency_hz`` (rad/s).
    stroke_weight : ndarray, shape (n,)
        ``sigma^2 = stroke_weight @ |T - 1|^2`` (m^2): trapezoid weight in ``f`` times the
        floor displacement PSD ``S_v / w^2``, over the floor spectrum's whole range; zero at
        points used by the bands only.
    band_weight : ndarray, shape (n_bands, n)
        Payload band mean-square velocity ``band_weight @ |T|^2`` ((m/s)^2): trapezoid
        weight in ``f`` within each band times the band-aware floor velocity PSD.
    bands : Bands
        The one-third-octave bands.
    band_points : ndarray of int, shape (n_bands, points_per_band)
        Index into ``frequency_hz`` of each band-grid point (row ``b`` runs from the band's
        lower to its upper edge).
    band_psd_velocity : ndarray, shape (n_bands, points_per_band)
        Floor velocity PSD at the band-grid points, band-aware ((m/s)^2/Hz).
    floor_velocity_rms_m_s : ndarray, shape (n_bands,)
        Floor band RMS velocity, ``sqrt(band_weight @ 1)``.
    limit_velocity_m_s : ndarray or None, shape (n_bands,)
        The target curve's band RMS velocity limits (``None`` without a target).
    floor_range_hz : tuple of float
        The range of the floor spectrum covered by ``stroke_weight``.
    points_per_band : int
    floor_name, target_name : str
    """

    frequency_hz: np.ndarray
    omega: np.ndarray
    stroke_weight: np.ndarray
    band_weight: np.ndarray
    bands: Bands
    band_points: np.ndarray
    band_psd_velocity: np.ndarray
    floor_velocity_rms_m_s: np.ndarray
    limit_velocity_m_s: np.ndarray | None
    floor_range_hz: tuple[float, float]
    points_per_band: int
    floor_name: str = ""
    target_name: str = ""

    @property
    def n_points(self) -> int:
        """Number of evaluation frequencies."""
        return int(self.frequency_hz.size)

    @property
    def n_bands(self) -> int:
        """Number of bands."""
        return len(self.bands)

    def band_weight_for(self, quantity: str = "velocity") -> np.ndarray:
        """Band weights for the payload's ``displacement``, ``velocity`` or ``acceleration``.

        ``band_weight * w^p`` with ``p = -2, 0, 2``: the floor velocity PSD becomes the
        displacement or acceleration PSD point by point (``S_x = S_v/w^2``, ``S_a = w^2
        S_v``).
        """
        check_choice("quantity", quantity, tuple(_QUANTITY_POWER))
        p = _QUANTITY_POWER[quantity]
        if p == 0:
            return self.band_weight
        return self.band_weight * self.omega**p


def _trapezoid_weights(x: np.ndarray) -> np.ndarray:
    """Weights of the trapezoid rule along the last axis of ``x`` (each row increasing)."""
    dx = np.diff(x, axis=-1)
    w = np.zeros_like(x)
    w[..., :-1] += 0.5 * dx
    w[..., 1:] += 0.5 * dx
    return w


def default_bands(floor, target=None) -> Bands:
    """Bands of a response: the target's bands (or all bands) inside the floor's range.

    Parameters
    ----------
    floor : FloorSpectrum
    target : CriterionCurve, optional

    Returns
    -------
    Bands
        With a target: the target curve's bands whose edges lie within the floor spectrum's
        range. Without: the floor's own bands (band-constant) or every whole band inside its
        range (point-wise).
    """
    lo, hi = floor.f_min_hz * (1 - _REL_TOL), floor.f_max_hz * (1 + _REL_TOL)
    if target is None:
        if floor.bands is not None:
            return floor.bands
        cand = third_octave_bands(0.01, 1e5)
    else:
        cand = target.bands()
    inside = (cand.lower_hz >= lo) & (cand.upper_hz <= hi)
    if not inside.any():
        what = (
            f"target {target.name!r} ({cand.labels[0]} to {cand.labels[-1]} Hz) and "
            if (target is not None)
            else ""
        )
        raise InputError(
            f"bands: {what}the floor spectrum {floor.name!r} (defined from "
            f"{floor.f_min_hz:.4g} to {floor.f_max_hz:.4g} Hz) share no whole "
            "one-third-octave band"
        )
    return Bands(tuple(np.asarray(cand.index)[inside].tolist()))


def response_grid(floor, bands=None, *, target=None, points_per_band: int = 50) -> ResponseGrid:
    """Build the :class:`ResponseGrid` of a floor spectrum (once, in NumPy).

    Parameters
    ----------
    floor : FloorSpectrum
        The floor's velocity PSD.
    bands : Bands or tuple of float, optional
        The bands of the band response, or ``(f_min_hz, f_max_hz)`` (nominal centres).
        Default: :func:`default_bands`.
    target : CriterionCurve, optional
        The criterion whose limits are stored (``limit_velocity_m_s``).
    points_per_band : int
        Points per band, both edges included (>= 2; 50 or more recommended).

    Returns
    -------
    ResponseGrid

    Raises
    ------
    InputError
        Bands outside the floor data or outside the target curve (the message names
        ``bands``), a bad ``points_per_band``.

    Notes
    -----
    Stroke grid: a band-constant floor uses its own band grid (``points_per_band`` per
    band, band-aware PSD: exact for the band-constant PSD); a point-wise floor a log grid
    over its range with :data:`STROKE_POINTS_PER_THIRD_OCTAVE` points per one-third octave
    (at least ``points_per_band``). The stroke integral covers the floor's whole range, not
    only the bands: floor motion outside the bands still moves the spring.
    """

    if not isinstance(floor, FloorSpectrum):
        raise InputError(f"floor: expected a FloorSpectrum, got {type(floor).__name__}")
    if bands is None:
        bands = default_bands(floor, target)
    elif isinstance(bands, tuple | list) and len(bands) == 2 and not isinstance(bands, Bands):
        bands = third_octave_bands(*bands)
    g_b, s_b = floor.band_grid(bands, points_per_band)
    if floor.bands is not None:
        g_s, s_s = floor.band_grid(floor.bands, points_per_band)
    else:
        f0, f1 = floor.f_min_hz, floor.f_max_hz
        per = max(int(points_per_band), STROKE_POINTS_PER_THIRD_OCTAVE)
        n_s = max(per, math.ceil(per * math.log(f1 / f0) / math.log(10.0**0.1))) + 1
        g_s = np.geomspace(f0, f1, n_s)
        g_s[0], g_s[-1] = f0, f1
        s_s = np.asarray(floor.psd_velocity(g_s), dtype=float)
        g_s, s_s = g_s[None, :], s_s[None, :]
    freq, inv = np.unique(np.concatenate([g_b.ravel(), g_s.ravel()]), return_inverse=True)
    nb = g_b.size
    band_points = inv[:nb].reshape(g_b.shape)
    stroke_points = inv[nb:].reshape(g_s.shape)
    omega = 2.0 * math.pi * freq
    band_w = np.zeros((len(bands), freq.size))
    rows = np.broadcast_to(np.arange(len(bands))[:, None], band_points.shape)
    np.add.at(band_w, (rows, band_points), _trapezoid_weights(g_b) * s_b)
    stroke_w = np.zeros(freq.size)
    np.add.at(stroke_w, stroke_points, _trapezoid_weights(g_s) * s_s / omega[stroke_points] ** 2)
    limit = None
    if target is not None:
        limit = np.asarray(target.velocity_rms_m_s(bands), dtype=float)
    arrays = [freq, omega, stroke_w, band_w, band_points, np.asarray(s_b, dtype=float)]
    for a in arrays:
        a.flags.writeable = False
    floor_rms = np.sqrt(band_w.sum(axis=1))
    floor_rms.flags.writeable = False
    return ResponseGrid(
        frequency_hz=freq,
        omega=omega,
        stroke_weight=stroke_w,
        band_weight=band_w,
        bands=bands,
        band_points=band_points,
        band_psd_velocity=arrays[5],
        floor_velocity_rms_m_s=floor_rms,
        limit_velocity_m_s=limit,
        floor_range_hz=(float(floor.f_min_hz), float(floor.f_max_hz)),
        points_per_band=int(points_per_band),
        floor_name=floor.name,
        target_name="" if target is None else target.name,
    )


# ---------------------------------------------------------------------------
# backend-agnostic quadratures
# ---------------------------------------------------------------------------
def _weighted_sum(weights: np.ndarray, values):
    """``weights @ values`` for NumPy values, a sparse CasADi product for symbols.

    ``weights`` is a NumPy vector (n,) or matrix (m, n); ``values`` a NumPy array whose
    first axis has length n, or a CasADi column (n x 1). Returns a scalar / (m,) array, or
    a CasADi scalar / (m x 1) column.
    """
    if bk.is_casadi(values):
        import casadi as ca
        from scipy import sparse

        w2 = np.atleast_2d(weights)
        out = ca.mtimes(ca.DM(sparse.csc_matrix(w2)), values)
        return out[0, 0] if np.ndim(weights) == 1 else out
    return np.tensordot(weights, np.asarray(values), axes=(weights.ndim - 1, 0))


def stroke_variance(relative_transmissibility: Cx, grid: ResponseGrid):
    """Variance of the spring stroke, ``sigma^2 = sum_j stroke_weight[j] |T_j - 1|^2`` (m^2).

    Parameters
    ----------
    relative_transmissibility : Cx
        ``T - 1`` at ``grid.frequency_hz`` (NumPy arrays whose first axis is the grid, or
        CasADi n x 1 columns); :func:`isodesign.response.isolator.relative_transmissibility`.
    grid : ResponseGrid

    Returns
    -------
    float, ndarray or CasADi scalar
        ``sigma^2``; the RMS stroke is its square root.
    """
    return _weighted_sum(grid.stroke_weight, as_cx(relative_transmissibility).abs2())


def tube_velocity_variance(relative_transmissibility: Cx, resistance: Cx, design,
                           grid: ResponseGrid, flow: str | None = None):
    """Variance of the capillary's mean velocity, ``sigma_u^2`` ((m/s)^2), any backend.

    ``sigma_u^2 = sum_j stroke_weight[j] |T_j - 1|^2 |U/X|_j^2``: the stroke's spectrum
    times the linear tube-velocity gain :func:`~isodesign.spring.equations.tube_velocity_gain2`
    for the resistance ``C`` at the grid's frequencies (the random-input linearization's
    ``C(w; sigma_u)``), i.e. ``integral |H_u(f)|^2 S_v(f) df`` with ``H_u`` the tube velocity
    per floor velocity.

    Parameters
    ----------
    relative_transmissibility : Cx
        ``T - 1`` at ``grid.frequency_hz``.
    resistance : Cx
        ``C`` at ``grid.frequency_hz`` (Pa s/kg).
    design : SpringDesign
        The loaded design (fields may be CasADi symbols).
    grid : ResponseGrid
    flow : str, optional
        The flow model of ``resistance`` (distributed acoustics; see
        :func:`~isodesign.spring.equations.air_stiffness`).
    """
    rel = as_cx(relative_transmissibility)
    return stroke_weighted_sum(
        rel.abs2() * tube_velocity_gain2(design, grid.omega, resistance, flow), grid
    )


def stroke_weighted_sum(values, grid: ResponseGrid):
    """``sum_j stroke_weight[j] values[j]`` (any backend): the variance of a response whose
    squared gain per unit floor displacement is ``values`` (e.g. ``|T - 1|^2 |U/X|^2``).

    Parameters
    ----------
    values : array or CasADi column
        Squared gains at ``grid.frequency_hz``.
    grid : ResponseGrid

    Returns
    -------
    float or CasADi scalar
    """
    return _weighted_sum(grid.stroke_weight, values)


def band_mean_square(transmissibility: Cx, grid: ResponseGrid, quantity: str = "velocity"):
    """Payload band mean squares ``sum_j band_weight[b, j] |T_j|^2`` per band.

    Parameters
    ----------
    transmissibility : Cx
        Absolute transmissibility ``T`` at ``grid.frequency_hz`` (NumPy or CasADi column).
    grid : ResponseGrid
    quantity : {'velocity', 'displacement', 'acceleration'}
        Payload quantity ((m/s)^2, m^2 or (m/s^2)^2).

    Returns
    -------
    ndarray, shape (n_bands,), or CasADi (n_bands x 1)
        Band mean squares; the band RMS is the square root. With ``T = 1`` this is the
        floor's band mean square exactly as :meth:`FloorSpectrum.band_rms` computes it.
    """
    return _weighted_sum(grid.band_weight_for(quantity), as_cx(transmissibility).abs2())


def band_margin_db(band_mean_square_value, grid: ResponseGrid):
    """Margin per band in dB, ``10 log10(limit^2 / mean square)`` (any backend).

    Positive: below the limit. Needs a grid built with a target.

    Parameters
    ----------
    band_mean_square_value : array or CasADi column
        Payload band mean-square velocities ((m/s)^2), one per band of ``grid``.
    grid : ResponseGrid
        Built with a target (its ``limit_velocity_m_s``).

    Returns
    -------
    array or CasADi column
        Margins in dB.
    """
    if grid.limit_velocity_m_s is None:
        raise InputError("grid: built without a target; no limits to compare with")
    lim2 = grid.limit_velocity_m_s**2
    if bk.is_casadi(band_mean_square_value):
        import casadi as ca

        lim2 = ca.DM(lim2)
    return (10.0 / math.log(10.0)) * bk.log(lim2 / band_mean_square_value)


def velocity_margin_db(limit_velocity_rms_m_s, velocity_rms_m_s) -> np.ndarray:
    """Margin in dB of band RMS velocities, ``20 log10(limit / velocity)`` (NumPy).

    Positive: below the limit; ``+inf`` where the velocity is 0. The results of the
    vertical payload (:class:`.random_input.BandResponse`) and of the rigid table
    (:class:`isodesign.table.response.TableBandResponse`) both report their margins with it.

    Parameters
    ----------
    limit_velocity_rms_m_s : array_like
        The criterion's band RMS velocities (m/s).
    velocity_rms_m_s : array_like
        The response's band RMS velocities (m/s), broadcastable against the limits.

    Returns
    -------
    ndarray
        Margins in dB.
    """
    with np.errstate(divide="ignore"):
        return 20.0 * np.log10(np.asarray(limit_velocity_rms_m_s) / np.asarray(velocity_rms_m_s))
