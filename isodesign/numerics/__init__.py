"""Numerics shared by every discipline: NumPy/CasADi dispatch and complex pairs.

* :mod:`isodesign.numerics.backend`: elementary functions that evaluate on NumPy arrays and
  on CasADi symbols alike (``bk.exp``, ``bk.sqrt``, smooth ``max``/``abs``, ...).
* :mod:`isodesign.numerics.cplx`: :class:`~isodesign.numerics.cplx.Cx`, a complex value as a
  (real, imaginary) pair, so that one physics function serves both backends.
"""
