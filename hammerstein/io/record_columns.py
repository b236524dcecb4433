"""Whether a record file holds the columns it is asked for, from its opening only.

The checks :func:`hammerstein.io.datafiles.read_records` makes on a whole file,
made on its first :data:`~hammerstein.io.datafiles.HEAD_BYTES` bytes, so that
``validate`` names every column problem of a scenario's record files before
anything is read whole.
"""

from __future__ import annotations

from pathlib import Path

from hammerstein.io.datafiles import (HEAD_BYTES, MIN_SAMPLES, DataFileError, _column,
                                      _named_once, _read_table, _time_column, _units,
                                      column_list)

__all__ = ["record_column_problem", "record_column_problems"]


def record_column_problem(path, inputs, outputs, time=None, skip_rows=0, input_unit="V",
                          output_unit="µm"):
    """Whether :func:`read_records` would find the columns it is given, from the file's opening only.

    Reads at most the first :data:`HEAD_BYTES` bytes of the table (the
    header, a units row and the first data rows), so that a file can be
    checked before it is read whole: a column named that the header does not
    hold, a column read in another unit, the same column as input and
    output, a time column named in another unit than seconds or not
    increasing, a file of fewer than :data:`MIN_SAMPLES` rows. The data rows beyond the opening
    are not checked.

    Parameters
    ----------
    path : str or pathlib.Path
    inputs, outputs : str, int or list
        Input and output columns, as :func:`read_records` takes them.
    time : str or int, optional
        Time column [s].
    skip_rows : int
        Lines of a preamble before the table.
    input_unit, output_unit : str
        The units the inputs and outputs are read in.

    Returns
    -------
    str or None
        The first problem, as :func:`read_records` words it, or None.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rec.csv"
    >>> _ = path.write_text("t,ux,x\\n" + "".join(f"{k * 1e-4},{k},{2 * k}\\n" for k in range(10)))
    >>> record_column_problem(path, "uy", "x", "t").endswith("available columns: 0:t, 1:ux, 2:x")
    True
    >>> record_column_problem(path, "ux", "x", "t") is None
    True
    """
    found = record_column_problems(path, inputs, outputs, time, skip_rows, input_unit,
                                   output_unit)
    return found[0] if found else None


def record_column_problems(path, inputs, outputs, time=None, skip_rows=0, input_unit="V",
                           output_unit="µm"):
    """Every problem :func:`record_column_problem` finds, not only the first.

    Each column named is looked for on its own (a missing input does not hide
    a missing output, nor the time column); a file whose opening cannot be
    read, or that is too short, is one problem.

    Parameters
    ----------
    path : str or pathlib.Path
    inputs, outputs : str, int or list
        Input and output columns, as :func:`read_records` takes them.
    time : str or int, optional
        Time column [s].
    skip_rows : int
        Lines of a preamble before the table.
    input_unit, output_unit : str
        The units the inputs and outputs are read in.

    Returns
    -------
    list of str
        The problems, as :func:`read_records` words them, each once, in the
        order inputs, outputs, time; empty when the opening reads.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "rec.csv"
    >>> _ = path.write_text("t,ux,x\\n" + "".join(f"{k * 1e-4},{k},{2 * k}\\n" for k in range(10)))
    >>> [p.split(": ", 1)[1][:14] for p in record_column_problems(path, "uy", "z", "time")]
    ['no input colum', 'no output colu', 'no time column']
    """
    ins, outs = column_list(inputs), column_list(outputs)
    if not ins or not outs or any(c == "" for c in ins + outs):
        return [f"{path}: expected at least one input and one output column, found inputs "
                f"{inputs!r}, outputs {outputs!r}"]
    try:
        frame, header = _read_table(path, skip_rows, head=True)
    except DataFileError as exc:
        return [str(exc)]
    if frame.shape[0] < MIN_SAMPLES and Path(path).stat().st_size <= HEAD_BYTES:
        return [f"{path}: too short, expected at least {MIN_SAMPLES} samples, found "
                f"{frame.shape[0]}"]
    units, problems, named = _units(input_unit, output_unit), [], {"input": [], "output": []}

    def look(fn, *args):
        try:
            return fn(*args)
        except DataFileError as exc:
            if str(exc) not in problems:
                problems.append(str(exc))
            return None

    for role, keys in (("input", ins), ("output", outs)):
        for key in keys:
            column = look(_column, frame, header, key, role, path, units)
            if column is not None:
                named[role].append(column[1])
    look(_named_once, named["input"], named["output"], path)    # of the columns found
    if time is not None:
        look(_time_column, frame, header, time, path)
    return problems
