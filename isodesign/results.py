"""Display of result objects: a short ``repr``, a readable text table and notebook HTML.

Every result class of isodesign (:class:`~isodesign.response.random_input.BandResponse`,
:class:`~isodesign.spring.stiffness.StiffnessResult`, ...) derives from
:class:`ResultDisplay` and declares its dataclass with ``repr=False``. A class gives

* ``_summary_items()``: a few ``(name, formatted value)`` pairs, the key figures;
* ``to_frame()``: its table (:class:`pandas.DataFrame`).

and gets:

* ``repr(result)``: one line, ``<BandResponse: PASS, worst band 4 Hz +5.01 dB, ...>``
  (never the arrays: a band response's default dataclass repr was 471 kB);
* ``str(result)``: the key figures and the table's first and last rows as text;
* ``result._repr_html_()``: the same as HTML for Jupyter.

Only the standard library at import; pandas is imported when a table is rendered.
"""

from __future__ import annotations

import html

__all__ = ["MAX_ROWS", "ResultDisplay"]

#: Rows of a result's table shown by ``str`` and ``_repr_html_`` (first and last halves).
MAX_ROWS = 20
#: Longest ``repr``, characters.
MAX_REPR = 240


class ResultDisplay:
    """Mixin giving a result a short ``repr``, a table ``str`` and ``_repr_html_``."""

    __slots__ = ()

    def _summary_items(self) -> list[tuple[str, str]]:
        """Key figures as ``(name, formatted value)``; override in the result class."""
        return []

    def _display_frame(self):
        """The table shown by ``str`` and in notebooks (default ``to_frame()``)."""
        to_frame = getattr(self, "to_frame", None)
        return None if to_frame is None else to_frame()

    def _safe_items(self) -> list[tuple[str, str]]:
        try:
            return [(str(k), str(v)) for k, v in self._summary_items()]
        except Exception as exc:  # a display must never raise
            return [("summary unavailable", f"{type(exc).__name__}: {exc}")]

    def __repr__(self) -> str:
        items = self._safe_items()
        body = ", ".join(f"{k} {v}" if k else v for k, v in items)
        text = f"<{type(self).__name__}: {body}>" if body else f"<{type(self).__name__}>"
        if len(text) > MAX_REPR:
            text = text[: MAX_REPR - 4] + "...>"
        return text

    def __str__(self) -> str:
        lines = [type(self).__name__]
        items = self._safe_items()
        if items:
            width = max(len(k) for k, _ in items)
            lines += [f"  {k:<{width}}  {v}" for k, v in items]
        df = self._frame_or_none()
        if df is not None:
            import pandas as pd

            with pd.option_context("display.width", 120, "display.max_columns", 10,
                                   "display.max_colwidth", 40):
                lines += ["", df.to_string(max_rows=MAX_ROWS, max_cols=10, index=False)]
            lines.append(f"[{len(df)} rows x {df.shape[1]} columns; to_frame() gives the table]")
        return "\n".join(lines)

    def _frame_or_none(self):
        try:
            return self._display_frame()
        except Exception:  # a display must never raise
            return None

    def _repr_html_(self) -> str:
        e = html.escape
        out = [f"<div class='isodesign-result'><strong>{e(type(self).__name__)}</strong>"]
        items = self._safe_items()
        if items:
            rows = "".join(f"<tr><th style='text-align:left'>{e(k)}</th><td>{e(v)}</td></tr>"
                           for k, v in items)
            out.append(f"<table>{rows}</table>")
        df = self._frame_or_none()
        if df is not None:
            out.append(df.to_html(max_rows=MAX_ROWS, max_cols=12, index=False, border=0))
            out.append(f"<p><small>{len(df)} rows x {df.shape[1]} columns; "
                       "<code>to_frame()</code> gives the table</small></p>")
        out.append("</div>")
        return "".join(out)
