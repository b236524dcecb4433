"""Tables shared by the reports: long metrics and GitHub markdown tables."""

from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["COLUMNS", "metrics_frame", "markdown_table"]

#: Columns of ``metrics.csv``.
COLUMNS = ["case", "channel", "metric", "value", "unit"]


def metrics_frame(results):
    """Long-format metrics of all cases.

    Parameters
    ----------
    results : list
        Results with ``name`` and ``metrics`` (rows ``{channel, metric,
        value, unit}``), e.g. :class:`hammerstein.scenario.execute.CaseResult`.

    Returns
    -------
    pandas.DataFrame
        Columns ``case, channel, metric, value, unit``.
    """
    rows = [{"case": r.name, **row} for r in results for row in r.metrics]
    return pd.DataFrame(rows, columns=COLUMNS)


def markdown_table(frame, floatfmt="{:.4g}"):
    """A pandas DataFrame as a GitHub markdown table (no extra dependency).

    Parameters
    ----------
    frame : pandas.DataFrame
        The table; its index is not written.
    floatfmt : str
        ``str.format`` pattern of the float cells; NaN cells are left empty.

    Returns
    -------
    str
        Header, separator and one line per row, joined by newlines (no
        trailing newline).
    """
    def fmt(v):
        if isinstance(v, (float, np.floating)):
            return "" if np.isnan(v) else floatfmt.format(v)
        return str(v)
    head = "| " + " | ".join(map(str, frame.columns)) + " |"
    sep = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(fmt(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([head, sep, *body])
