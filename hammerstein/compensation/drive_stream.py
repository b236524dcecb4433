"""Chunk-by-chunk drives: :class:`DriveStream` (behind :mod:`hammerstein.compensation.drive`).

A compensator's drive computed on a reference read or generated in pieces,
equal to the whole-record computation of
:func:`hammerstein.compensation.drive.drive_signal` for every chunk size.
"""

from __future__ import annotations

import numpy as np

from hammerstein.compensation._repeat import kept_samples
from hammerstein.compensation.hammerstein_compensator import continuation
from hammerstein.exceptions import CompensatorError

__all__ = ["DriveStream"]


def _fade_weights(start, n, fade):
    """Raised-cosine weights of samples ``start .. start + n - 1`` for a fade of ``fade`` samples."""
    k = np.arange(start, start + n)
    w = np.ones(n)
    inside = k < fade
    w[inside] = 0.5 * (1.0 - np.cos(np.pi * k[inside] / fade))
    return w


def _rest_state(compensator):
    """The compensator's own state at rest (its ``initial_state()``), else zeros.

    Zeros are the rest of a PI compensator, not of every compensator: the
    exact inverse of a Preisach model starts from the model's demagnetised
    hysterons (zero hysteron states would put the inverse on another memory
    than the actuator's and offset every level it tracks afterwards).
    """
    if hasattr(compensator, "initial_state"):
        return np.array(compensator.initial_state(), dtype=float)
    return np.zeros(compensator.n_states) if hasattr(compensator, "n_states") else None


class DriveStream:
    """A compensator's drive computed chunk by chunk, equal to the whole-record computation.

    Feed the reference with :meth:`push` (any chunk sizes, in order), then
    call :meth:`finish`; the concatenated returns are the commanded
    voltages of :func:`drive_signal` (before the amplifier).

    Parameters
    ----------
    compensator : object
        Any compensator (``simulate(reference, initial_state)``); a
        :class:`~hammerstein.compensation.hammerstein_compensator.HammersteinCompensator`
        with ``inversion = "zpetc"`` runs its preview (the first
        ``preview_samples`` voltages come once that much reference has
        arrived).
    fade_samples : int
        Fade-in from rest [samples] (0: none).
    period_samples : int, optional
        Period of a periodic reference: the ZPETC inverse's continuation
        past the end (see :func:`continuation`).

    Raises
    ------
    CompensatorError
        For a Hammerstein compensator with ``inversion = "stable"`` (whole
        record only: use :func:`drive_signal`).

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.io.presets import load_plant
    >>> from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
    >>> plant = load_plant("rakotondrabe-2dof")
    >>> comp = HammersteinCompensator(plant.hysteresis, plant.dynamics)
    >>> t = np.arange(2000) * plant.sampling_period
    >>> yr = 20 * np.vstack([np.cos(2 * np.pi * 100 * t), np.sin(2 * np.pi * 100 * t)])
    >>> stream = DriveStream(comp, fade_samples=200, period_samples=200)
    >>> parts = [stream.push(yr[:, i:i + 700]) for i in range(0, 2000, 700)] + [stream.finish()]
    >>> whole = drive_signal(comp, yr, plant.sampling_period, 200, fade_samples=200).inputs
    >>> float(np.max(np.abs(np.concatenate(parts, axis=1) - whole))) < 1e-9
    True
    """

    def __init__(self, compensator, fade_samples=0, period_samples=None):
        self.compensator = compensator
        self.fade = max(int(fade_samples), 0)
        self.period_samples = period_samples
        inv = getattr(compensator, "inverse", None)
        if hasattr(compensator, "run_reference") and inv is None:
            raise CompensatorError("inversion = 'stable' inverts the whole record at once: "
                                   "compute its drive with drive_signal(...), not in chunks")
        self._zpetc = inv is not None and hasattr(compensator, "run_reference")
        self.preview = compensator.preview_samples if self._zpetc else 0
        self._n = 0                       # reference samples received
        self._head = None                 # ZPETC: first P faded samples until the filter starts
        self._tail, self._held = [], 0    # last chunks, for the continuation
        self._state = None
        self._keep = kept_samples(period_samples)

    def _faded(self, chunk):
        w = _fade_weights(self._n, chunk.shape[1], self.fade) if self._n < self.fade else None
        return chunk if w is None else chunk * w      # rest output = 0 µm

    def _remember(self, faded):
        self._tail.append(faded)      # trimmed once it holds twice what is kept: linear in all
        self._held += faded.shape[1]
        if self._held > 2 * self._keep:
            self._tail = [np.concatenate(self._tail, axis=1)[:, -self._keep:]]
            self._held = self._tail[0].shape[1]

    def push(self, reference):
        """Voltages for the next chunk of reference.

        Parameters
        ----------
        reference : array_like, shape (p, n)
            The next n reference samples [µm].

        Returns
        -------
        numpy.ndarray, shape (m, n')
            Commanded voltages [V]; ``n' = n`` except for the ZPETC inverse,
            whose first ``preview_samples`` voltages wait for that much reference.
        """
        comp = self.compensator
        r = np.asarray(reference, dtype=float)
        r = np.atleast_2d(r)
        faded = self._faded(r)
        self._n += r.shape[1]
        self._remember(faded)
        if not self._zpetc:
            if self._state is None:
                self._state = _rest_state(comp)
            u, self._state = comp.simulate(faded, self._state)
            return u
        if self._state is None:                       # the inverse starts on the first P samples
            self._head = faded if self._head is None else np.concatenate([self._head, faded], 1)
            P = self.preview
            if self._head.shape[1] < P or self._head.shape[1] == 0:
                return np.zeros((comp.model.n_inputs, 0))
            s0 = comp.preview_state(self._head, P)          # as start's
            state = _rest_state(comp)      # e.g. a Preisach model's demagnetised hysterons
            state[comp.hysteresis_compensator.n_states:] = s0
            self._state = state
            faded, self._head = self._head[:, P:], None
        if faded.shape[1] == 0:
            return np.zeros((comp.model.n_inputs, 0))
        u, self._state = comp.simulate(faded, self._state)
        return u

    def finish(self):
        """The last voltages (ZPETC: the preview past the end, from the continuation).

        Returns
        -------
        numpy.ndarray, shape (m, n'')
            [V].
        """
        comp = self.compensator
        if not self._zpetc or not self._tail:
            return np.zeros((getattr(comp, "model").n_inputs, 0)) if hasattr(comp, "model") \
                else np.zeros((0, 0))
        P = self.preview
        ext = continuation(np.concatenate(self._tail, axis=1), P, self.period_samples)
        if self._state is None:          # fewer than P samples in all: start on what there is
            head = np.concatenate([self._head, ext], axis=1)
            n = self._head.shape[1]
            stream = DriveStream(comp, 0, None)
            stream._zpetc, stream.preview = True, P
            out = stream.push(head)
            return out[:, :n]
        u, self._state = comp.simulate(ext, self._state)
        return u
