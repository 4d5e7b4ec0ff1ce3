"""Measured complex stiffness of a spring on a test rig: the CSV schema and its reader.

Schema (``docs/calibration.md``)::

    # configuration: single_chamber        (capillary blocked) or dual_chamber
    # source: rig 2026-11-20, spring S/N 12
    frequency_hz,amplitude_mm,k_real_n_per_m,k_imag_n_per_m
    0.5,0.05,25120,1830
    ...

Columns (names carry the units; one of each group):

* frequency: ``frequency_hz``;
* amplitude (piston displacement amplitude X): ``amplitude_m``, ``amplitude_mm``, ``amplitude_um``;
* stiffness, either ``k_real_<u>`` and ``k_imag_<u>`` or ``k_abs_<u>`` and ``phase_deg`` /
  ``phase_rad`` (the force leads the displacement by the phase), with ``<u>`` one of
  ``n_per_m``, ``kn_per_m``, ``n_per_mm``.

``configuration`` (header or option) says what was measured: the spring with the capillary
blocked (``single_chamber``: the air is Eq. 40's k_s) or the dual-chamber spring
(``dual_chamber``: the air is Eq. 38's k_d*).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from isodesign.errors import InputError
from isodesign.floor.curve_files import _read_csv
from isodesign.io.files import names_for_message

__all__ = [
    "CONFIGURATIONS",
    "MeasuredStiffness",
    "read_measured_csv",
]

CONFIGURATIONS = ("single_chamber", "dual_chamber")
_AMPLITUDE_UNITS = {"amplitude_m": 1.0, "amplitude_mm": 1e-3, "amplitude_um": 1e-6}
_STIFFNESS_UNITS = {"n_per_m": 1.0, "kn_per_m": 1e3, "n_per_mm": 1e3}
_PHASE_UNITS = {"phase_deg": math.pi / 180.0, "phase_rad": 1.0}


@dataclass(frozen=True, eq=False)
class MeasuredStiffness:
    """Complex stiffness measured at (frequency, amplitude) points, SI.

    Attributes
    ----------
    frequency_hz, amplitude_m : ndarray, shape (n,)
    k : ndarray of complex, shape (n,)
        Measured total stiffness (air + diaphragm), N/m.
    configuration : {'single_chamber', 'dual_chamber'}
    source : str
    """

    frequency_hz: np.ndarray
    amplitude_m: np.ndarray
    k: np.ndarray
    configuration: str
    source: str = ""

    def __post_init__(self):
        f = np.asarray(self.frequency_hz, dtype=float).reshape(-1)
        x = np.asarray(self.amplitude_m, dtype=float).reshape(-1)
        k = np.asarray(self.k, dtype=complex).reshape(-1)
        where = f" ({self.source})" if self.source else ""
        if not (f.size == x.size == k.size) or f.size == 0:
            raise InputError(
                f"measured stiffness{where}: frequency_hz, amplitude_m and k need the same "
                f"(non-zero) length, got {f.size}, {x.size}, {k.size}"
            )
        for nm, v in (("frequency_hz", f), ("amplitude_m", x)):
            if not np.all(np.isfinite(v)) or np.any(v <= 0):
                raise InputError(f"measured stiffness{where}: {nm} must be finite and > 0")
        if not np.all(np.isfinite(k)):
            raise InputError(f"measured stiffness{where}: stiffness has NaN or infinite values")
        if self.configuration not in CONFIGURATIONS:
            raise InputError(
                f"configuration: unknown {self.configuration!r}; valid: {', '.join(CONFIGURATIONS)}"
            )
        for nm, v in (("frequency_hz", f), ("amplitude_m", x), ("k", k)):
            v.flags.writeable = False
            object.__setattr__(self, nm, v)

    def amplitude_levels(self, rel_tol: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
        """Distinct amplitudes (within ``rel_tol``) and each point's level index."""
        order = np.argsort(self.amplitude_m)
        levels: list[float] = []
        idx = np.empty(self.amplitude_m.size, dtype=int)
        for i in order:
            a = self.amplitude_m[i]
            if not levels or a > levels[-1] * (1 + rel_tol):
                levels.append(a)
            idx[i] = len(levels) - 1
        lv = np.array([np.exp(np.mean(np.log(self.amplitude_m[idx == j]))) for j in
                       range(len(levels))])  # fmt: skip
        return lv, idx

    def to_frame(self):
        """One row per point (SI columns)."""
        import pandas as pd

        return pd.DataFrame(
            {
                "frequency_hz": self.frequency_hz,
                "amplitude_m": self.amplitude_m,
                "k_real_n_per_m": self.k.real,
                "k_imag_n_per_m": self.k.imag,
            }
        )

    def to_csv(self, path) -> Path:
        """Write the schema's CSV (SI columns, configuration in the header)."""
        p = Path(path)
        lines = [f"# configuration: {self.configuration}"]
        if self.source:
            lines.append(f"# source: {' '.join(self.source.split())}")
        lines.append("frequency_hz,amplitude_m,k_real_n_per_m,k_imag_n_per_m")
        lines += [
            f"{f:.10g},{x:.10g},{k.real:.10g},{k.imag:.10g}"
            for f, x, k in zip(self.frequency_hz, self.amplitude_m, self.k, strict=True)
        ]
        p.write_text("\n".join(lines) + "\n", encoding="utf-8")
        return p


def read_measured_csv(path, *, configuration: str | None = None) -> MeasuredStiffness:
    """Read measured complex stiffness (schema in the module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    configuration : {'single_chamber', 'dual_chamber'}, optional
        What was measured; overrides the ``# configuration:`` header line.

    Returns
    -------
    MeasuredStiffness

    Raises
    ------
    InputError
        Missing file, columns or configuration; unknown units; non-numeric, NaN or
        non-positive frequency or amplitude values. The message names the file, line and
        column.
    """
    _, cols, rows, where = _read_csv(path)
    conf = configuration or _header_value(path, "configuration")
    if conf is None:
        raise InputError(
            f"configuration: not given as an option and not in the header of {where} (add "
            f"'# configuration: single_chamber' or 'dual_chamber')"
        )
    conf = conf.strip().lower().replace("-", "_").replace(" ", "_")

    def col(names: dict[str, float], what: str) -> tuple[int, float]:
        found = [c for c in cols if c in names]
        if len(found) != 1:
            got = "none" if not found else names_for_message(found)
            raise InputError(
                f"path: {where} needs exactly one {what} column of {', '.join(names)} "
                f"(found {got}; columns: {names_for_message(cols)})"
            )
        return cols.index(found[0]), names[found[0]]

    def values(j: int) -> np.ndarray:
        out = np.empty(len(rows))
        for i, (lineno, fields) in enumerate(rows):
            if len(fields) != len(cols):
                raise InputError(
                    f"path: {where} line {lineno}: expected {len(cols)} fields, got {len(fields)}"
                )
            try:
                out[i] = float(fields[j])
            except ValueError:
                raise InputError(
                    f"path: {where} line {lineno}, column '{cols[j]}': {fields[j]!r} is not a "
                    "number"
                ) from None
            if not math.isfinite(out[i]):
                raise InputError(
                    f"path: {where} line {lineno}, column '{cols[j]}': NaN or infinite value"
                )
        return out

    jf, _ = col({"frequency_hz": 1.0}, "frequency")
    ja, fa = col(_AMPLITUDE_UNITS, "amplitude")
    f, x = values(jf), values(ja) * fa
    for arr, j in ((f, jf), (x, ja)):
        bad = np.flatnonzero(arr <= 0)
        if bad.size:
            raise InputError(
                f"path: {where} line {rows[bad[0]][0]}, column '{cols[j]}': must be > 0"
            )
    re_cols = {f"k_real_{u}": s for u, s in _STIFFNESS_UNITS.items()}
    if any(c in re_cols for c in cols):
        jr, sr = col(re_cols, "real-stiffness")
        ji, si = col({f"k_imag_{u}": s for u, s in _STIFFNESS_UNITS.items()}, "imaginary-stiffness")
        k = values(jr) * sr + 1j * values(ji) * si
    else:
        abs_cols = {f"k_abs_{u}": s for u, s in _STIFFNESS_UNITS.items()}
        if not any(c in abs_cols for c in cols):
            raise InputError(
                f"path: {where} needs stiffness columns: k_real_<u> and k_imag_<u>, or "
                f"k_abs_<u> and phase_deg|phase_rad, with <u> in {', '.join(_STIFFNESS_UNITS)} "
                f"(columns: {', '.join(cols)})"
            )
        jm, sm = col(abs_cols, "magnitude")
        jp, sp = col(_PHASE_UNITS, "phase")
        k = values(jm) * sm * np.exp(1j * values(jp) * sp)
    return MeasuredStiffness(f, x, k, conf, source=str(path))


def _header_value(path, key: str) -> str | None:
    """``key: value`` from the leading ``#`` lines (``_read_csv`` keeps only its own keys)."""
    try:
        with Path(path).open(encoding="utf-8-sig") as fh:
            for line in fh:
                s = line.strip()
                if s and not s.startswith("#"):
                    break
                for part in s.lstrip("#").split(";"):
                    if ":" in part:
                        k, v = part.split(":", 1)
                        if k.strip().lower() == key:
                            return v.strip()
    except OSError:
        return None
    return None
