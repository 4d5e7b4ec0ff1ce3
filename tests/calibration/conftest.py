"""Simulated rig data for the calibration tests (time-domain simulator, cached per session)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from isodesign.calibration import MeasuredStiffness
from isodesign.simulation.harmonic_rig import simulate_grid
from isodesign.spring.design import SpringDesign
from isodesign.spring.diaphragm import ViscoelasticDiaphragm

#: The diaphragm the rig "has" (the illustrative viscoelastic model: softening, eta rising).
TRUE_DIAPHRAGM = ViscoelasticDiaphragm()
#: The dual-chamber rig spring: K, D_c and n differ from the reference spring's 1.5, 0.9 mm and
#: adiabatic 1.4, which is where the air-side fit starts.
TRUE_AIR = {"minor_loss": 2.5, "capillary_diameter_m": 1.0e-3, "polytropic_index": 1.3}
AMPLITUDES_M = np.array([0.05, 0.1, 0.2, 0.5]) * 1e-3


def noisy(k, sigma, seed):
    """``k + |k| sigma (n1 + j n2)``: independent relative noise on both parts."""
    rng = np.random.default_rng(seed)
    return k + np.abs(k) * sigma * (
        rng.standard_normal(k.shape) + 1j * rng.standard_normal(k.shape)
    )


def measured(freq, amp, k, configuration, source="simulated rig"):
    ff, xx = np.meshgrid(freq, amp, indexing="ij")
    return MeasuredStiffness(ff.ravel(), xx.ravel(), k.ravel(), configuration, source)


@pytest.fixture(scope="session")
def single_chamber_rig():
    """(frequencies, amplitudes, noise-free k) of the reference spring, capillary blocked.

    Blocked = a 10 um capillary with the Poiseuille law (tau ~ 2e4 s: the air is k_s within
    1e-5); about 1 s.
    """
    ref = SpringDesign.reference()
    f = np.geomspace(0.2, 24, 20)
    g = simulate_grid(
        ref.replace(capillary_diameter_m=1e-5), f, AMPLITUDES_M, flow="poiseuille",
        diaphragm=TRUE_DIAPHRAGM,
    )  # fmt: skip
    return f, AMPLITUDES_M, g.k


@pytest.fixture(scope="session")
def dual_chamber_rig():
    """(design, frequencies, amplitudes, noise-free k) of the dual-chamber rig spring with
    :data:`TRUE_AIR` and :data:`TRUE_DIAPHRAGM`; 10-20 s, hence the slow tests."""
    d = SpringDesign.reference().replace(**TRUE_AIR)
    f = np.geomspace(0.2, 24, 14)
    g = simulate_grid(d, f, AMPLITUDES_M, flow="quasi_steady", diaphragm=TRUE_DIAPHRAGM)
    return d, f, AMPLITUDES_M, g.k


@pytest.fixture(scope="session")
def rig():
    """The truth and helpers (test modules cannot import conftest in importlib mode)."""
    return SimpleNamespace(
        true_diaphragm=TRUE_DIAPHRAGM, true_air=TRUE_AIR, noisy=noisy, measured=measured
    )
