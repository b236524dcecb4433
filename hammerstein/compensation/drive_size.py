"""Drive files' size: the largest one written, the limit it is read within, its rows by blocks.

A drive file of ``hammerstein compensate`` or ``learn`` holds ``t``, one column
per input [V] and the columns of the outputs it aims at or predicts [µm], each
value at full precision (``%.17g``). Its size follows from the record's
length: at most :data:`VALUE_BYTES` per value, under a comment header of at
most :data:`HEADER_BYTES`. :func:`drive_file_limit` is the size of the largest
drive of the largest record a command accepts
(:func:`hammerstein.core.numbers.max_record_samples`), or the data files'
limit when that is larger: a drive file a command wrote for a record it
accepted is read again by ``evaluate`` and ``learn`` (a 150 s drive at 20 kHz
with its predicted and shaped columns, 270 MiB, was beyond the 256 MiB of every
data file), while every read stays bounded. :func:`write_drive_rows` writes the
rows :data:`DRIVE_CHUNK_ROWS` at a time, never the whole table as text, and can
sign the file: its last comment line keeps the SHA-256 of its other bytes, which
:func:`drive_changed` computes again before a command replaces the file (a drive
a user appended a measured column to is theirs).
"""

from __future__ import annotations

import hashlib
import os
import stat

import numpy as np

from hammerstein.core.files import FileLimitError, hash_blocks, limit
from hammerstein.core.numbers import RECORD_SAMPLES_ENV, max_record_samples

__all__ = ["DRIVE_MARK", "DIGEST_START", "VALUE_BYTES", "HEADER_BYTES", "MAX_DRIVE_COLUMNS",
           "DRIVE_CHUNK_ROWS", "drive_file_limit", "drive_limit_words", "file_limit",
           "write_drive_rows", "drive_changed"]

#: First characters of every CSV file written by ``hammerstein compensate`` / ``learn`` (ownership).
DRIVE_MARK = "# hammerstein"

#: Start of a signed drive file's last comment line; 64 hexadecimal digits follow, then
#: :data:`DIGEST_END`: the SHA-256 of the file's bytes without that line.
DIGEST_START = "# sha256 of this file without this line: "

#: The rest of the digest line after its 64 digits.
DIGEST_END = " (hammerstein replaces the file only while it matches)\n"

#: Most bytes of one value of a drive file and its separator: ``%.17g`` of a float64 is at most
#: 24 characters (``-2.2250738585072014e-308``), then a comma or the end of the line.
VALUE_BYTES = 25

#: Bytes allowed for a drive file's comment header and its row of column names.
HEADER_BYTES = 1 << 16

#: Most columns counted for a drive file's limit (``t``, one per input, three per output at most:
#: shaped, learnt, predicted); a header naming more is counted as this many.
MAX_DRIVE_COLUMNS = 64

#: Rows of a drive file formatted per string operation by :func:`write_drive_rows`.
DRIVE_CHUNK_ROWS = 20_000


def drive_file_limit(n_columns):
    """The size limit [bytes] of a drive file of ``n_columns`` columns.

    The larger of the data files' limit (:func:`hammerstein.core.files.limit`
    ``("data")``, ``HAMMERSTEIN_MAX_DATA_BYTES``) and the largest drive file
    of the largest accepted record: :data:`HEADER_BYTES` plus
    ``max_record_samples()`` rows (``HAMMERSTEIN_MAX_RECORD_SAMPLES``,
    default 1e7) of ``n_columns`` values of :data:`VALUE_BYTES` each.

    Parameters
    ----------
    n_columns : int
        Columns of the drive file (``t`` included), counted up to
        :data:`MAX_DRIVE_COLUMNS`.

    Returns
    -------
    int
        Largest accepted size [bytes].

    Examples
    --------
    >>> drive_file_limit(7)     # 1e7 samples of t, 2 inputs, 2 shaped, 2 predicted: 1.6 GiB
    1750065536
    """
    columns = min(max(int(n_columns), 1), MAX_DRIVE_COLUMNS)
    return max(limit("data"), HEADER_BYTES + max_record_samples() * columns * VALUE_BYTES)


def drive_limit_words(n_columns):
    """What a drive file's limit is, for messages: ``drive file of 7 columns ...``.

    Parameters
    ----------
    n_columns : int
        Columns of the drive file.

    Returns
    -------
    str
        The file's kind and where its limit comes from (no trailing period).

    Examples
    --------
    >>> drive_limit_words(3)
    'drive file of 3 columns (the size of the largest record accepted, 1e+07 samples: HAMMERSTEIN_MAX_RECORD_SAMPLES)'
    """
    return (f"drive file of {int(n_columns)} columns (the size of the largest record accepted, "
            f"{max_record_samples():.3g} samples: {RECORD_SAMPLES_ENV})")


def file_limit(head):
    """The size limit of a data file, and its kind in words, from its opening bytes.

    A file that opens with :data:`DRIVE_MARK` (a drive ``compensate`` or
    ``learn`` wrote) is read within :func:`drive_file_limit` of its columns
    (its first line that is not a ``#`` comment, split at commas); any other
    file within the data files' limit.

    Parameters
    ----------
    head : bytes
        The file's first bytes (its header lines; 64 KiB hold them).

    Returns
    -------
    cap : int
        Largest accepted size [bytes].
    what : str
        ``"data file"``, or :func:`drive_limit_words` of a drive file.

    Examples
    --------
    >>> file_limit(b"t,x\\n0,1\\n")[1]
    'data file'
    >>> file_limit(b"# hammerstein compensate drive\\nt,ux,uy\\n0,0,0\\n")[1][:25]
    'drive file of 3 columns ('
    """
    if not head.startswith(DRIVE_MARK.encode("ascii")):
        return limit("data"), "data file"
    names = next((line for line in head.split(b"\n") if line.strip() and
                  not line.startswith(b"#")), b"")
    n_columns = names.count(b",") + 1
    return drive_file_limit(n_columns), drive_limit_words(n_columns)


def write_drive_rows(fh, head, data, cap=None, what="drive file", signed=False):
    """Write a drive file's text: ``head``, then one ``%.17g`` row per sample, by blocks.

    The rows are those of ``numpy.savetxt(fh, data, delimiter=",", fmt="%.17g")``
    byte for byte, formatted :data:`DRIVE_CHUNK_ROWS` at a time: the memory is a
    block's, where the whole table's text (in a ``StringIO``, 4 bytes a
    character, and two copies of it) had taken 1.8 GB for 3e6 samples.

    ``signed``: a line :data:`DIGEST_START` ``<64 hex digits>`` :data:`DIGEST_END`
    goes before ``head``'s last line (the row of column names), in place of
    any digest line ``head`` holds (a header copied from another drive); the
    digits, written as placeholders, are filled once the rows are written
    (``fh`` is sought back) with the SHA-256 of every other byte written,
    hashed as it is written. :func:`drive_changed` checks it.

    Parameters
    ----------
    fh : binary file object
        Where the UTF-8 text goes (seekable when ``signed``).
    head : str
        The comment lines and the row of column names, each ending in ``"\\n"``.
    data : numpy.ndarray, shape (n_samples, n_columns)
        The values (s, V, µm), float64.
    cap : int, optional
        Most bytes to write [bytes]; a file that would take more is not
        finished.
    what : str
        What the file is, for the message.
    signed : bool
        Write the digest line (above).

    Returns
    -------
    int
        Bytes written.

    Raises
    ------
    FileLimitError
        The text would take more than ``cap`` bytes (the message names the
        limit and how to raise it; the caller's temporary is then removed).

    Examples
    --------
    >>> import io
    >>> fh = io.BytesIO()
    >>> write_drive_rows(fh, "t,ux\\n", np.array([[0.0, 0.1], [0.5, 1 / 3]]))
    51
    >>> print(fh.getvalue().decode(), end="")
    t,ux
    0,0.10000000000000001
    0.5,0.33333333333333331
    """
    data = np.asarray(data, dtype=float)
    row = ",".join(["%.17g"] * data.shape[1]) + "\n"
    written = 0
    sha = hashlib.sha256() if signed else None

    def put(text, hashed=True):
        nonlocal written
        chunk = text.encode("utf-8")
        if sha is not None and hashed:
            sha.update(chunk)
        written += len(chunk)
        if cap is not None and written > cap:
            raise FileLimitError(
                f"--out: the {what} would take more than {cap / 2**20:.4g} MiB, the limit "
                f"within which evaluate and learn read it (HAMMERSTEIN_MAX_DATA_BYTES, or "
                f"{RECORD_SAMPLES_ENV}, raises it for every command); nothing written: a "
                f"shorter reference (fewer periods), or raise the limit")
        fh.write(chunk)

    at = None
    if signed:
        head = "".join(ln for ln in head.splitlines(keepends=True)
                       if not ln.startswith(DIGEST_START))
        cut = head.rstrip("\n").rfind("\n") + 1        # the row of column names starts there
        put(head[:cut])
        at = fh.tell() + len(DIGEST_START)
        put(DIGEST_START + "0" * 64 + DIGEST_END, hashed=False)
        put(head[cut:])
    else:
        put(head)
    for start in range(0, data.shape[0], DRIVE_CHUNK_ROWS):
        block = data[start:start + DRIVE_CHUNK_ROWS]
        put((row * block.shape[0]) % tuple(block.ravel().tolist()))
    if at is not None:
        end = fh.tell()
        fh.seek(at)
        fh.write(sha.hexdigest().encode("ascii"))
        fh.seek(end)
    return written


def _digest_line(head):
    """``(start, end, digest)`` of the digest line among the comment lines opening ``head``, or None."""
    start, mark = 0, DIGEST_START.encode("ascii")
    while start < len(head) and head.startswith(b"#", start):
        end = head.find(b"\n", start)
        if end < 0:
            return None
        if head.startswith(mark, start):
            digest = head[start + len(mark):start + len(mark) + 64].decode("ascii", "replace")
            return start, end + 1, digest
        start = end + 1
    return None


def drive_changed(path):
    """Whether a signed drive file differs from what was written (its digest line, :func:`write_drive_rows`).

    The SHA-256 of the file's bytes without its digest line is computed
    again, read in 1 MiB blocks: the memory is a block's, and no more than
    the largest drive file of its columns (:func:`file_limit`) is read; a
    larger file was not written so, and counts as changed.

    Parameters
    ----------
    path : str or pathlib.Path
        A drive file.

    Returns
    -------
    bool or None
        True when it changed since it was written (a measured column added,
        rows edited, its digest line altered); False when it holds what was
        written; None when it has no digest line (written by an earlier
        version, or the line was removed), is not a regular file, or cannot
        be read.

    Examples
    --------
    >>> import io, tempfile
    >>> buf = io.BytesIO()
    >>> _ = write_drive_rows(buf, "# hammerstein compensate drive\\nt,ux\\n",
    ...                      np.array([[0.0, 0.5]]), signed=True)
    >>> with tempfile.NamedTemporaryFile(suffix=".csv") as fh:
    ...     _ = fh.write(buf.getvalue()); fh.flush()
    ...     before = drive_changed(fh.name)
    ...     _ = fh.write(b"5e-05,0.25\\n"); fh.flush()
    ...     before, drive_changed(fh.name)
    (False, True)
    """
    try:
        with open(path, "rb") as fh:
            if not stat.S_ISREG(os.fstat(fh.fileno()).st_mode):
                return None
            head = fh.read(HEADER_BYTES)
            found = _digest_line(head)
            if found is None:
                return None
            start, end, digest = found
            cap = file_limit(head)[0]
            sha = hashlib.sha256(head[:start])
            sha.update(head[end:])
            if not hash_blocks(fh, sha, len(head), cap):
                return True
    except OSError:
        return None
    return sha.hexdigest() != digest
