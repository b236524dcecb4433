"""One checker of the numbers read from files and given to the API.

TOML integers are Python ints of any size (``10**400`` is valid TOML), and
a float may be subnormal (``5e-324``), so ``numpy.isfinite`` (which refuses
a huge int with a TypeError) and a plain ``> 0`` test (which lets a
subnormal through to a division that overflows) are not enough.
:func:`is_number` accepts a real, finite, normal-or-zero number of any
Python or numpy numeric type except bool; :func:`check_array` applies the
same rule to an array of the API (NaN, infinity, complex values and shape
mismatches refused with a message naming the argument);
:func:`integer_problem` and :func:`check_integer` are the integer checker of
both the scenario files and the API (``iterations = 10**9`` refused with the
maximum named); :func:`check_samples` is the budget every command and API
function checks before allocating a record (``HAMMERSTEIN_MAX_RECORD_SAMPLES``).
"""

from __future__ import annotations

import math
import numbers
import os
import sys

import numpy as np

__all__ = ["is_number", "number_problem", "check_array", "integer_problem", "check_integer",
           "magnitude_problem", "FLOAT_MAX", "FLOAT_TINY", "MAX_ITERATIONS", "MAX_MAGNITUDE", "MAX_HYSTERONS",
           "RECORD_SAMPLES_ENV", "DEFAULT_RECORD_SAMPLES", "max_record_samples", "samples_problem",
           "check_samples", "PLAUSIBLE", "plausibility_problem"]

#: Largest finite float64; a Python int beyond it cannot become a float.
FLOAT_MAX = sys.float_info.max
#: Smallest normal float64: a non-zero magnitude below it is subnormal (refused).
FLOAT_TINY = sys.float_info.min
#: Largest magnitude of a signal value (data file, API array, simulated output or
#: voltage): beyond ``sqrt(FLOAT_MAX)`` = 1.34e154 the squares of an RMS overflow to
#: inf and LAPACK's scaling (DLASCL) fails, so 1e150 leaves room for sums over
#: 1e8 samples. No actuator moves 1e150 µm.
MAX_MAGNITUDE = 1e150
#: Most hysterons per component of an identified model (scenario files, CLI and API alike).
MAX_HYSTERONS = 100
#: Most fixed-point (or learning) iterations per sample of a compensator, in a
#: scenario file, on the command line and through the API alike.
MAX_ITERATIONS = 100


def number_problem(v):
    """Why ``v`` is not a usable real number (a short phrase), or None.

    Parameters
    ----------
    v : object

    Returns
    -------
    str or None
        ``"not a number"``, ``"not finite"``, ``"beyond the float range"``
        (a Python int over 1.8e308) or ``"subnormal"`` (0 < |v| < 2.2e-308).

    Examples
    --------
    >>> [number_problem(v) for v in (1, 2.5, True, 10**400, float("nan"), 5e-324)]
    [None, None, 'not a number', 'beyond the float range', 'not finite', 'subnormal']
    """
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        return "not a number"
    if isinstance(v, numbers.Integral):
        try:
            x = float(v)
        except OverflowError:
            return "beyond the float range"
    else:
        x = float(v)
    if not math.isfinite(x):
        return "not finite"
    if x != 0.0 and abs(x) < FLOAT_TINY:
        return "subnormal"
    return None


def is_number(v):
    """Whether ``v`` is a real, finite, non-subnormal number (bool excluded).

    Parameters
    ----------
    v : object

    Returns
    -------
    bool
    """
    return number_problem(v) is None


def check_array(a, name, error=ValueError, ndim=None, length=None):
    """``a`` as a finite real float64 array, or an error naming ``name``.

    Parameters
    ----------
    a : array_like
    name : str
        Argument name for messages (``"u"``, ``"records[0].y"``).
    error : type
        Exception class raised.
    ndim : int, optional
        Required number of dimensions.
    length : int, optional
        Required length of the last axis (samples), e.g. that of the input.

    Returns
    -------
    numpy.ndarray
        float64.

    Raises
    ------
    error
        Complex values, non-numeric data, NaN or infinite values (the first
        index named), a magnitude beyond :data:`MAX_MAGNITUDE`, a wrong
        number of dimensions or a length mismatch.
    """
    arr = np.asarray(a)
    if np.iscomplexobj(arr):
        raise error(f"{name}: expected real values, found complex ones")
    try:
        arr = arr.astype(float)
    except (TypeError, ValueError, OverflowError):
        raise error(f"{name}: expected numbers") from None
    if ndim is not None and arr.ndim != ndim:
        raise error(f"{name}: expected {ndim} dimension(s), found shape {arr.shape}")
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        raise error(f"{name}: non-finite value {arr[idx]} at index {idx if len(idx) > 1 else idx[0]}")
    problem = magnitude_problem(arr)
    if problem:
        raise error(f"{name}: {problem}")
    if length is not None and arr.shape[-1] != length:
        raise error(f"{name}: {arr.shape[-1]} samples, expected {length} (as the other signal)")
    return arr


def _short(v, n=60):
    """``repr(v)``, or the digit count of an integer longer than ``n`` digits."""
    text = repr(v)
    if len(text) <= n:
        return text
    if isinstance(v, numbers.Integral):
        return f"{'-' if v < 0 else ''}an integer of {len(str(abs(int(v))))} digits"
    return text[:n] + "..."


def integer_problem(v, minimum=0, maximum=None):
    """Why ``v`` is not an integer in ``minimum..maximum`` (a phrase), or None.

    Python ints of any size and numpy integers are integers; bools, floats
    (even ``3.0``) and strings are not.

    Parameters
    ----------
    v : object
        The value.
    minimum : int
        Smallest accepted value.
    maximum : int, optional
        Largest accepted value.

    Returns
    -------
    str or None
        ``"expected an integer >= 1, found 0"`` (no maximum) or
        ``"expected an integer 1..100, found 0"``: the bounds there are, whichever is missed.

    Examples
    --------
    >>> integer_problem(10**9, 1, MAX_ITERATIONS)
    'expected an integer 1..100, found 1000000000'
    >>> integer_problem(0, 1, MAX_ITERATIONS)
    'expected an integer 1..100, found 0'
    >>> integer_problem(3, 1, 100) is None
    True
    """
    bounds = f">= {minimum}" if maximum is None else f"{minimum}..{maximum}"
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Integral):
        return f"expected an integer {bounds}, found {_short(v)}"
    if v < minimum or (maximum is not None and v > maximum):   # both bounds, either side
        return f"expected an integer {bounds}, found {_short(int(v))}"
    return None


def check_integer(v, name, minimum=0, maximum=None, error=ValueError):
    """``v`` as a Python int in ``minimum..maximum``, or an error naming ``name``.

    Parameters
    ----------
    v : object
        The value (an int or numpy integer).
    name : str
        Field or argument name for the message (``"iterations"``).
    minimum, maximum : int
        Bounds (``maximum`` optional), inclusive.
    error : type
        Exception class raised.

    Returns
    -------
    int

    Raises
    ------
    error
        ``"<name>: expected an integer 1..100, found 1000000000"``.

    Examples
    --------
    >>> check_integer(10**9, "iterations", 1, MAX_ITERATIONS)
    Traceback (most recent call last):
    ...
    ValueError: iterations: expected an integer 1..100, found 1000000000
    """
    problem = integer_problem(v, minimum, maximum)
    if problem:
        raise error(f"{name}: {problem}")
    return int(v)


def magnitude_problem(a, unit=""):
    """Why the values of ``a`` are too large to compute with (a phrase), or None.

    NaN values are skipped (they mark a divergence); an infinite value or a
    magnitude beyond :data:`MAX_MAGNITUDE` is a problem: the squares of the
    metrics would overflow and a linear solve would fail inside LAPACK.

    Parameters
    ----------
    a : array_like
        Values of any shape.
    unit : str
        Unit appended to the value in the message (``"µm"``).

    Returns
    -------
    str or None
        ``"3.04e+301 µm at index (0, 17) is beyond the limit 1e+150"``.

    Examples
    --------
    >>> magnitude_problem([[1.0, -2e300]], "V")
    '-2e+300 V at index (0, 1) is beyond the limit 1e+150'
    >>> magnitude_problem([1.0, float("nan")]) is None
    True
    """
    arr = np.asarray(a, dtype=float)
    with np.errstate(invalid="ignore"):
        big = np.abs(arr) > MAX_MAGNITUDE     # False for NaN, True for inf
    if not big.any():
        return None
    idx = tuple(int(i) for i in np.argwhere(big)[0])
    where = idx[0] if len(idx) == 1 else idx
    return (f"{arr[idx]:.3g}{' ' + unit if unit else ''} at index {where} is beyond the limit "
            f"{MAX_MAGNITUDE:.0e}")


#: Environment variable that raises :func:`max_record_samples` (a positive integer).
RECORD_SAMPLES_ENV = "HAMMERSTEIN_MAX_RECORD_SAMPLES"
#: Default largest record a command or API function allocates: 10 million samples
#: (80 MB per signal row; 500 s at T = 50 µs).
DEFAULT_RECORD_SAMPLES = 10_000_000


def max_record_samples():
    """Largest number of samples of one record (per signal), before anything is allocated.

    Returns
    -------
    int
        ``HAMMERSTEIN_MAX_RECORD_SAMPLES`` when it is a positive integer
        (ASCII digits), else :data:`DEFAULT_RECORD_SAMPLES`.
    """
    text = os.environ.get(RECORD_SAMPLES_ENV, "").strip()
    if text.isascii() and text.isdigit() and int(text) > 0:
        return int(text)
    return DEFAULT_RECORD_SAMPLES


def samples_problem(n, what, sampling_period=None, rows=1):
    """Why a record of ``n`` samples must not be allocated (one line), or None.

    Parameters
    ----------
    n : float or int
        Samples the record would have, computed from the arguments before
        any allocation (``duration / T``); may be a float, ``inf`` or NaN.
    what : str
        What asks for it, named in the message (``"--hold"``,
        ``"--reference: ref.csv"``).
    sampling_period : float, optional
        T [s], to say how long the largest record is.
    rows : int
        Signals of the record (the bytes named are ``8 n rows``).

    Returns
    -------
    str or None
        ``"--hold: the record would have 1.8e+14 samples (2.9 PB); expected
        at most 1e+07 (500 s at T = 5e-05 s; raise it with
        HAMMERSTEIN_MAX_RECORD_SAMPLES=N)"``.

    Examples
    --------
    >>> samples_problem(1e3, "--hold") is None
    True
    >>> samples_problem(float("inf"), "--f-min")
    '--f-min: the record would have inf samples; expected at most 1e+07 (raise it with HAMMERSTEIN_MAX_RECORD_SAMPLES=N)'
    """
    cap = max_record_samples()
    try:
        n = float(n)
    except OverflowError:
        n = math.inf
    if n <= cap:                    # False for NaN
        return None
    size = ""
    if math.isfinite(n):
        b = 8.0 * n * max(int(rows), 1)
        unit = next(((u, s) for u, s in (("PB", 1e15), ("TB", 1e12), ("GB", 1e9), ("MB", 1e6))
                     if b >= s), ("bytes", 1))
        size = f" ({b / unit[1]:.3g} {unit[0]})"
    span = ""
    if sampling_period is not None and is_number(sampling_period) and sampling_period > 0:
        span = f"{cap * float(sampling_period):.3g} s at T = {float(sampling_period):g} s; "
    text = os.environ.get(RECORD_SAMPLES_ENV)
    ignored = "" if text is None or max_record_samples() != DEFAULT_RECORD_SAMPLES or \
        text.strip() == str(DEFAULT_RECORD_SAMPLES) else \
        f"; its value {text[:40]!r} is not a positive integer, the default applies"
    return (f"{what}: the record would have {n:.3g} samples{size}; expected at most {cap:.3g} "
            f"({span}raise it with {RECORD_SAMPLES_ENV}=N{ignored})")


def check_samples(n, what, error=ValueError, sampling_period=None, rows=1):
    """``int(n)`` when a record of ``n`` samples is within the budget, else ``error``.

    The check every command and API function makes from its arguments
    (duration / sampling period, hold, periods, lowest frequency, file
    times) *before* allocating: an oversized request is refused at once,
    naming the limit and its override.

    Parameters
    ----------
    n : float or int
        Samples the record would have (``inf`` and NaN are refused).
    what : str
        The argument or file named in the message.
    error : type
        Exception class raised.
    sampling_period : float, optional
        T [s], for the message.
    rows : int
        Signals of the record, for the bytes in the message.

    Returns
    -------
    int

    Raises
    ------
    error
        Beyond :func:`max_record_samples`, or ``n`` not a number.

    Examples
    --------
    >>> check_samples(2000.0, "--periods")
    2000
    """
    problem = samples_problem(n, what, sampling_period, rows)
    if problem is None and isinstance(n, float) and not math.isfinite(n):
        problem = f"{what}: the record would have {n} samples"
    if problem:
        raise error(problem)
    return int(n)


#: Plausible magnitudes of a piezoelectric actuator's signals, per unit: ``(smallest
#: non-zero, largest)``. Beyond them a value is computed with but warned about, naming
#: the likely unit mistake.
PLAUSIBLE = {"µm": (1e-4, 1e4), "V": (None, 2e3), "Hz": (None, 1e5)}


def plausibility_problem(value, unit, what="value"):
    """Why a magnitude is implausible for a piezoelectric actuator (a warning), or None.

    Ranges (:data:`PLAUSIBLE`): displacements 0.1 nm to 10 mm (``µm``),
    voltages up to 2 kV (``V``), frequencies up to 100 kHz (``Hz``). The
    message names the likely unit mistake: metres or millimetres given for
    µm (too small), nanometres for µm (too large), millivolts for volts,
    rad/s for Hz.

    Parameters
    ----------
    value : float
        A peak magnitude (its absolute value is judged).
    unit : {'µm', 'V', 'Hz'}
    what : str
        What the value is, at the front of the message (``"reference peak"``).

    Returns
    -------
    str or None

    Examples
    --------
    >>> plausibility_problem(1e38, "µm", "amplitude")
    'amplitude 1e+38 µm is beyond 1e+04 µm (10 mm), implausible for a piezoelectric actuator; was it given in nm (1 µm = 1000 nm)?'
    >>> plausibility_problem(3e-5, "µm", "radius")
    'radius 3e-05 µm is below 0.0001 µm (0.1 nm), implausible for a piezoelectric actuator; was it given in m or mm (1 mm = 1000 µm)?'
    >>> plausibility_problem(150.0, "V") is None
    True
    """
    low, high = PLAUSIBLE[unit]
    v = abs(float(value))
    if not math.isfinite(v):
        return None     # the number checkers refuse it
    if high is not None and v > high:
        limit, slip = {"µm": ("1e+04 µm (10 mm)", "nm (1 µm = 1000 nm)"),
                       "V": (f"{high:g} V", "mV (1 V = 1000 mV)"),
                       "Hz": (f"{high:g} Hz", "rad/s (1 Hz = 2 pi rad/s)")}[unit]
        return (f"{what} {v:g} {unit} is beyond {limit}, implausible for a piezoelectric "
                f"actuator; was it given in {slip}?")
    if low is not None and 0 < v < low:
        return (f"{what} {v:g} {unit} is below {low:g} µm (0.1 nm), implausible for a "
                f"piezoelectric actuator; was it given in m or mm (1 mm = 1000 µm)?")
    return None
