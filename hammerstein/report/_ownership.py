"""Who owns a report directory: its marker, its manifest, and the inputs it must not hold.

Behind :mod:`hammerstein.runner`. Every report directory carries a
:data:`MARKER` file: ``hammerstein <version>``, the ``owner`` line of the run
that wrote it, then ``manifest`` and one ``file <relative path>`` line per
file of the report. A marked directory holding entries its manifest does not
list (a user's notes) is moved aside (never deleted) only with ``force``; a marker without a
manifest (an older version) keeps the older rule (replaced). A directory
holding one of the scenario's inputs is never replaced.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from hammerstein.core.files import bounded_read_text, escape, file_digest, safe_write

__all__ = ["MARKER", "ownership_problem", "input_problem", "write_manifest", "report_manifest",
           "unlisted_entries", "manifest_text", "kept_name", "kept_note", "digests_of"]

#: File in every report directory: the project wrote it (``run`` may replace it).
MARKER = ".hammerstein-report"


def _is_ours(target):
    """Whether ``target`` is a report directory the project wrote (marker) or an empty directory."""
    if target.is_symlink() or not target.is_dir():
        return False
    if (target / MARKER).is_file() and not (target / MARKER).is_symlink():
        return True
    return not any(target.iterdir())


def _marker_lines(target):
    """The manifest's lines of the marker of ``target`` (after ``manifest``), or None."""
    try:
        text = bounded_read_text(target / MARKER, "toml", "report marker")
    except (OSError, ValueError):
        return None
    lines = text.splitlines()
    if "manifest" not in lines:
        return None
    return lines[lines.index("manifest") + 1:]


def _manifest(target):
    """The relative paths the marker of ``target`` lists (its manifest), or None (an older report)."""
    lines = _marker_lines(target)
    if lines is None:
        return None
    return {ln[5:] for ln in lines if ln.startswith("file ")}


def _digests(target):
    """{relative path: SHA-256} the marker of ``target`` keeps (empty for an older marker)."""
    out = {}
    for ln in _marker_lines(target) or []:
        if ln.startswith("sha256 "):
            digest, _, rel = ln[7:].partition(" ")
            out[rel] = digest
    return out


def _changed(target):
    """Listed files of ``target`` whose bytes differ from those the manifest's digests keep."""
    return sorted(rel for rel, digest in _digests(target).items()
                  if os.path.isfile(target / rel) and not os.path.islink(target / rel)
                  and file_digest(target / rel) != digest)


def _unlisted(target):
    """Entries of the marked ``target`` its manifest does not list, then the listed files changed
    since they were written (``<path> (changed)``); none without a manifest."""
    listed = _manifest(target)
    if listed is None:
        return []
    dirs = {p.as_posix() for f in listed for p in Path(f).parents if p != Path(".")}
    extra = []
    for d, dirnames, names in os.walk(target):     # links are not followed
        for n in sorted(dirnames) + sorted(names):
            full = os.path.join(d, n)
            rel = Path(os.path.relpath(full, target)).as_posix()
            is_dir = n in dirnames and not os.path.islink(full)
            if rel == MARKER or (rel in dirs if is_dir else rel in listed):
                continue
            extra.append(rel)
            if is_dir:
                dirnames.remove(n)                  # named once, not each file under it
    return extra + [f"{rel} (changed)" for rel in _changed(target)]


def report_manifest(target):
    """The relative paths the marker of the report directory ``target`` lists, or None.

    Parameters
    ----------
    target : pathlib.Path
        A report directory.

    Returns
    -------
    set of str or None
        None without a marker, or with a marker that lists nothing (an older
        version's, or ``evaluate``'s before it wrote one).
    """
    if not (Path(target) / MARKER).is_file():
        return None
    return _manifest(Path(target))


def unlisted_entries(target):
    """Entries of the marked report directory ``target`` its manifest does not list.

    Parameters
    ----------
    target : pathlib.Path

    Returns
    -------
    list of str
        Relative paths (a directory named once); empty without a manifest.
    """
    return _unlisted(Path(target))


def manifest_text(version, files, token=None, digests=None):
    """The marker of a report directory listing ``files`` (relative paths).

    Parameters
    ----------
    version : str
    files : iterable of str
    token : str, optional
        The ``owner`` line.
    digests : dict of str to str, optional
        {relative path: SHA-256} of the files as written: a later ``run``,
        ``check --out`` or ``evaluate`` into the directory then replaces no
        file the user has edited since (``report.md`` annotated by hand).

    Returns
    -------
    str
    """
    digests = digests or {}
    return (f"hammerstein {version}\n" + (f"owner {token}\n" if token else "") + "manifest\n"
            + "".join(f"file {f}\n" for f in sorted(files) if f != MARKER)
            + "".join(f"sha256 {digests[f]} {f}\n" for f in sorted(digests)
                      if f != MARKER and digests[f]))


def digests_of(directory, files):
    """{relative path: SHA-256} of ``files`` (relative to ``directory``) that are regular files.

    Parameters
    ----------
    directory : str or pathlib.Path
    files : iterable of str

    Returns
    -------
    dict of str to str
    """
    directory = Path(directory)
    return {f: file_digest(directory / f) for f in files
            if (directory / f).is_file() and not (directory / f).is_symlink()}


def write_manifest(tmp, version, token=None):
    """Rewrite the marker of the finished report directory ``tmp`` with the files it holds.

    Parameters
    ----------
    tmp : str or pathlib.Path
        The report, complete (in its temporary directory).
    version : str
        The version written on the marker's first line.
    token : str, optional
        The owner token of the temporary directory (its ``owner`` line).
    """
    tmp = Path(tmp)
    wrote = sorted(Path(os.path.relpath(os.path.join(d, n), tmp)).as_posix()
                   for d, _, names in os.walk(tmp) for n in names)
    safe_write(tmp / MARKER, manifest_text(version, wrote, token, digests_of(tmp, wrote)),
               "report marker")


def _entry(path):
    """Where the directory entry ``path`` is (its directories resolved, not its last name)."""
    head, name = os.path.split(os.path.abspath(path))
    return os.path.join(os.path.realpath(head), name)


def input_problem(target, inputs):
    """One line naming a file of ``inputs`` that replacing ``target`` would delete, or None.

    A file is found by its path (resolved, and the entry named, a link
    included) under ``target`` or by its inode among the files under it (a
    hard link), links inside ``target`` not followed (what a replacement
    removes). A link at ``target`` itself is renamed away, not followed.

    Parameters
    ----------
    target : pathlib.Path
        The report directory to be replaced.
    inputs : iterable of str or pathlib.Path
        Files the command reads.

    Returns
    -------
    str or None
    """
    if not inputs or not os.path.lexists(target) or os.path.islink(target):
        return None
    root = os.path.realpath(target)
    inside = root.rstrip(os.sep) + os.sep
    wanted = {}
    for given in inputs:
        if not os.path.lexists(given):       # a name that is no file: nothing to delete
            continue
        try:
            places = (os.path.realpath(given), _entry(given))
        except (OSError, ValueError):
            continue
        if any(p == root or p.startswith(inside) for p in places):
            return _input_message(target, given)
        try:
            st = os.stat(given)
            wanted.setdefault((st.st_dev, st.st_ino), given)
        except (OSError, ValueError):
            pass
    found = [target] if not os.path.isdir(target) else \
        (os.path.join(d, n) for d, _, names in os.walk(target) for n in names)
    for f in found:
        try:
            st = os.lstat(f)
        except OSError:
            continue
        if (st.st_dev, st.st_ino) in wanted:
            return _input_message(target, f"{f} (a hard link to {wanted[(st.st_dev, st.st_ino)]})")
    return None


def _input_message(target, given):
    return (f"{escape(target)}: holds {escape(given)}, which this scenario reads; the report "
            f"would replace {escape(target)} and delete it (an input is never an output): move "
            f"the file out of {escape(target)} or choose another --out")


def ownership_problem(target, force, inputs=()):
    """Why the report directory ``target`` may not be replaced (one line), or None.

    ``inputs`` (the files the scenario reads) are never replaced, with or
    without ``force``; a marked directory holding entries its manifest does
    not list is replaced only with ``force``.

    Parameters
    ----------
    target : pathlib.Path
        ``out_dir/<scenario name>``.
    force : bool
        Write the report although ``target`` holds what hammerstein did not write
        (the runner moves it aside, never deletes it; never an input).
    inputs : iterable of str or pathlib.Path
        The scenario file and the files it names.

    Returns
    -------
    str or None
    """
    problem = input_problem(target, inputs)
    if problem or force or not os.path.lexists(target):
        return problem
    if _is_ours(target):
        extra = _unlisted(target)
        if not extra:
            return None
        more = f" and {len(extra) - 3} more" if len(extra) > 3 else ""
        changed = any(e.endswith(" (changed)") for e in extra)
        what = ("hammerstein did not write or that changed since it wrote them" if changed else
                "hammerstein did not write")
        where = (f"not in its {MARKER} or not as it keeps them" if changed else
                 f"not in its {MARKER}")
        return (f"{escape(target)}: holds {len(extra)} file(s) {what} "
                f"({', '.join(escape(e) for e in extra[:3])}{more}; {where}); move "
                f"them away, choose another --out, or use --force to move it aside (never deleted) "
                f"and write the report")
    what = ("a symbolic link" if target.is_symlink() else
            "a directory hammerstein did not write" if target.is_dir() else
            "a file" if target.is_file() else "not a directory")
    return (f"{target}: exists and is {what} (no {MARKER} file); move it away, choose another "
            f"--out, or use --force to move it aside (never deleted) and write the report")


def kept_name(target):
    """A new name beside ``target`` for what ``--force`` moves aside: ``<name>.kept-<time>[-k]``."""
    stem = f"{target.name[:200]}.kept-{time.strftime('%Y%m%dT%H%M%S')}"
    k, kept = 1, target.with_name(stem)
    while os.path.lexists(kept):
        k += 1
        kept = target.with_name(f"{stem}-{k}")
    return kept


def kept_note(out_dir, kept):
    """The note saying what ``--force`` moved aside from ``out_dir`` to ``kept`` (one line).

    Worded by what ``kept`` is once moved: a directory "held files
    hammerstein did not write"; a file, a link or anything else stood where
    the report goes (a plain file at ``DIR/<scenario>`` was said to have
    "held files").
    """
    kept = Path(kept)
    if kept.is_dir() and not kept.is_symlink():
        what, where = "held files hammerstein did not write or changed", f"{escape(kept)}/"
    else:
        what = ("was a symbolic link" if kept.is_symlink() else
                "was a file hammerstein did not write" if kept.is_file() else
                "was not a directory")
        where = escape(kept)
    return (f"note: the earlier {escape(out_dir)} {what}: --force moved it to {where} "
            f"(nothing deleted)")
