"""The floor in three axes and the table's response grid.

A rigid floor: the same translation under every isolator, its x, y and z motions
uncorrelated random processes, each a velocity PSD (a criterion, band values, a PSD or a
site-survey axis). Floor rotation and differential motion between isolators are outside
the model (docs/table.md, section 9).

Without horizontal data the vertical floor is applied to x and y as well (a conservative
and common assumption for VC criteria); :attr:`TableFloor.notes` says so, and every result
carries it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from isodesign.errors import InputError
from isodesign.floor import FloorSpectrum
from isodesign.floor.bands import Bands
from isodesign.response.linearization import default_bands, response_grid
from isodesign.response.model import resolve_floor, resolve_target
from isodesign.table.assembly import AXES

__all__ = ["TableFloor", "TableGrid", "table_floor", "table_grid"]


@dataclass(frozen=True, eq=False)
class TableFloor:
    """Floor spectra per axis (``None``: no motion in that axis).

    Attributes
    ----------
    x, y, z : FloorSpectrum or None
    notes : tuple of str
        Assumptions made (e.g. the vertical floor applied to x and y).
    """

    x: FloorSpectrum | None
    y: FloorSpectrum | None
    z: FloorSpectrum | None
    notes: tuple[str, ...] = ()

    def __post_init__(self):
        for a in AXES:
            v = getattr(self, a)
            if v is not None and not isinstance(v, FloorSpectrum):
                raise InputError(f"floor.{a}: expected a FloorSpectrum or None, got "
                                 f"{type(v).__name__}")
        if self.x is None and self.y is None and self.z is None:
            raise InputError("floor: no axis has a floor spectrum")

    @property
    def spectra(self) -> tuple:
        """``(x, y, z)``."""
        return (self.x, self.y, self.z)

    @property
    def names(self) -> tuple[str, str, str]:
        """Floor name per axis (``"none"`` without motion)."""
        return tuple("none" if s is None else s.name for s in self.spectra)


def _record_axes(path) -> dict:
    from isodesign.floor.survey import analyze_record, read_record

    res = analyze_record(read_record(path))
    return {a.lower(): res.floor("mean", a) for a in res.axes}


def table_floor(floor=None, *, x=None, y=None, z=None) -> TableFloor:
    """A :class:`TableFloor` from one floor (every axis) or one per axis.

    Parameters
    ----------
    floor : FloorSpectrum, str, CriterionCurve, path or TableFloor, optional
        One floor for every axis (:func:`~isodesign.response.model.resolve_floor`); a
        site-survey record CSV gives each of its axes its own spectrum (an axis it lacks
        takes the vertical one). Applying one vertical floor to x and y is noted.
    x, y, z : same kinds, ``False`` for no motion, optional
        Per-axis floors; they override ``floor`` for their axis.

    Returns
    -------
    TableFloor
    """
    if isinstance(floor, TableFloor):
        if x is None and y is None and z is None:
            return floor
        base = dict(zip(AXES, floor.spectra, strict=True))
        notes = list(floor.notes)
    else:
        base, notes = {}, []
        if floor is not None:
            from isodesign.floor.survey import is_record_csv

            if isinstance(floor, str | bytes) or hasattr(floor, "__fspath__"):
                try:
                    rec = is_record_csv(floor)
                except (OSError, InputError):
                    rec = False
                if rec:
                    try:
                        base = _record_axes(floor)
                    except InputError as exc:
                        raise InputError(f"floor: {exc}") from None
            if not base:
                fz = resolve_floor(floor)
                base = {"z": fz}
    given = {a: v for a, v in (("x", x), ("y", y), ("z", z)) if v is not None}
    for a, v in given.items():
        if v is False:
            base[a] = None
        else:
            try:
                base[a] = resolve_floor(v)
            except InputError as exc:
                raise InputError(f"floor.{a}: {str(exc).removeprefix('floor: ')}") from None
    if "z" not in base and ("x" not in base or "y" not in base):
        raise InputError("floor: give a vertical floor (z) or one per axis")
    missing = [a for a in ("x", "y") if a not in base]
    if missing and base.get("z") is not None:
        for a in missing:
            base[a] = base["z"]
        notes.append(f"the vertical floor {base['z'].name!r} is applied to "
                     f"{' and '.join(missing)} (no horizontal floor given)")
    return TableFloor(x=base.get("x"), y=base.get("y"), z=base.get("z"), notes=tuple(notes))


@dataclass(frozen=True, eq=False)
class TableGrid:
    """Frequencies and per-axis quadrature weights of a table response (NumPy, built once).

    Attributes
    ----------
    frequency_hz, omega : ndarray (n_freq,)
    stroke_weight : ndarray (3, n_freq)
        Per floor axis: ``variance = stroke_weight[a] @ |H_a|^2`` for a response ``H_a`` per
        unit floor displacement in axis ``a`` (zero for an axis without floor).
    band_weight : ndarray (3, n_bands, n_freq)
        Per floor axis: band mean square ``band_weight[a] @ |T_a|^2``.
    bands : Bands
    limit_velocity_m_s : ndarray (n_bands,) or None
    floor_velocity_rms_m_s : ndarray (3, n_bands)
    floor : TableFloor
    target_name : str
    axis_grids : tuple
        The per-axis :class:`~isodesign.response.linearization.ResponseGrid` (None for an
        axis without floor).
    """

    frequency_hz: np.ndarray
    omega: np.ndarray
    stroke_weight: np.ndarray
    band_weight: np.ndarray
    bands: Bands
    limit_velocity_m_s: np.ndarray | None
    floor_velocity_rms_m_s: np.ndarray
    floor: TableFloor
    target_name: str
    axis_grids: tuple

    @property
    def n_points(self) -> int:
        """Number of frequencies."""
        return int(self.frequency_hz.size)

    @property
    def n_bands(self) -> int:
        """Number of bands."""
        return len(self.bands)


def table_grid(floor, bands=None, *, target=None, points_per_band: int = 50) -> TableGrid:
    """The response grid of a three-axis floor (one frequency set for every axis).

    Parameters
    ----------
    floor : TableFloor or anything :func:`table_floor` accepts
    bands : Bands or (f_min_hz, f_max_hz), optional
        Default: the target's bands inside every axis' floor range.
    target : str, CriterionCurve or path, optional
        The criterion (its limits are stored).
    points_per_band : int
        Points per band.

    Returns
    -------
    TableGrid

    Raises
    ------
    InputError
        Axes whose spectra do not share one frequency grid (``floor: ...``).
    """
    fl = floor if isinstance(floor, TableFloor) else table_floor(floor)
    tg = None if target is None else resolve_target(target)
    present = [(i, s) for i, s in enumerate(fl.spectra) if s is not None]
    if bands is None:
        sets = [set(default_bands(s, tg).index) for _, s in present]
        common = sorted(set.intersection(*sets))
        if not common:
            raise InputError("bands: the axes' floor spectra share no whole band")
        bands = Bands(tuple(common))
    grids = [None, None, None]
    built: dict = {}
    for i, s in present:  # one floor on several axes: one grid
        if id(s) not in built:
            built[id(s)] = response_grid(s, bands, target=tg, points_per_band=points_per_band)
        grids[i] = built[id(s)]
    ref = grids[present[0][0]]
    for i, _ in present[1:]:
        g = grids[i]
        if g.frequency_hz.shape != ref.frequency_hz.shape or not np.allclose(
                g.frequency_hz, ref.frequency_hz, rtol=1e-12, atol=0):
            raise InputError(
                f"floor: the {AXES[i]} and {AXES[present[0][0]]} floor spectra span different "
                "frequency ranges or kinds; give every axis the same kind of floor (criteria, "
                "band values on the same bands, or one survey record)")
    nf, nb = ref.n_points, ref.n_bands
    sw = np.zeros((3, nf))
    bw = np.zeros((3, nb, nf))
    frms = np.zeros((3, nb))
    for i, g in enumerate(grids):
        if g is not None:
            sw[i], bw[i], frms[i] = g.stroke_weight, g.band_weight, g.floor_velocity_rms_m_s
    for a in (sw, bw, frms):
        a.flags.writeable = False
    return TableGrid(frequency_hz=ref.frequency_hz, omega=ref.omega, stroke_weight=sw,
                     band_weight=bw, bands=ref.bands, limit_velocity_m_s=ref.limit_velocity_m_s,
                     floor_velocity_rms_m_s=frms, floor=fl,
                     target_name="" if tg is None else tg.name,
                     axis_grids=tuple(grids))  # fmt: skip
