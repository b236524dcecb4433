"""Every error and warning class of hammerstein, in one place.

All errors derive from :class:`HammersteinError`, so one ``except
hammerstein.HammersteinError`` catches whatever the package raises on bad
input; all warnings derive from :class:`HammersteinWarning`. Each class also
keeps the built-in base it had before (:class:`ValueError` for invalid input,
:class:`RuntimeError` for a divergence during a simulation,
:class:`UserWarning` for warnings), so existing ``except ValueError`` clauses
keep working.

This module imports nothing (not even numpy): it is the bottom layer, below
:mod:`hammerstein.simulation` and :mod:`hammerstein.core`.

Examples
--------
>>> from hammerstein.exceptions import HammersteinError, HysteresisError
>>> issubclass(HysteresisError, HammersteinError), issubclass(HysteresisError, ValueError)
(True, True)
"""

from __future__ import annotations

__all__ = [
    "HammersteinError",
    "OutputError",
    "HammersteinWarning",
    "HysteresisError",
    "SignalError",
    "CompensatorError",
    "CompensatorDivergence",
    "ConvergenceWarning",
    "RangeWarning",
    "DynamicsError",
    "DynamicsWarning",
    "PresetError",
    "IdentificationError",
    "DataFileError",
    "ScenarioError",
    "BaselineError",
    "Invalid",
    "NestedInvalid",
    "FileLimitError",
    "ExportError",
    "AmplifierError",
    "AmplifierWarning",
    "FeedbackError",
]


class HammersteinError(Exception):
    """Base class of every error raised by hammerstein."""


class HammersteinWarning(UserWarning):
    """Base class of every warning emitted by hammerstein."""


# -- simulation and core ------------------------------------------------------------
class HysteresisError(HammersteinError, ValueError):
    """Invalid hysteresis model parameters or signals (names the field)."""


class SignalError(HammersteinError, ValueError):
    """Invalid reference or drive parameters (the message names the field)."""


class CompensatorError(HammersteinError, ValueError):
    """Invalid compensator parameters, or a law that cannot converge."""


class CompensatorDivergence(HammersteinError, RuntimeError):
    """The compensator output left every bound during a simulation.

    Parameters
    ----------
    sample : int
        Index of the first sample where the divergence was detected.
    reason : str
        What was detected (non-finite or out-of-bound input).

    Attributes
    ----------
    sample : int
        Index of the first sample where the divergence was detected.
    reason : str
        What was detected (non-finite or out-of-bound input).
    """

    def __init__(self, sample, reason):
        self.sample = int(sample)
        self.reason = str(reason)
        super().__init__(f"compensator diverged at sample {self.sample}: {self.reason}")


class ConvergenceWarning(HammersteinWarning):
    """The compensator's fixed-point iteration may not converge."""


class RangeWarning(HammersteinWarning):
    """A reference leaves the output range the model was identified on."""


class DynamicsError(HammersteinError, ValueError):
    """Invalid linear-dynamics parameters (names the field)."""


class DynamicsWarning(HammersteinWarning):
    """Linear dynamics that their sampling cannot represent (a mode at or above Nyquist)."""


class PresetError(HammersteinError, ValueError):
    """A model or preset file is missing, malformed or inconsistent."""


class IdentificationError(HammersteinError, ValueError):
    """The record or the options do not allow an identification (says why)."""


class DataFileError(HammersteinError, ValueError):
    """A data file cannot be read as a record (names the file and the problem)."""


# -- scenarios and the regression gate ---------------------------------------------
class ScenarioError(HammersteinError, ValueError):
    """A scenario file has one or more problems.

    Parameters
    ----------
    problems : iterable of str
        One ``file: key: message`` line per problem.

    Attributes
    ----------
    problems : list of str
        One ``file: key: message`` line per problem, each once, in the order first found.
    """

    def __init__(self, problems):
        # a case that overrides the plant loads its preset again: a missing preset was
        # named twice, word for word
        self.problems = list(dict.fromkeys(problems))
        super().__init__("\n".join(self.problems))


class BaselineError(HammersteinError, ValueError):
    """A baseline, metrics table or tolerance specification is unusable."""


class Invalid(HammersteinError, ValueError):
    """Raised by a scenario field checker; the message says what was expected.

    Caught by the scenario validation, which turns it into one line of a
    :class:`ScenarioError`.
    """


class NestedInvalid(Invalid):
    """A nested scenario table has problems.

    Parameters
    ----------
    problems : iterable of (str, str)
        ``(key, message)`` per problem.

    Attributes
    ----------
    problems : list of (str, str)
        ``(key, message)`` per problem.
    """

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("; ".join(f"{k}: {m}" for k, m in self.problems))


class FileLimitError(HammersteinError, ValueError):
    """A file cannot be read or written safely: not a regular file, or larger than its size
    limit (:mod:`hammerstein.core.files`; the message names the file and why)."""


class OutputError(FileLimitError, OSError):
    """An output file may not or could not be written: it is an input of the command, it
    resolves outside the output directory, its name is not acceptable, or the write failed (a
    full disk); the message names the file (:func:`hammerstein.core.files.safe_write`).

    Also an :class:`OSError`, so handlers of failed writes catch it."""


class ExportError(HammersteinError, ValueError):
    """A compensator, model or option cannot be exported as C code or an FMU
    (:mod:`hammerstein.export`; the message names what cannot be and why)."""
class AmplifierError(HammersteinError, ValueError):
    """A drive the amplifier cannot deliver (``limits = "error"``), or a bad ``[amplifier]``
    table (the message names the input, the peak and the limit, or the key)."""


class AmplifierWarning(HammersteinWarning):
    """A drive beyond the amplifier's range or slew rate (``limits = "warn"``)."""


class FeedbackError(HammersteinError, ValueError):
    """A feedback controller, sensor or loop that cannot be designed, discretised or run
    (:mod:`hammerstein.compensation.feedback`; the message names the key and why)."""
