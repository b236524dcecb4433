"""The signal files of one ``hammerstein evaluate``, each parsed once.

``evaluate`` had parsed the drive file three times (its length, its input
columns, its shaped reference) and the measured file up to four times;
:class:`Tables` parses each once and hands the table on,
:func:`drive_inputs` takes a drive's input voltages from it, and
:func:`now_or_later` takes a file's columns at once while saying their
error in its turn.
"""

from __future__ import annotations

import os

from hammerstein.compensation.drive_files import drive_input_names, optional_columns, read_table
from hammerstein.exceptions import DataFileError

__all__ = ["Tables", "now_or_later", "drive_inputs"]


class Tables:
    """The signal files of one ``evaluate``, each read and parsed once.

    The drive file had been parsed three times (its length, its input
    columns, its shaped reference) and the measured file up to four times
    (its columns for the default outputs, twice, its outputs, its inputs):
    :meth:`get` parses a file the first time it is asked for
    (:func:`hammerstein.compensation.drive_files.read_table`) and hands the
    same table on; a file that cannot be read raises the same error at each
    use. :meth:`drop` lets a table go once its columns are taken.
    """

    def __init__(self):
        self._got = {}

    def get(self, path, what, time="t"):
        """The parsed table of ``path``.

        Parameters
        ----------
        path : str or pathlib.Path
            The file.
        what : str
            What it is, for messages (``"--drive"``, ``"--measured"``).
        time : str
            Its time column.

        Returns
        -------
        hammerstein.io.datafiles._Table

        Raises
        ------
        DataFileError
            The file cannot be read (the same error at each call).
        """
        key = (os.fspath(path), what)
        if key not in self._got:
            try:
                self._got[key] = read_table(path, what, time)
            except DataFileError as exc:
                self._got[key] = exc
        got = self._got[key]
        if isinstance(got, DataFileError):
            raise got
        return got

    def drop(self, path, what):
        """Forget the table of ``path`` (None: no file) read as ``what`` (its memory goes)."""
        if path is not None:
            self._got.pop((os.fspath(path), what), None)


def now_or_later(function, *args):
    """``function(*args)`` called now; what it returned, or its error, when asked for.

    Returns
    -------
    callable
        Without arguments: returns the result, or raises the
        :class:`~hammerstein.exceptions.DataFileError` or ``OSError`` the call
        raised (a file's columns read early, their error said in its turn).
    """
    try:
        value = function(*args)
    except (DataFileError, OSError) as exc:
        error = exc

        def later():
            raise error
        return later
    return lambda: value


def drive_inputs(path, outs, T, table=None):
    """The drive file's input columns and their voltages.

    Parameters
    ----------
    path : str
        The drive file.
    outs : list of str
        Output names (their columns are no inputs).
    T : float
        Its sampling period [s].
    table : hammerstein.io.datafiles._Table, optional
        The drive file already parsed, or None to read it.

    Returns
    -------
    names : list of str
        Its input columns (:func:`hammerstein.compensation.drive_files.drive_input_names`).
    u : numpy.ndarray, shape (len(names), n_samples), or None
        Their voltages [V]; None without input columns.

    Raises
    ------
    DataFileError
        Columns that are not readable.
    OSError
        The file cannot be read.
    """
    names = drive_input_names(path, outs)
    return names, (optional_columns(path, names, T, "--drive", table) if names else None)
