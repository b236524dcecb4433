"""Plain numpy stepping loops: the reference implementation (``backend='numpy'``).

One Python iteration per sample, written as directly as the equations, so
that they serve as the test oracle of the compiled kernels. The public
functions of :mod:`hammerstein.simulation` dispatch here for
``backend='numpy'``; inputs are validated there.
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import CompensatorDivergence
from hammerstein.simulation._packing import STATUS_BOUND, divergence_error

__all__ = ["plays", "inverse_play", "hysteresis", "plant", "compensator_step", "compensator"]


def inverse_play(v, r, e, s):
    """Inverse play of threshold ``r``, motions of ``v`` up to ``e`` ignored.

    ``u(t) = a(t) + d(t)``: ``a`` follows ``v`` when ``|v(t) - a(t-T)| > e`` and holds
    otherwise; ``d = r`` when ``a`` rose, ``-r`` when it fell, else kept.

    Parameters
    ----------
    v : numpy.ndarray, shape (n_samples,)
        Desired play output [V].
    r : float
        Threshold [V].
    e : float
        Motion ignored [V].
    s : numpy.ndarray, shape (2,)
        ``[a(-T), d(-T)]`` [V].

    Returns
    -------
    u : numpy.ndarray, shape (n_samples,)
        Play input [V].
    final_state : numpy.ndarray, shape (2,)
        ``[a, d]`` after the last sample [V].
    """
    a, d = float(s[0]), float(s[1])
    u = np.empty(v.size)
    for t in range(v.size):
        if v[t] > a + e:
            a, d = v[t], r
        elif v[t] < a - e:
            a, d = v[t], -r
        u[t] = a + d
    return u, np.array([a, d])


def plays(u, r, s):
    """Play operators of one input, eq. (1): ``s <- max(u - r, min(u + r, s))``.

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input [V].
    r : numpy.ndarray, shape (n,)
        Thresholds [V].
    s : numpy.ndarray, shape (n,)
        Play outputs before the first sample [V].

    Returns
    -------
    y : numpy.ndarray, shape (n, n_samples)
        Play outputs [V].
    final_state : numpy.ndarray, shape (n,)
    """
    y = np.empty((r.size, u.size))
    for t in range(u.size):
        s = np.maximum(u[t] - r, np.minimum(u[t] + r, s))
        y[:, t] = s
    return y, s.copy()


def hysteresis(model, u, s):
    """Multivariable PI model, eq. (4), one sample at a time.

    Parameters
    ----------
    model : MultivariablePI
        Duck-typed: ``hysterons()`` and ``n_outputs``.
    u : numpy.ndarray, shape (m, n_samples)
        Inputs [V].
    s : numpy.ndarray, shape (n_hysterons,)
        Initial play states [V].

    Returns
    -------
    y : numpy.ndarray, shape (p, n_samples)
        Outputs [µm].
    final_state : numpy.ndarray, shape (n_hysterons,)
    """
    f = model.hysterons()
    y = np.empty((model.n_outputs, u.shape[1]))
    for t in range(u.shape[1]):
        ut = u[f["input_index"], t]
        s = np.maximum(ut - f["thresholds"], np.minimum(ut + f["thresholds"], s))
        y[:, t] = np.bincount(f["output_index"], weights=f["weights"] * s,
                              minlength=model.n_outputs) + f["gain"] @ u[:, t]
    return y, s


def plant(plant_, u, state):
    """Hammerstein plant: PI model then ``y = C x + D h``, ``x <- A x + B h``.

    Parameters
    ----------
    plant_ : HammersteinPlant
        Duck-typed: ``hysteresis``, ``is_static``, ``matrices``.
    u : numpy.ndarray, shape (m, n_samples)
        Inputs [V].
    state : numpy.ndarray, shape (n_states,)
        Play states [V] then linear states [µm].

    Returns
    -------
    y : numpy.ndarray, shape (p, n_samples)
        Outputs [µm].
    final_state : numpy.ndarray, shape (n_states,)
    """
    nh = plant_.hysteresis.n_hysterons
    h, play_final = hysteresis(plant_.hysteresis, u, state[:nh])
    if plant_.is_static:
        return h, play_final
    A, B, C, D = plant_.matrices
    x = state[nh:]
    y = np.empty_like(h)
    for t in range(h.shape[1]):
        y[:, t] = C @ x + D @ h[:, t]
        x = A @ x + B @ h[:, t]
    return y, np.concatenate([play_final, x])


def compensator_step(law, state, reference):
    """One sample of a compensator law (numpy), without divergence checks.

    The body of the numpy oracle loop, also the update of the python-control
    compensator system (:func:`hammerstein.io.interop.compensator_system`).

    Parameters
    ----------
    law : CompensatorLaw
        What the compensator's ``packed_law()`` returns.
    state : numpy.ndarray, shape (law.n_states,)
        ``U(t-T)`` [V], (``v_f(t-T)`` [V] for the low-pass law), play states
        [V], pre-filter state [µm].
    reference : numpy.ndarray, shape (p,)
        ``Yr(t)`` [µm].

    Returns
    -------
    inputs : numpy.ndarray, shape (m,)
        ``U(t)`` [V].
    new_state : numpy.ndarray, shape (law.n_states,)
        State committed with ``U(t)`` (the old state when U is not finite).
    """
    model = law.model
    u_prev, vf_prev, s, xf = law.split_state(state)
    Kinv = law.K_inv
    if law.prefilter is not None:
        Af, Bf, Cf, Df = law.prefilter
        target = Cf @ xf + Df @ reference
        xf = Af @ xf + Bf @ reference
    else:
        target = reference
    if law.lowpass:
        a = law.pole
        y_prev, _ = model.evaluate(u_prev, s)
        vf = a * vf_prev + (1.0 - a) * (u_prev - Kinv @ y_prev)
        u = Kinv @ target + vf
    else:
        u = u_prev
        for _ in range(law.iterations):
            y_hat, _ = model.evaluate(u, s)
            u = u + Kinv @ (target - y_hat)
    if not np.all(np.isfinite(u)):
        return u, state.copy()
    _, s = model.evaluate(u, s)
    return u, np.concatenate([u, vf, s, xf] if law.lowpass else [u, s, xf])


def compensator(law, yr, state):
    """A compensator law over a record, one :func:`compensator_step` per sample.

    Parameters
    ----------
    law : CompensatorLaw
    yr : numpy.ndarray, shape (p, n_samples)
        Reference [µm].
    state : numpy.ndarray, shape (law.n_states,)
        Initial state.

    Returns
    -------
    inputs : numpy.ndarray, shape (m, n_samples)
        Voltages [V].
    final_state : numpy.ndarray, shape (law.n_states,)

    Raises
    ------
    CompensatorDivergence
        When U is non-finite or beyond ``law.divergence_bound``.
    """
    bound = law.divergence_bound
    u_out = np.empty((law.model.n_inputs, yr.shape[1]))
    for t in range(yr.shape[1]):
        u, new_state = compensator_step(law, state, yr[:, t])
        if not np.all(np.isfinite(u)):
            raise CompensatorDivergence(t, "the input voltage became non-finite")
        if np.max(np.abs(u)) > bound:
            raise divergence_error(u, bound, STATUS_BOUND, t)
        u_out[:, t] = u
        state = new_state
    return u_out, state
