"""The non-Gaussian tube velocity of the distortion power (docs/random-response.md 3c).

The Hermite expansion of the minor loss's residual (:func:`abs_square_hermite_coefficient`,
section 3a), the tube velocity's kurtosis to first order in it (:func:`tube_kurtosis`,
:func:`table_kurtosis`) and resummed to the unimodal bound (:func:`resummed_kurtosis`), the
generalized-Gaussian marginal of that kurtosis (:func:`generalized_gaussian_moments`), its
equivalent gain (:func:`non_gaussian_factors`, :func:`minor_loss_gain_shift`) and the
residual's Hermite coefficients as a translation process (:func:`translation_coefficients`);
the validity flag (:func:`kurtosis_flag`). NumPy.
"""

from __future__ import annotations

import functools
import math

import numpy as np

__all__ = [
    "GAUSSIAN_RESIDUAL",
    "KURTOSIS_FIRST_ORDER_VERIFIED_MIN",
    "NON_GAUSSIAN_ORDERS",
    "abs_square_hermite_coefficient",
    "generalized_gaussian_moments",
    "kurtosis_flag",
    "minor_loss_coefficient",
    "minor_loss_gain_shift",
    "non_gaussian_factors",
    "resummed_kurtosis",
    "table_kurtosis",
    "translation_coefficients",
    "tube_kurtosis",
]

#: The Hermite orders of the Gaussian residual (3 and 5: 93.6 % and 4.7 % of the residual
#: power ``(3 - 8/pi) s^4``; the orders >= 7, left out, carry the other 1.7 %).
DISTORTION_ORDERS = (3, 5)
#: The Hermite orders of the non-Gaussian residual (section 3c): its translation-process
#: expansion moves power from order 3 to the higher ones (orders 3-11 hold 95-99 % of it).
NON_GAUSSIAN_ORDERS = (3, 5, 7, 9, 11)


def _abs_moment(m: int) -> float:
    """``E|x|^m`` of a standard Gaussian."""
    return 2.0 ** (m / 2) * math.gamma((m + 1) / 2) / math.sqrt(math.pi)


@functools.lru_cache(maxsize=64)
def abs_square_hermite_coefficient(k: int) -> float:
    """``c_k = E[|x| x He_k(x)] / k!`` for a standard Gaussian ``x`` (0 for even ``k``).

    Parameters
    ----------
    k : int
        The order (>= 1).

    Returns
    -------
    float
        ``c_1 = sqrt(8/pi)`` (the closure's gain), ``c_3 = sqrt(2/pi)/3``, ...
    """
    if k % 2 == 0:
        return 0.0
    coef = np.polynomial.hermite_e.herme2poly([0.0] * k + [1.0])  # He_k in powers of x
    # E[|x| x x^j] = E|x|^(j+2) for odd j (0 for even j)
    e = sum(cj * _abs_moment(j + 2) for j, cj in enumerate(coef) if j % 2 == 1)
    return e / math.factorial(k)


_WEIGHTS = {k: math.factorial(k) * abs_square_hermite_coefficient(k) ** 2
            for k in DISTORTION_ORDERS}

#: The lowest first-order kurtosis estimate (:func:`tube_kurtosis`) at which the non-Gaussian
#: distortion is verified against the Monte Carlo (the 4-isolator table on 4x VC-A, first
#: order 1.09-1.20, resummed 2.05-2.07, simulated 1.89-2.02: every band within 0.25 dB;
#: docs/random-response.md 3c). Below it the first-order term is larger than the whole
#: correction it resums, so the expansion's next terms matter: flagged.
KURTOSIS_FIRST_ORDER_VERIFIED_MIN = 1.0
#: The smallest kurtosis of a symmetric unimodal density (the uniform one, Khintchine).
UNIMODAL_KURTOSIS_MIN = 1.8
#: The Gaussian residual's variance per ``s^4``: ``E x^4 - c_1^2 = 3 - 8/pi``.
GAUSSIAN_RESIDUAL = 3.0 - 8.0 / math.pi


def _gg_log_kurtosis(t):
    """``ln kurtosis`` of the generalized Gaussian of shape ``beta = e^t`` and its derivative
    in ``t`` (arrays)."""
    from scipy.special import digamma, gammaln

    b = np.exp(t)
    val = gammaln(5.0 / b) + gammaln(1.0 / b) - 2.0 * gammaln(3.0 / b)
    der = (-5.0 * digamma(5.0 / b) - digamma(1.0 / b) + 6.0 * digamma(3.0 / b)) / b
    return val, der


_GG_T = np.linspace(math.log(2.0), math.log(1e4), 4001)  # ln beta
_GG_LOGK = None


def generalized_gaussian_moments(kurtosis):
    """The unit-variance generalized Gaussian ``p(x) ~ exp(-|x/a|^beta)`` of a kurtosis.

    Parameters
    ----------
    kurtosis : float or ndarray
        ``E x^4`` (clipped to ``(1.8, 3]``: ``beta`` from 2, the Gaussian, to infinity, the
        uniform).

    Returns
    -------
    beta : float or ndarray
        The shape (Newton's method in ``ln beta`` from a tabulated start, to 1e-12).
    gain : float or ndarray
        ``E|x|^3`` (the minor loss's equivalent gain; ``sqrt(8/pi)`` at ``beta = 2``).
    residual : float or ndarray
        ``E x^4 - (E|x|^3)^2``: the residual's variance per ``s^4`` (``3 - 8/pi`` at 2).
    """
    from scipy.special import gammaln

    global _GG_LOGK
    if _GG_LOGK is None:
        _GG_LOGK = _gg_log_kurtosis(_GG_T)[0]  # decreasing in t
    kap = np.clip(np.asarray(kurtosis, dtype=float), UNIMODAL_KURTOSIS_MIN + 1e-6, 3.0)
    target = np.log(kap)
    t = np.interp(-target, -_GG_LOGK, _GG_T)
    for _ in range(2):  # Newton from the table's interpolation (to rounding)
        val, der = _gg_log_kurtosis(t)
        t = np.where(kap >= 3.0, math.log(2.0), np.clip(t - (val - target) / der,
                                                         _GG_T[0], _GG_T[-1]))
    b = np.exp(t)
    gain = np.exp(gammaln(4.0 / b) + 0.5 * gammaln(1.0 / b) - 1.5 * gammaln(3.0 / b))
    kur = np.exp(_gg_log_kurtosis(t)[0])
    res = kur - gain * gain
    if np.ndim(kurtosis) == 0:
        return float(b), float(gain), float(res)
    return b, gain, res


_GH_Z, _GH_W = np.polynomial.hermite_e.hermegauss(96)
_GH_W = _GH_W / _GH_W.sum()
# the integrands are even (G and He_k odd): the positive nodes, their weights doubled
_GH_ZP, _GH_WP = _GH_Z[48:], 2.0 * _GH_W[48:]
_HE_AT_NODES: dict = {}


def translation_coefficients(kurtosis, orders=NON_GAUSSIAN_ORDERS, beta=None):
    """The Hermite coefficients of the residual of a non-Gaussian tube velocity.

    The tube velocity is taken as a translation process, ``x = F(z)``, ``z`` standard
    Gaussian and ``F`` the monotone map onto the unit-variance generalized Gaussian of the
    given kurtosis (:func:`generalized_gaussian_moments`), so that the residual
    ``G(z) = |F(z)| F(z) - E|x|^3 F(z)`` is a function of a Gaussian process and Mehler's
    theorem applies to it as to the Gaussian residual (docs/random-response.md 3c):
    ``a_k = E[G(z) He_k(z)] / k!`` (Gauss-Hermite, 96 nodes), the residual's autocovariance
    ``sum_k k! a_k^2 rho_z^k`` and the cross-covariance of two such residuals
    ``sum_k k! a_k,i a_k,j rho_ij^k``. At kurtosis 3, ``F`` is the identity and ``a_k = c_k``.

    Parameters
    ----------
    kurtosis : float or ndarray (n,)
        The tube velocities' kurtosis.
    orders : tuple of int
        The odd orders ``k``.
    beta : float or ndarray, optional
        The generalized Gaussian's shape at ``kurtosis``, if known
        (:func:`generalized_gaussian_moments`).

    Returns
    -------
    ndarray (n, len(orders)) or (len(orders),)
        ``a_k`` (signed).
    """
    from numpy.polynomial.hermite_e import hermeval
    from scipy.special import gammainccinv, gammaln, ndtr

    kap = np.atleast_1d(np.asarray(kurtosis, dtype=float))
    if beta is None:
        beta = generalized_gaussian_moments(kap)[0]
    beta = np.atleast_1d(np.asarray(beta, dtype=float))[:, None]
    # F(z), z > 0: the generalized Gaussian's quantile at the standard normal's probability,
    # by its upper tail (P(X > x) = Q(1/beta, (x/a)^beta) / 2); F is odd
    x = np.exp(0.5 * (gammaln(1.0 / beta) - gammaln(3.0 / beta))) * gammainccinv(
        1.0 / beta, 2.0 * ndtr(-_GH_ZP)[None, :]) ** (1.0 / beta)
    x = x / np.sqrt(np.sum(_GH_WP * x * x, axis=1, keepdims=True))  # unit variance
    gain = np.sum(_GH_WP * x ** 3, axis=1, keepdims=True)
    g = x * x - gain * x
    if orders not in _HE_AT_NODES:
        _HE_AT_NODES[orders] = np.array([hermeval(_GH_ZP, [0.0] * k + [1.0])
                                         / math.factorial(k) for k in orders])
    out = (_GH_WP * g) @ _HE_AT_NODES[orders].T
    gauss = kap >= 3.0
    if np.any(gauss):
        out[gauss] = [abs_square_hermite_coefficient(k) for k in orders]
    return out if np.ndim(kurtosis) else out[0]


def resummed_kurtosis(first_order):
    """The tube velocity's kurtosis from its first-order estimate ``3 - delta``: the
    exponential that has the first order's slope at ``delta = 0`` and the unimodal bound
    1.8 as ``delta -> infinity``, ``1.8 + 1.2 exp(-delta / 1.2)`` (docs/random-response.md,
    section 3c).

    Parameters
    ----------
    first_order : float or ndarray
        The first-order kurtosis (:func:`tube_kurtosis`; above 3 it is taken as 3).

    Returns
    -------
    float or ndarray
        The kurtosis, in ``(1.8, 3]``.
    """
    span = 3.0 - UNIMODAL_KURTOSIS_MIN
    out = UNIMODAL_KURTOSIS_MIN + span * np.exp(np.minimum(0.0, np.asarray(first_order,
                                                                        dtype=float) - 3.0)
                                                / span)
    return float(out) if np.ndim(first_order) == 0 else out


def minor_loss_coefficient(design, flow: str):
    """``K rho / 2`` (Pa s^2/m^2), the quadratic drop's coefficient whose residual the
    distortion carries; 0 for ``flow='poiseuille'``, which has no minor loss (its closure
    linearizes none, section 2 of docs/random-response.md).

    Parameters
    ----------
    design : SpringDesign
        The loaded design.
    flow : str
        The flow model.

    Returns
    -------
    float
        The coefficient.
    """
    return 0.0 if flow == "poiseuille" else 0.5 * design.minor_loss * design.density_kg_m3


def minor_loss_gain_shift(design, sigma_u, gain_ratio):
    """The change of the minor loss's equivalent resistance when its Gaussian gain
    ``sqrt(8/pi)`` is scaled by ``gain_ratio`` (docs/random-response.md 3c). Any backend.

    Parameters
    ----------
    design : SpringDesign
        The loaded design (fields may be CasADi symbols).
    sigma_u : float, array or CasADi symbol
        The tube velocity's RMS, m/s.
    gain_ratio : float
        ``E|x|^3 / sqrt(8/pi)``.

    Returns
    -------
    float, array or CasADi symbol
        ``K (gain_ratio - 1) sqrt(8/pi) sigma_u / (2 A_c)``, Pa s/kg.
    """
    c1 = math.sqrt(8.0 / math.pi)
    return design.minor_loss * (gain_ratio - 1.0) * c1 * sigma_u / (2.0 * design.capillary_area_m2)


def tube_kurtosis(a3, s, h_ue, p3):
    """The tube velocity's kurtosis to first order in the residual.

    ``u = u_L + u_e``, ``u_L`` Gaussian of RMS ``s``, ``u_e`` the response to the residual
    ``e = A He_3(x) + ...`` (``A = (K rho/2) s^2 c_3``): by Mehler,
    ``E[u_L^3 u_e] = 6 s^3 A sum_f Re H_ue(f) P_3(f)``, so ``E u^4 / s^4 = 3 + (24 A/s) sum_f
    Re H_ue P_3`` (docs/random-response.md, section 3c).

    Parameters
    ----------
    a3 : float
        ``A``, Pa.
    s : float
        ``sigma_u``, m/s.
    h_ue : complex ndarray
        The tube velocity per unit source at the bins (groups), (m/s)/Pa.
    p3 : ndarray
        The normalized one-sided spectrum of ``rho_u^3`` on the same bins.

    Returns
    -------
    float
        The first-order kurtosis (below 3: the residual opposes the tube's large velocities).
    """
    return 3.0 + 24.0 * a3 / s * float(np.sum(np.real(h_ue) * p3))


def non_gaussian_factors(kurtosis_first_order):
    """``(kurtosis, gain_ratio, residual_ratio)`` from the first-order kurtosis: the resummed
    kurtosis (:func:`resummed_kurtosis`), and the minor loss's equivalent gain ``E|x|^3`` and
    the residual's variance ``E x^4 - (E|x|^3)^2`` of the generalized Gaussian of that
    kurtosis over the Gaussian ones (docs/random-response.md, section 3c).

    Parameters
    ----------
    kurtosis_first_order : float or ndarray
        :func:`tube_kurtosis`'s value (per isolator).

    Returns
    -------
    kurtosis, gain_ratio, residual_ratio, beta : float or ndarray
        The resummed kurtosis, ``E|x|^3 / sqrt(8/pi)``, ``(kurtosis - (E|x|^3)^2) /
        (3 - 8/pi)`` and the generalized Gaussian's shape.
    """
    kurt = resummed_kurtosis(kurtosis_first_order)
    beta, gain, res = generalized_gaussian_moments(kurt)
    return kurt, gain / math.sqrt(8.0 / math.pi), res / GAUSSIAN_RESIDUAL, beta


def kurtosis_flag(first_order, kurtosis, where: str = "") -> list[str]:
    """The validity flag of the non-Gaussian distortion: a first-order kurtosis estimate below
    :data:`KURTOSIS_FIRST_ORDER_VERIFIED_MIN` (the expansion's next terms matter there).

    Parameters
    ----------
    first_order, kurtosis : float or ndarray
        The first-order and the resummed kurtosis (per isolator).
    where : str
        What the values belong to ("isolator " for a table).

    Returns
    -------
    list of str
        One line, or none.
    """
    k1 = np.atleast_1d(np.asarray(first_order, dtype=float))
    k = np.atleast_1d(np.asarray(kurtosis, dtype=float))
    low = np.flatnonzero(k1 < KURTOSIS_FIRST_ORDER_VERIFIED_MIN)
    if low.size == 0:
        return []
    i = low[np.argmin(k1[low])]
    who = f" ({where}{', '.join(str(j + 1) for j in low)})" if where else ""
    return [f"distortion: the tube velocity's kurtosis to first order is {k1[i]:.2f} "
            f"(resummed {k[i]:.2f}){who}, below {KURTOSIS_FIRST_ORDER_VERIFIED_MIN:g} where "
            "the non-Gaussian distortion is verified against the Monte Carlo (0.25 dB): the "
            "tube flow is strongly quadratic, the expansion's next terms matter and the band "
            "response may be off by more than 0.3 dB"]


def table_kurtosis(p3ij, ut, amp, s, iu, ju, on: bool = True):
    """Per isolator of a table: ``(first-order kurtosis, kurtosis, gain_ratio,
    residual_ratio, beta)`` (arrays (n,); :func:`non_gaussian_factors`).

    ``E[u_L,i^3 u_e,i] = 6 s_i^3 sum_j A_j Re sum_f P3_ij conj(H_ij)`` (Mehler, the residual
    ``e_j = A_j He_3(x_j) + ...``, ``A_j = (K rho_j/2) s_j^2 c_3``, ``H_ij`` isolator ``i``'s
    tube velocity per unit source ``j``, ``P3_ij`` the normalized one-sided cross-spectrum of
    ``rho_ij^3``), so ``kurtosis_i = 3 + (24 / s_i) sum_j A_j Re sum_f P3_ij conj(H_ij)``:
    :func:`tube_kurtosis` with the cross terms.

    Parameters
    ----------
    p3ij : complex ndarray (f, m)
        ``P3`` of the pairs ``(iu, ju)`` (upper triangle) on the bins.
    ut : complex ndarray (f, n, n)
        ``H_ij`` on the same bins.
    amp : ndarray (n,)
        ``(K rho_i / 2) s_i^2``, Pa.
    s : ndarray (n,)
        The tube velocities' RMS, m/s.
    iu, ju : ndarray
        The pairs' indices.
    on : bool
        The non-Gaussian correction (False: the first-order kurtosis only, ratios 1).
    """
    n = s.size
    p3 = np.empty((p3ij.shape[0], n, n), dtype=complex)
    p3[:, iu, ju] = p3ij
    p3[:, ju, iu] = np.conj(p3ij)
    a3 = amp * abs_square_hermite_coefficient(3)
    corr = np.real(np.einsum("fij,fij->ij", p3, np.conj(ut)))
    kurt1 = 3.0 + 24.0 / s * (corr @ a3)
    ones = np.ones(n)
    if not on:
        return kurt1, 3.0 * ones, ones, ones, 2.0 * ones
    return (kurt1, *non_gaussian_factors(kurt1))
