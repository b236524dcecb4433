"""Warnings of many cases folded into one line per distinct message.

A sweep of 85 cases raises the same convergence warning 85 times, each with
its own numbers (``rho(I - K^-1 J) reaches 1.02`` in one case, ``1.03`` in
another), and the same dynamics warning for each compensator kind it
compares (``kind = 'per-axis'``, ``kind = 'static-gain'``).
:func:`group_warnings` groups the ``(case, message)`` pairs of a scenario by
their *template*, the message with every number and every single-quoted name
replaced by a placeholder (:func:`message_template`), and renders each group
once, with the numbers that differ between its cases shown as a range
(``1.02-1.03``) and the names as a list (``'per-axis'/'static-gain'``). The
command line prints the groups, and so do the sweep sections of ``report.md``
(naming the compensators, axes and frequencies of each group);
``warnings.csv`` keeps every case's own message.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

__all__ = ["WarningGroup", "message_template", "group_warnings"]

#: An unsigned decimal number (a sign is part of the text: ``K^-1`` keeps its ``-``).
_NUMBER = r"\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
#: A single-quoted name (a kind, a gain), as ``repr`` writes a string.
_NAME = r"'[^'\s]*'"
#: The variable parts of a message: names first, so that the digits of ``'mv-50Hz'``
#: stay in the name.
_SLOT = re.compile(f"{_NAME}|{_NUMBER}")


@dataclass
class WarningGroup:
    """One distinct warning of a scenario and the cases that raised it.

    Parameters
    ----------
    message : str
        The message; numbers that differ between the cases read ``lo-hi``
        (en dash).
    cases : list of str
        The cases, in order of first appearance.
    """

    message: str
    cases: list

    @property
    def count(self):
        """Number of cases."""
        return len(self.cases)

    def line(self, source, names=3):
        """``source: <cases>: message``; up to ``names`` case names, else a count.

        Parameters
        ----------
        source : str
            File name in front.
        names : int
            Most case names written out; more cases are written as ``N cases``.

        Returns
        -------
        str
        """
        who = ", ".join(self.cases) if self.count <= names else f"{self.count} cases"
        if self.count > 1 and self.count <= names:
            who = f"{self.count} cases ({who})"
        return f"{source}: {who}: {self.message}"


def message_template(message):
    """The message with runs of whitespace folded, every number replaced by ``#`` and every quoted name by ``'?'``.

    Parameters
    ----------
    message : object
        A warning message (converted with ``str``).

    Returns
    -------
    str
        The template: warnings that differ only in their numbers and
        quoted names share it.

    Examples
    --------
    >>> message_template("rho reaches 1.02 >= 1 at  50 Hz")
    'rho reaches # >= # at # Hz'
    >>> message_template("kind = 'mv-50Hz' is rate independent at 200 Hz")
    "kind = '?' is rate independent at # Hz"
    """
    return _SLOT.sub(lambda m: "'?'" if m.group().startswith("'") else "#",
                     " ".join(str(message).split()))


def _merge(messages):
    """One message from messages of the same template: differing numbers as ranges,
    differing names as a list in order of appearance."""
    texts = _SLOT.split(messages[0])
    slots = [_SLOT.findall(m) for m in messages]
    out = [texts[0]]
    for k in range(len(slots[0])):
        values = list(dict.fromkeys(s[k] for s in slots))
        if len(values) == 1:
            out.append(values[0])
        elif values[0].startswith("'"):
            out.append("/".join(values))
        elif re.search(r"(?:^|[\s(=,:])-$", out[-1]):     # a minus sign: negative numbers
            out[-1] = out[-1][:-1]
            lo = max(values, key=float)                   # the most negative first
            hi = min(values, key=float)
            out.append(f"-{lo} to -{hi}")
        else:
            lo = min(values, key=float)
            hi = max(values, key=float)
            out.append(f"{lo}\u2013{hi}")
        out.append(texts[k + 1])
    return "".join(out)


def group_warnings(pairs):
    """Group ``(case, message)`` pairs by message template.

    Parameters
    ----------
    pairs : iterable of (str, str)
        Case name and warning message (e.g.
        :attr:`hammerstein.runner.ScenarioOutcome.warnings`).

    Returns
    -------
    list of WarningGroup
        In order of first appearance; a case appears once per group even if
        it raised the message several times.

    Examples
    --------
    >>> g = group_warnings([("a", "rho 1.02 >= 1"), ("b", "rho 1.03 >= 1"), ("c", "range"),
    ...                     ("d", "kind = 'diagonal' at 50 Hz"), ("e", "kind = 'per-axis' at 50 Hz")])
    >>> [(x.count, x.message) for x in g]
    [(2, 'rho 1.02–1.03 >= 1'), (1, 'range'), (2, "kind = 'diagonal'/'per-axis' at 50 Hz")]
    """
    groups = {}
    for case, msg in pairs:
        msg = " ".join(str(msg).split())
        cases, messages = groups.setdefault(message_template(msg), ({}, []))
        cases.setdefault(str(case), None)
        messages.append(msg)
    return [WarningGroup(_merge(messages), list(cases)) for cases, messages in groups.values()]
