"""The distortion power the statistical linearization leaves out (NumPy).

The statistical closure replaces the tube's quadratic minor-loss drop ``(K rho / 2) |u| u``
by its Gaussian-equivalent linear term ``(K rho / 2) sqrt(8/pi) s u`` (``s = sigma_u``). For a
Gaussian ``u`` the rest has a computable spectrum (``docs/random-response.md``, section 3a):
with ``x = u / s`` and the Hermite expansion ``|x| x = sum_k c_k He_k(x)`` (odd ``k``,
``c_k = E[|x| x He_k(x)] / k!``),

    R_e(tau) = (K rho / 2)^2 s^4 sum_{k >= 3} k! c_k^2 rho_u(tau)^k,

``rho_u`` the tube velocity's normalized autocorrelation: the residual is uncorrelated with
``u`` (so with every input: its cross-spectrum is zero by construction) and its spectrum is the
``k``-fold self-convolution of the tube velocity's normalized spectrum, weighted by
``k! c_k^2``. It is carried through the linear system as a pressure-drop source in the tube.

The tube velocity is not Gaussian where its law is strongly quadratic (section 3c): its
kurtosis to first order in the residual (:func:`tube_kurtosis`), resummed to the unimodal
bound (:func:`resummed_kurtosis`), gives the generalized-Gaussian marginal at which the
minor loss's equivalent gain is evaluated (:func:`non_gaussian_factors`) and, the velocity
taken as a translation of a Gaussian process onto that marginal, the residual's Hermite
weights (:func:`translation_coefficients`, orders 3-11, :class:`PairTransform`); a
first-order kurtosis below the verified range is flagged (:func:`kurtosis_flag`).

Here the tube velocity's spectrum is the line spectrum of the response grid (the power of each
grid point at its frequency), shared linearly between the two neighbouring bins of a uniform
two-sided grid, the convolutions are taken by FFT, and the source's response is evaluated on
groups of bins (:func:`bin_groups`), a group straddling a band edge shared by its overlap
(:func:`band_fractions`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from isodesign.response.non_gaussian import (  # noqa: F401  (re-exported)
    _WEIGHTS,
    DISTORTION_ORDERS,
    GAUSSIAN_RESIDUAL,
    KURTOSIS_FIRST_ORDER_VERIFIED_MIN,
    NON_GAUSSIAN_ORDERS,
    UNIMODAL_KURTOSIS_MIN,
    abs_square_hermite_coefficient,
    generalized_gaussian_moments,
    kurtosis_flag,
    minor_loss_coefficient,
    minor_loss_gain_shift,
    non_gaussian_factors,
    resummed_kurtosis,
    table_kurtosis,
    translation_coefficients,
    tube_kurtosis,
)

__all__ = [
    "DISTORTION_ORDERS",
    "DistortionPower",
    "PairTransform",
    "abs_square_hermite_coefficient",
    "bin_groups",
    "cross_convolutions",
    "distortion_power",
    "generalized_gaussian_moments",
    "kurtosis_flag",
    "non_gaussian_factors",
    "resummed_kurtosis",
    "source_network",
    "table_kurtosis",
    "translation_coefficients",
    "tube_kurtosis",
]

#: The order whose convolution the FFT period of :class:`PairTransform` holds without
#: aliasing (the higher orders' spectra alias by their negligible mass beyond it).
PERIOD_ORDER = 5
#: Bin width of the convolution grid, Hz.
DISTORTION_BIN_HZ = 0.05
#: Bins merge into groups no wider than this fraction of their frequency (within one band)
#: for the response to the sources: the sources' power is summed over a group exactly, the
#: response evaluated once at its mean frequency. Below ``DISTORTION_BIN_HZ /
#: DISTORTION_GROUP_REL`` (5 Hz) every bin is its own group. Against every bin alone (0, the
#: reference) the distortion's added variances and band mean squares agree within 1e-3
#: (``tests/response/test_distortion.py``; measured 4e-4 on the built-in table).
DISTORTION_GROUP_REL = 0.01
#: The distortion's response is evaluated up to this multiple of the highest frequency of the
#: tube velocity's spectrum (the odd orders spread its power to 3 and 5 times that).
DISTORTION_RANGE_FACTOR = 1.5
#: The closure before the distortion is evaluated (at its state) is solved to this tolerance
#: on ``ln sigma`` only (the distortion's bin groups hold 1e-3 of it): the closure with the
#: distortion, the one reported, to the caller's.
DISTORTION_FIRST_RTOL = 1e-5


@dataclass(frozen=True)
class DistortionPower:
    """The residual's power carried through the system (one isolator's source).

    Attributes
    ----------
    frequency_hz : ndarray
        The bin groups' mean frequencies (one-sided; :func:`bin_groups`).
    source_power : ndarray
        Power of the pressure-drop source per bin group, Pa^2.
    stroke_variance : float
        Added stroke variance, m^2.
    tube_velocity_variance : float
        Added tube velocity variance, (m/s)^2.
    tube_power : ndarray
        The added tube velocity power per bin, (m/s)^2 (its line spectrum).
    payload_velocity_power : ndarray
        The added payload velocity power per bin, (m/s)^2.
    kurtosis_first_order : float
        The tube velocity's kurtosis to first order in the residual (3: Gaussian).
    kurtosis : float
        Its resummed value (:func:`resummed_kurtosis`), the non-Gaussian correction's.
    gain_ratio : float
        The minor loss's equivalent gain at that kurtosis over the Gaussian ``sqrt(8/pi)``.
    residual_ratio : float
        The residual's variance carried (the translation process's weights,
        :func:`translation_coefficients`) over the Gaussian one (orders 3 and 5).
    extent_hz : tuple of ndarray, optional
        The groups' ``(lower, upper)`` frequency extents (:func:`group_extents`).
    """

    frequency_hz: np.ndarray
    source_power: np.ndarray
    stroke_variance: float
    tube_velocity_variance: float
    tube_power: np.ndarray
    payload_velocity_power: np.ndarray
    kurtosis_first_order: float = 3.0
    kurtosis: float = 3.0
    gain_ratio: float = 1.0
    residual_ratio: float = 1.0
    extent_hz: tuple | None = None

    def band_mean_square(self, lower_hz, upper_hz, power: int = 0) -> np.ndarray:
        """The added payload band mean squares (``power``: -2 displacement, 0 velocity, 2
        acceleration); a group straddling a band edge shared by its overlap
        (:func:`band_fractions`)."""
        f = self.frequency_hz
        w = (2.0 * math.pi * f) ** power
        if self.extent_hz is None:
            lo_g, hi_g = f, np.nextafter(f, np.inf)  # every group at its frequency
        else:
            lo_g, hi_g = self.extent_hz
        return (self.payload_velocity_power * w) @ band_fractions(lo_g, hi_g, lower_hz,
                                                                  upper_hz)


def _bins(freq_hz, weights, bin_hz: float):
    """Each line's weight shared between its two neighbouring bins in proportion to its
    distance (linear, "cloud in cell"): ``(index, weight)``, twice as many. It keeps every
    line's frequency as the mean of its two parts, so the spectra's convolutions keep their
    mean frequencies and the grid's error is of second order in the bin width
    (docs/random-response.md 3a; rounding to the nearest bin moved a line by up to half a
    bin, an error of first order)."""
    r = np.asarray(freq_hz, dtype=float) / bin_hz
    i0 = np.floor(r).astype(int)
    a = (r - i0).reshape(r.shape + (1,) * (np.ndim(weights) - 1))
    w = np.asarray(weights)
    return np.concatenate([i0, i0 + 1]), np.concatenate([(1.0 - a) * w, a * w])


def _odd_orders(hf, kmax: int):
    """``sum_k w_k hf^k`` over the odd orders ``k = 3 .. kmax`` with a Hermite weight
    (:data:`_WEIGHTS`): the residual's spectrum in the transform domain, where the
    ``k``-fold self-convolution of the spectrum is the ``k``-th power of its transform."""
    h2 = hf * hf
    # Horner in h2: hf h2 (w_3 + h2 (w_5 + ...)), in place
    ks = range(3, kmax + 1, 2)
    spec = np.full_like(h2, _WEIGHTS.get(ks[-1], 0.0))
    for k in reversed(ks[:-1]):
        spec *= h2
        spec += _WEIGHTS.get(k, 0.0)
    spec *= h2
    spec *= hf
    return spec


def normalized_convolutions(freq_hz, power, bin_hz: float = DISTORTION_BIN_HZ,
                            keep_hz: float | None = None, third: bool = False,
                            orders: tuple | None = None):
    """``sum_k k! c_k^2 (P * ... * P)_k`` of a normalized one-sided line spectrum, binned.

    Parameters
    ----------
    freq_hz, power : ndarray
        Line frequencies (> 0) and powers (summing to 1).
    bin_hz : float
        Bin width.
    keep_hz : float, optional
        Return the bins up to this frequency only (and one more): the FFT period is then
        only as long as they need to be free of aliasing (``n > kmax imax + keep``, the
        convolution spanning ``+-kmax imax`` bins), the same numbers to rounding. Default:
        every bin, to ``kmax`` times the highest line.
    third : bool
        Also return the normalized spectrum of ``rho_u^3`` alone (weight 1), ``p3_bins``.
    orders : tuple of int, optional
        Instead, return the normalized spectrum of ``rho_u^k`` for each ``k`` (weight 1),
        ``(f_bins, spectra (len(orders), bins))``, from the same transform.

    Returns
    -------
    f_bins : ndarray
        One-sided bin centres (> 0).
    p_bins : ndarray
        The residual's normalized power per bin (summing to ``sum_k k! c_k^2`` less what falls
        in the zero bin).
    """
    from scipy.fft import irfft, next_fast_len, rfft

    kmax = max(orders) if orders else max(DISTORTION_ORDERS)
    idx, power = _bins(freq_hz, power, bin_hz)
    imax = int(idx.max())
    top = kmax * imax
    if keep_hz is not None:
        top = min(top, math.ceil(keep_hz / bin_hz) + 1)
    n = next_fast_len(max(2 * imax + 2, kmax * imax + top + 1), real=True)
    h = np.bincount(np.concatenate([idx % n, (-idx) % n]),
                    weights=np.concatenate([0.5 * power, 0.5 * power]), minlength=n)
    hf = rfft(h)
    if orders:  # each order alone (weight 1), in one batched transform
        spec = np.stack([hf ** k for k in orders])
        conv = irfft(spec, n, axis=-1)
        pos = conv[:, 1:top + 1] + conv[:, n - top:][:, ::-1]
        return bin_hz * np.arange(1, top + 1), pos
    spec = _odd_orders(hf, kmax)
    if third:  # the third order alone too (the first-order kurtosis), in the same transform
        spec = np.stack([spec, hf * hf * hf])
    conv = irfft(spec, n, axis=-1)
    pos = conv[..., 1:top + 1] + conv[..., n - top:][..., ::-1]
    f_bins = bin_hz * np.arange(1, top + 1)
    if third:
        return f_bins, np.clip(pos[0], 0.0, None), pos[1]
    return f_bins, np.clip(pos, 0.0, None)


def source_gains(design, omega, c, k, mass_kg, flow):
    """Per unit pressure-drop source in the tube: ``(|X|^2, |U|^2)`` at ``omega``.

    The source ``dp`` (a drop along the tube, like its friction) at the tube's inlet adds
    ``dp / D1`` to the piston pressure (``D1 = C_t Z3 + ch_t``, the network of
    ``docs/acoustics.md`` section 3; ``1 + j w C_t Z3`` lumped), i.e. the force
    ``A_p dp / D1``; the payload (mass per isolator ``m``, floor held) moves by
    ``X = -A_p dp / (D1 (k - m w^2))``, and the tube's volume velocity is
    ``Q1 = (j w A_p X - C_t dp) / D1``, ``Q2 = Q1 / den2``, ``U^2 = (|Q1|^2 + |Q2|^2)/(2 A_c^2)``.

    Parameters
    ----------
    design : SpringDesign
        The loaded design.
    omega : ndarray
        Angular frequency, rad/s.
    c : complex ndarray
        The closure's resistance ``C`` at ``omega``, Pa s/kg.
    k : complex ndarray
        The spring's stiffness at ``omega`` (air and diaphragm), N/m.
    mass_kg : float
        Payload mass per isolator.
    flow : str
        The flow model.

    Returns
    -------
    tuple of ndarray
        ``|X/dp|^2`` (m^2/Pa^2) and ``|U/dp|^2`` ((m/s)^2/Pa^2).
    """
    w = np.asarray(omega, dtype=float)
    force_per_dp, u_per_x, u_per_dp, ends = source_network(design, w, c, flow)
    x = -force_per_dp / (k - mass_kg * w * w)
    return np.abs(x) ** 2, np.abs(u_per_x * x + u_per_dp) ** 2 * ends


def distortion_power(design, flow, freq_hz, tube_power, state_at, mass_kg,
                     iterations: int = 1, bin_hz: float = DISTORTION_BIN_HZ,
                     edges_hz=(), group_rel: float = DISTORTION_GROUP_REL,
                     non_gaussian: bool = True) -> DistortionPower:
    """The minor loss's distortion power through the system, self-consistently.

    Parameters
    ----------
    design : SpringDesign
        The loaded design.
    flow : str
        The flow model.
    freq_hz, tube_power : ndarray
        The linearized tube velocity's line spectrum on the response grid: each grid point's
        share of ``sigma_u^2`` ((m/s)^2).
    state_at : callable
        ``omega -> (k, C)``, complex arrays: the closure's spring at other frequencies.
    mass_kg : float
        Payload mass per isolator.
    iterations : int
        Passes of the self-consistency (the distortion's own tube velocity added to the
        spectrum it is computed from).
    bin_hz : float
        Bin width of the convolutions.
    edges_hz : sequence of float
        The band edges: no bin group spans one (:func:`bin_groups`).
    group_rel : float
        Bin groups' width relative to their frequency (0: every bin alone).
    non_gaussian : bool
        Scale the residual's power to the tube velocity's predicted kurtosis
        (:func:`tube_kurtosis`, docs/random-response.md section 3c; False: Gaussian).

    Returns
    -------
    DistortionPower
        On the bin groups (``frequency_hz`` their mean frequencies, the powers summed).
    """
    coeff = minor_loss_coefficient(design, flow)
    f_lines = np.asarray(freq_hz, dtype=float)
    p_lines = np.asarray(tube_power, dtype=float)
    keep = p_lines > 0
    f_lines, p_lines = f_lines[keep], p_lines[keep]
    added_u = f_bins = gains = None
    for _ in range(max(1, int(iterations))):
        if added_u is None:
            f_all, p_all = f_lines, p_lines
        else:  # the distortion's own tube velocity, within the lines' range
            inside = f_bins <= f_lines.max()
            f_all = np.concatenate([f_lines, f_bins[inside]])
            p_all = np.concatenate([p_lines, added_u[inside]])
        s2 = float(np.sum(p_all))
        orders = NON_GAUSSIAN_ORDERS if non_gaussian else DISTORTION_ORDERS
        tr = PairTransform(f_all, (p_all / s2)[:, None], bin_hz)
        unit = np.eye(len(orders))[0]
        p3 = tr.spectra(unit, orders)[:, 0].real
        f_bins = tr.f_bins
        # the response above the lines' range (the payload bands, the stroke and the tube
        # fall off there) is left out: keep the bins up to DISTORTION_RANGE_FACTOR f_max
        top = f_bins <= DISTORTION_RANGE_FACTOR * f_lines.max()
        f_bins, p3 = f_bins[top], p3[top]
        # the source's power summed over bin groups, its response once per group
        f_edge = f_bins
        starts, f_bins = bin_groups(f_bins, edges_hz, group_rel)
        extent = group_extents(f_edge, starts, bin_hz)
        p3 = np.add.reduceat(p3, starts)
        if gains is None or gains[0].size != f_bins.size:
            w = 2.0 * math.pi * f_bins
            k, c = state_at(w)
            x_dp, u_dp, ends = source_response(design, w, c, k, mass_kg, flow)
            gains = (np.abs(x_dp) ** 2, np.abs(u_dp) ** 2 * ends, u_dp)
        a3 = coeff * s2 * abs_square_hermite_coefficient(3)
        kurt1 = tube_kurtosis(a3, math.sqrt(s2), gains[2], p3)
        kurt, gain_ratio, beta = 3.0, 1.0, 2.0
        if non_gaussian:
            kurt, gain_ratio, _, beta = non_gaussian_factors(kurt1)
        a_k = translation_coefficients(kurt, orders, beta)
        weights = np.array([math.factorial(k) for k in orders]) * a_k * a_k
        res_ratio = float(weights.sum()) / sum(_WEIGHTS.values())
        shape = np.add.reduceat(tr.spectra(weights, orders)[:, 0].real[top], starts)
        src = coeff * coeff * s2 * s2 * np.clip(shape, 0.0, None)
        added_u = src * gains[1]
    w = 2.0 * math.pi * f_bins
    return DistortionPower(
        frequency_hz=f_bins, source_power=src, stroke_variance=float(np.sum(src * gains[0])),
        tube_velocity_variance=float(np.sum(added_u)), tube_power=added_u,
        payload_velocity_power=src * gains[0] * w * w, kurtosis_first_order=kurt1,
        kurtosis=kurt, gain_ratio=gain_ratio, residual_ratio=res_ratio, extent_hz=extent,
    )


def source_response(design, omega, c, k, mass_kg, flow):
    """Per unit pressure-drop source in the tube, complex: ``(X, U1, ends)``
    (:func:`source_gains` before the squares).

    Parameters
    ----------
    design, omega, c, k, mass_kg, flow
        As :func:`source_gains`.

    Returns
    -------
    tuple
        ``X/dp`` (m/Pa), ``U1/dp`` ((m/s)/Pa) complex, and ``ends`` (:func:`source_network`).
    """
    w = np.asarray(omega, dtype=float)
    force_per_dp, u_per_x, u_per_dp, ends = source_network(design, w, c, flow)
    x = -force_per_dp / (k - mass_kg * w * w)
    return x, u_per_x * x + u_per_dp, ends


def source_network(design, omega, c, flow):
    """The tube's network seen by a pressure-drop source and by the stroke (complex).

    The parts of :func:`source_gains` before the payload is attached: with the stroke ``X``
    (compression) imposed and a source ``dp`` in the tube, the piston's force is
    ``k X + A_p dp / D1`` and the tube's inlet velocity ``U1 = (j w A_p X - C_t dp)/(D1 A_c)``.

    Parameters
    ----------
    design : SpringDesign
        The loaded design.
    omega : ndarray
        Angular frequency, rad/s.
    c : complex ndarray
        The closure's resistance ``C`` at ``omega``.
    flow : str
        The flow model.

    Returns
    -------
    force_per_dp : complex ndarray
        ``A_p / D1`` (m^2).
    u_per_x : complex ndarray
        ``j w A_p / (D1 A_c)`` (1/s).
    u_per_dp : complex ndarray
        ``-C_t / (D1 A_c)`` ((m/s)/Pa).
    ends : ndarray
        ``(1 + 1/|den2|^2)/2``: the tube's mean square velocity over its two ends per
        ``|U1|^2`` (1 for the lumped model).
    """
    from isodesign.numerics.cplx import Cx
    from isodesign.spring.acoustics import acoustic_network

    d = design
    w = np.asarray(omega, dtype=float)
    a_p, a_c = d.piston_area_m2, d.capillary_area_m2
    if d.acoustics == "distributed":
        net = acoustic_network(d, w, flow)
        parts = net._numpy()
        _, den1, den2 = net._solve_numpy(parts, Cx.from_complex(c))
        c_t = parts[2]
    else:
        n, p0 = d.process_index, d.pressure_pa
        jw = 1j * w
        z3 = d.density_kg_m3 * c + 1.0 / (jw * d.bottom_volume_m3 / (n * p0))
        c_t = jw * d.top_volume_m3 / (n * p0)
        den1 = 1.0 + c_t * z3
        den2 = np.ones_like(den1)
    ends = 0.5 * (1.0 + 1.0 / np.abs(den2) ** 2)
    return a_p / den1, 1j * w * a_p / (den1 * a_c), -c_t / (den1 * a_c), ends


def cross_convolutions(freq_hz, cross_power, bin_hz: float = DISTORTION_BIN_HZ,
                       third: bool = False, orders: tuple | None = None):
    """:func:`normalized_convolutions` of a normalized complex cross line spectrum.

    For two jointly Gaussian unit processes with cross-correlation ``rho_ij(tau)`` (Mehler:
    ``E[He_k(x_i) He_m(x_j)] = delta_km k! rho_ij^k``) the residuals' cross-covariance is
    ``sum_k k! c_k^2 rho_ij(tau)^k``: its one-sided cross-spectrum is the ``k``-fold
    self-convolution of the two-sided cross-spectrum (``S_ij(-f) = conj S_ij(f)``).

    Parameters
    ----------
    freq_hz : ndarray
        Line frequencies (> 0).
    cross_power : complex ndarray
        ``E[u_i u_j*]`` per line, divided by ``s_i s_j`` (one-sided).
    bin_hz : float
        Bin width.
    third : bool
        Also return the normalized cross-spectrum of ``rho_ij^3`` alone (weight 1).
    orders : tuple of int, optional
        Instead, the normalized cross-spectrum of ``rho_ij^k`` for each ``k`` (weight 1):
        ``(f_bins, spectra (bins, len(orders)))``.

    Returns
    -------
    f_bins : ndarray
        One-sided bin centres.
    p_bins : complex ndarray
        The residuals' normalized one-sided cross power per bin.
    """
    kmax = max(orders) if orders else max(DISTORTION_ORDERS)
    idx, p = _bins(freq_hz, np.asarray(cross_power, dtype=complex), bin_hz)
    imax = int(idx.max())
    from scipy.fft import next_fast_len

    n = next_fast_len(2 * kmax * imax + 2)
    h = np.zeros(n, dtype=complex)
    np.add.at(h, idx % n, 0.5 * p)
    np.add.at(h, (-idx) % n, 0.5 * np.conj(p))
    hf = np.fft.fft(h)
    top = kmax * imax
    f_bins = bin_hz * np.arange(1, top + 1)
    if orders:
        return f_bins, np.stack([2.0 * np.fft.ifft(hf ** k)[1:top + 1] for k in orders], axis=-1)
    spec = _odd_orders(hf, kmax)
    conv = np.fft.ifft(spec)
    if third:
        return f_bins, 2.0 * conv[1:top + 1], 2.0 * np.fft.ifft(hf * hf * hf)[1:top + 1]
    return f_bins, 2.0 * conv[1:top + 1]


def pair_convolutions(freq_hz, cross_power, bin_hz: float = DISTORTION_BIN_HZ,
                      third: bool = False, orders: tuple | None = None):
    """:func:`cross_convolutions` of many pairs at once, in real arithmetic.

    The two-sided cross-spectrum ``h`` of a pair is Hermitian (``h(-f) = conj h(f)``), so its
    transform, the cross-correlation ``rho_ij(tau)``, is real: one real inverse FFT per pair
    (batched), the odd powers of the real correlation, one real FFT back. The same numbers as
    :func:`cross_convolutions` to rounding (``tests/response/test_distortion.py``), at half
    its FFT work and without the per-pair calls.

    Parameters
    ----------
    freq_hz : ndarray (f,)
        Line frequencies (> 0).
    cross_power : complex ndarray (f, m)
        ``E[u_i u_j*]`` per line and pair, divided by ``s_i s_j`` (one-sided).
    bin_hz : float
        Bin width.
    third : bool
        Also return the normalized cross-spectra of ``rho_ij^3`` alone (weight 1),
        ``p3_bins`` (bins, m), from the same transforms (the first-order kurtosis).
    orders : tuple of int, optional
        Instead, return the normalized cross-spectra of ``rho_ij^k`` for each ``k`` (weight
        1): ``(f_bins, spectra (bins, m, len(orders)))`` (the non-Gaussian residuals' weights
        differ per pair, section 3c).

    Returns
    -------
    f_bins : ndarray
        One-sided bin centres, up to :data:`DISTORTION_RANGE_FACTOR` times the highest line
        (and one bin more; :func:`cross_convolutions` returns all of them, to ``kmax``
        times): the FFT period is only as long as these bins need to be free of aliasing.
    p_bins : complex ndarray (bins, m)
        The residuals' normalized one-sided cross power per bin and pair.
    """
    p = np.asarray(cross_power, dtype=complex)
    rep, cols = _same_columns(p)
    if cols.size < p.shape[1]:  # a symmetric table's pairs repeat: each distinct one once
        res = _pair_convolutions(freq_hz, p[:, cols], bin_hz, third, orders)
        return (res[0], *(r[:, rep] for r in res[1:]))
    return _pair_convolutions(freq_hz, p, bin_hz, third, orders)


def _pair_convolutions(freq_hz, p, bin_hz: float, third: bool = False,
                       orders: tuple | None = None):
    """:func:`pair_convolutions` of distinct pairs."""
    from scipy.fft import irfft, next_fast_len, rfft

    kmax = max(orders) if orders else max(DISTORTION_ORDERS)
    idx, p = _bins(freq_hz, p, bin_hz)
    imax = int(idx.max())
    # no aliasing below the bins kept: the k-fold convolution spans +-kmax imax, so a
    # period n > kmax imax + keep leaves [0, keep] exact
    keep = min(kmax * imax, math.ceil(DISTORTION_RANGE_FACTOR * imax) + 1)
    n = next_fast_len(max(2 * imax + 2, kmax * imax + keep + 1), real=True)
    m = p.shape[1]
    # the one-sided half of conj(h): its Hermitian extension is conj(h) (h Hermitian), and
    # n irfft(conj h) = conj(fft(h)) = fft(h), real
    nb = n // 2 + 1
    flat = (idx[:, None] + nb * np.arange(m)[None, :]).ravel()  # lines may share a bin
    half = np.empty((m, nb), dtype=complex)
    half.real = np.bincount(flat, weights=0.5 * p.real.ravel(), minlength=m * nb).reshape(m, nb)
    half.imag = np.bincount(flat, weights=-0.5 * p.imag.ravel(), minlength=m * nb).reshape(m, nb)
    # the zero bin (idx == 0) carries 0.5 p + 0.5 conj p in the two-sided grid
    half.imag[:, 0] = 0.0
    hf = n * irfft(half, n, axis=-1)
    if orders:  # each order alone: (bins, m, orders)
        spec = np.stack([hf ** k for k in orders], axis=1)  # (m, orders, n)
        conv = np.conj(rfft(spec, axis=-1)[:, :, 1:keep + 1]) / n
        return bin_hz * np.arange(1, keep + 1), 2.0 * np.transpose(conv, (2, 0, 1))
    spec = _odd_orders(hf, kmax)
    if third:
        spec = np.concatenate([spec, hf * hf * hf])
    # ifft(spec)[k] = conj(rfft(spec)[k]) / n for a real spec
    conv = np.conj(rfft(spec, axis=-1)[:, 1:keep + 1]) / n
    f_bins = bin_hz * np.arange(1, keep + 1)
    if third:
        return f_bins, 2.0 * conv[:m].T, 2.0 * conv[m:].T
    return f_bins, 2.0 * conv.T


class PairTransform:
    """The pairs' normalized correlations ``rho_ij(tau)`` on one FFT period, from which any
    weighted sum of their odd powers is transformed back (the non-Gaussian residuals, whose
    weights are known only after the third order has given the kurtosis; section 3c).

    The period is that of :data:`PERIOD_ORDER`: free of aliasing for the orders up to it,
    and for the higher ones up to their mass beyond it, the ``k``-fold convolution of the
    tube velocity's spectrum beyond ``PERIOD_ORDER`` times its highest line, which is below
    1e-9 of the band powers here (``test_pair_transform_period``).

    Parameters
    ----------
    freq_hz : ndarray (f,)
        Line frequencies (> 0).
    cross_power : complex ndarray (f, m)
        ``E[u_i u_j*]`` per line and pair, divided by ``s_i s_j`` (one-sided).
    bin_hz : float
        Bin width.
    period_order : int
        The order whose convolution the period holds without aliasing.
    """

    def __init__(self, freq_hz, cross_power, bin_hz: float = DISTORTION_BIN_HZ,
                 period_order: int | None = None):
        from scipy.fft import irfft, next_fast_len

        p = np.asarray(cross_power, dtype=complex)
        self.rep, cols = _same_columns(p)
        idx, q = _bins(freq_hz, p[:, cols], bin_hz)
        imax = int(idx.max())
        kmax = period_order or PERIOD_ORDER
        keep = min(kmax * imax, math.ceil(DISTORTION_RANGE_FACTOR * imax) + 1)
        n = next_fast_len(max(2 * imax + 2, kmax * imax + keep + 1), real=True)
        m = q.shape[1]
        nb = n // 2 + 1
        flat = (idx[:, None] + nb * np.arange(m)[None, :]).ravel()
        half = np.empty((m, nb), dtype=complex)
        half.real = np.bincount(flat, weights=0.5 * q.real.ravel(),
                                minlength=m * nb).reshape(m, nb)
        half.imag = np.bincount(flat, weights=-0.5 * q.imag.ravel(),
                                minlength=m * nb).reshape(m, nb)
        half.imag[:, 0] = 0.0
        self.hf = n * irfft(half, n, axis=-1)  # rho_ij(tau), real
        self.n, self.keep = n, keep
        self.f_bins = bin_hz * np.arange(1, keep + 1)

    def spectra(self, weights, orders=NON_GAUSSIAN_ORDERS):
        """``sum_k w_k,ij (rho_ij^k)``'s one-sided spectra, ``(bins, m)`` complex.

        Parameters
        ----------
        weights : ndarray (len(orders),) or (m, len(orders))
            Per pair (or for all) the weight of each order.
        orders : tuple of int
            Consecutive odd orders from 3.
        """
        from scipy.fft import rfft

        m = self.rep.size
        w = np.asarray(weights, dtype=float)
        if w.ndim == 1:  # one weight row for all: the distinct correlations
            h, wu, inv = self.hf, np.broadcast_to(w, (self.hf.shape[0], w.size)), self.rep
        else:  # each distinct (correlation, weights) once
            key = np.column_stack([self.rep, np.broadcast_to(w, (m, len(orders)))])
            uniq, inv = np.unique(key, axis=0, return_inverse=True)
            h = self.hf[uniq[:, 0].astype(int)]
            wu = uniq[:, 1:]
        nz = np.flatnonzero(np.any(wu != 0.0, axis=0))
        top = int(nz[-1]) + 1 if nz.size else 1  # the highest order weighted
        h2 = h * h
        spec = h2 * h  # h^3
        if top > 1 or np.any(wu[:, 0] != 1.0):
            acc = np.repeat(wu[:, top - 1:top], h.shape[1], axis=1)
            for j in range(top - 2, -1, -1):  # Horner in h^2
                acc *= h2
                acc += wu[:, j:j + 1]
            spec *= acc
        conv = np.conj(rfft(spec, axis=-1)[:, 1:self.keep + 1]) / self.n
        return 2.0 * conv.T[:, np.ravel(inv)]


def _same_columns(p, rtol: float = 1e-12):
    """Columns of ``p`` equal to an earlier one within ``rtol`` of its largest entry.

    Returns ``(rep, cols)``: ``cols`` the distinct columns' indices, ``rep[j]`` the position
    in ``cols`` of column ``j``'s representative (candidates by a rounded projection, each
    match checked entry by entry).
    """
    m = p.shape[1]
    scale = np.max(np.abs(p), axis=0)
    proj = np.cos(np.arange(p.shape[0]) * 0.7)[:, None] * p  # not a BLAS product: a
    sig = proj.sum(axis=0) / np.where(scale > 0, scale, 1.0)  # loaded machine's threads
    seen: dict = {}
    cols: list[int] = []
    rep = np.empty(m, dtype=int)
    for j in range(m):
        key = (round(float(sig[j].real), 6), round(float(sig[j].imag), 6))
        i = seen.get(key)
        if i is not None and np.max(np.abs(p[:, j] - p[:, cols[i]])) <= rtol * scale[cols[i]]:
            rep[j] = i
            continue
        seen.setdefault(key, len(cols))
        rep[j] = len(cols)
        cols.append(j)
    return rep, np.asarray(cols, dtype=int)


def bin_groups(f_bins, edges_hz=(), rel: float = DISTORTION_GROUP_REL):
    """Groups of consecutive bins for the sources' response: no wider than ``rel`` of their
    frequency, never across an edge of ``edges_hz`` (the bands').

    The sources' power is summed over a group exactly; the response to it is evaluated once,
    at the group's mean frequency (:data:`DISTORTION_GROUP_REL`).

    Parameters
    ----------
    f_bins : ndarray
        Bin centres, increasing (> 0).
    edges_hz : sequence of float
        Frequencies no group spans (a bin at an edge starts a group, as a band's lower
        edge is in the band).
    rel : float
        Largest group width over its frequency (0: every bin alone).

    Returns
    -------
    starts : ndarray of int
        Index of each group's first bin (for ``np.add.reduceat``).
    f_groups : ndarray
        The groups' mean frequencies.
    """
    f = np.asarray(f_bins, dtype=float)
    if rel <= 0 or f.size == 0:
        return np.arange(f.size), f
    cell = np.floor(np.log(f) / rel).astype(np.int64)
    seg = np.searchsorted(np.unique(np.asarray(edges_hz, dtype=float)), f, side="right")
    new = np.ones(f.size, dtype=bool)
    new[1:] = (cell[1:] != cell[:-1]) | (seg[1:] != seg[:-1])
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, f.size))
    return starts, np.add.reduceat(f, starts) / counts


def group_extents(f_bins, starts, bin_hz: float):
    """The frequency extent ``(lower, upper)`` of each bin group: from its first bin's lower
    edge to its last bin's upper edge (a bin stands for ``+-bin_hz/2`` about its centre)."""
    f = np.asarray(f_bins, dtype=float)
    last = np.append(np.asarray(starts)[1:] - 1, f.size - 1)
    return f[starts] - 0.5 * bin_hz, f[last] + 0.5 * bin_hz


def band_fractions(extent_lo, extent_hi, lower_hz, upper_hz):
    """``(groups, bands)``: the share of each bin group's power in each band, its power
    spread evenly over its extent (a group straddling a band edge, its first bin's, is split
    by the overlap; assigning whole bins by their centres erred by up to half a bin's
    power at each edge, docs/random-response.md 3a)."""
    lo = np.asarray(extent_lo, dtype=float)[:, None]
    hi = np.asarray(extent_hi, dtype=float)[:, None]
    over = (np.minimum(hi, np.asarray(upper_hz, dtype=float)[None, :])
            - np.maximum(lo, np.asarray(lower_hz, dtype=float)[None, :]))
    return np.clip(over, 0.0, None) / (hi - lo)
