"""Owners of temporaries: host, PID namespace, process start and call (behind :mod:`hammerstein.core.files`).

A temporary's name carries an owner token; :func:`owner_alive` tells a
stale temporary (its process gone) from one still being written.
"""

from __future__ import annotations

import os
import secrets

from hammerstein.core._strings import escape


# -- owners of temporaries: host, PID namespace, process start, call ----------------------
_LIVE = set()          # nonces of the temporaries this process is working on


def _pid_namespace():
    try:
        return str(os.stat("/proc/self/ns/pid").st_ino)
    except OSError:
        return "-"


def _start_time(pid):
    """Start time of process ``pid`` (clock ticks since boot, /proc), None if gone, '-' if unknown."""
    try:
        with open(f"/proc/{int(pid)}/stat", "rb") as fh:
            data = fh.read(4096)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, OverflowError):
        return "-"
    try:
        return data.rsplit(b")", 1)[1].split()[19].decode()
    except (IndexError, UnicodeDecodeError):
        return "-"


def owner_token():
    """A new owner token for a temporary: this host, PID namespace, process and call.

    Registered as live in this process until :func:`release_owner`; a
    temporary is judged stale by :func:`owner_alive` from its token, never
    from its PID alone (two PID namespaces share PIDs, two threads share one).

    Returns
    -------
    str
        ``host=<hostname> pidns=<inode> pid=<pid> start=<ticks> nonce=<hex>``.
    """
    nonce = secrets.token_hex(8)
    _LIVE.add(nonce)
    host = escape(os.uname().nodename if hasattr(os, "uname") else "-", 100).replace(" ", "_")
    return (f"host={host} pidns={_pid_namespace()} pid={os.getpid()} "
            f"start={_start_time(os.getpid())} nonce={nonce}")


def release_owner(token):
    """Forget a token of :func:`owner_token` (its temporary is gone or renamed).

    Parameters
    ----------
    token : str
    """
    _LIVE.discard(parse_owner(token).get("nonce"))


def parse_owner(token):
    """The fields of a token of :func:`owner_token` (``{}`` when it is not one).

    Parameters
    ----------
    token : str

    Returns
    -------
    dict of str to str
    """
    fields = dict(p.split("=", 1) for p in str(token).split() if "=" in p)
    return fields if {"host", "pidns", "pid", "start", "nonce"} <= fields.keys() else {}


def owner_alive(token):
    """Whether the owner of a temporary may still be working on it.

    Parameters
    ----------
    token : str
        From :func:`owner_token`.

    Returns
    -------
    bool or None
        False when the owner is certainly gone (same host and PID
        namespace, and its process has exited or its PID now belongs to a
        process started at another time, or it is this process and the call
        is over); True when it is alive; None when it cannot be told
        (another host or PID namespace, no /proc): keep the temporary.
    """
    f = parse_owner(token)
    if not f:
        return None
    host = escape(os.uname().nodename if hasattr(os, "uname") else "-", 100).replace(" ", "_")
    if f["host"] != host or f["pidns"] != _pid_namespace() or f["pidns"] == "-":
        return None
    if not (f["pid"].isascii() and f["pid"].isdigit()):
        return None
    start = _start_time(f["pid"])
    if start is None:
        return False
    if start == "-" or f["start"] == "-":
        return None
    if start != f["start"]:
        return False           # the PID was reused by a later process
    if int(f["pid"]) == os.getpid():
        return f["nonce"] in _LIVE
    return True
