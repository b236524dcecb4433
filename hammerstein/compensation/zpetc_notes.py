"""What the ZPETC inverse leaves of a reference: its gain per frequency and ``compensate``'s note.

ZPETC (Tomizuka, J. Dyn. Sys., Meas., Control 109(1), 65-68, 1987) replaces
each zero of G it cannot cancel by a zero-phase factor; at a periodic
reference's main frequency (:func:`hammerstein.compensation.shaping.main_frequency`)
the drive then draws that gain of the reference, which ``compensate`` names.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation.shaping import main_frequency

__all__ = ["ZPETC_NOTE_ERROR", "zpetc_gain", "zpetc_note"]


#: ``compensate`` names the ZPETC inverse's gain error at the reference's main frequency from
#: this relative deviation (:func:`zpetc_note`).
ZPETC_NOTE_ERROR = 0.01


def zpetc_gain(unacceptable_zeros, sampling_period, frequencies):
    """The gain ``|b(e^jwT)|^2 / b(1)^2`` the ZPETC inverse leaves at each frequency.

    ZPETC replaces each zero ``beta`` of G it cannot cancel by a zero-phase factor, so that
    ``G F = |b(e^jwT)|^2 / b(1)^2 I`` with ``b(z) = prod (z - beta)`` (Tomizuka, J. Dyn.
    Sys., Meas., Control 109(1), 65-68, 1987; :class:`hammerstein.compensation.inversion.ZPETCInverse`).

    Parameters
    ----------
    unacceptable_zeros : array_like, complex, shape (n_zeros,)
        The zeros of G the inverse approximates (``ZPETCInverse.unacceptable_zeros``).
    sampling_period : float
        T [s].
    frequencies : array_like, shape (n_freq,)
        [Hz].

    Returns
    -------
    numpy.ndarray, shape (n_freq,)
        1 at 0 Hz; 1 everywhere without such zeros.

    Examples
    --------
    >>> float(zpetc_gain([-0.97], 5e-5, [0.0])[0])
    1.0
    >>> round(float(zpetc_gain([-0.97], 5e-5, [300.0])[0]) - 1, 4)   # 2 beta (1 - cos wT) / (1 - beta)^2
    -0.0022
    """
    beta = np.asarray(unacceptable_zeros, dtype=complex).ravel()
    z = np.exp(2j * np.pi * np.asarray(frequencies, dtype=float) * float(sampling_period))
    if beta.size == 0:
        return np.ones(z.shape)
    b = np.prod(z[:, None] - beta[None, :], axis=1)
    return np.abs(b) ** 2 / np.abs(np.prod(1.0 - beta)) ** 2


def zpetc_note(unacceptable_zeros, sampling_period, reference, period_samples,
               limit=ZPETC_NOTE_ERROR):
    """A note when the ZPETC inverse misses a periodic reference's main frequency, or None.

    Its gain there (:func:`zpetc_gain`) is what the drive draws of the reference's
    fundamental; beyond ``limit`` from 1 the zero of G nearest that frequency on the unit
    circle is named, and the stable inversion, which inverts such zeros exactly.

    Parameters
    ----------
    unacceptable_zeros : array_like, complex
        The zeros of G the inverse approximates.
    sampling_period : float
        T [s].
    reference : array_like, shape (p, n_samples)
        [µm].
    period_samples : int or None
        One period [samples]; None: not periodic (None returned).
    limit : float
        Relative gain error from which the note is given.

    Returns
    -------
    str or None

    Examples
    --------
    >>> T = 1e-4
    >>> t = np.arange(4000) * T
    >>> ref = np.sin(2 * np.pi * 150.0 * t)[None, :]
    >>> beta = 1.004 * np.exp(2j * np.pi * 375.0 * T * np.array([1, -1]))
    >>> zpetc_note(beta, T, ref, 200).split(":")[0]
    "the ZPETC inverse passes the reference's main frequency (150 Hz) at 0.705 of its gain"
    """
    beta = np.asarray(unacceptable_zeros, dtype=complex).ravel()
    T = float(sampling_period)
    f0 = None if beta.size == 0 else main_frequency(reference, period_samples, T)
    if f0 is None:
        return None
    g = float(zpetc_gain(beta, T, [f0])[0])
    if abs(g - 1.0) <= limit:
        return None
    hz = np.abs(np.angle(beta)) / (2 * np.pi * T)
    k = int(np.argmin(np.abs(np.abs(beta) - 1.0) + 1e-6 * np.abs(hz - f0)))
    where = (f"z = {beta[k].real:.4g}, on the real axis" if abs(beta[k].imag) < 1e-12 else
             f"|z| = {abs(beta[k]):.4g} at {hz[k]:.4g} Hz")
    return (f"the ZPETC inverse passes the reference's main frequency ({f0:.4g} Hz) at {g:.3g} "
            f"of its gain: G has a zero it cannot cancel ({where}), "
            f"and the drive draws about {g:.3g} of the reference there; `--inversion stable` "
            f"inverts it exactly (`export --inversion stable` deploys it)")
