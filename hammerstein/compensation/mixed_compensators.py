"""The rate-independent compensator kinds over a model that is not a classical PI.

The kinds ``multivariable``, ``diagonal``, ``per-axis`` and ``static-gain``
are defined on the classical PI (:mod:`hammerstein.compensation.compensators`). What
each needs is a forward operator Gamma and a gain (the inverse
multiplicative law, Theorem 4.1 of the paper), an exact inverse of each
direct path (the per-axis inverse), or a linear gain. A multivariable
Preisach model (:class:`~hammerstein.models.preisach.MultivariableHysteresis`,
e.g. identified with ``hammerstein identify --model preisach``) has a forward
operator and, its direct paths being monotone, an exact per-sample inverse
(:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`), so
each kind is built over it as follows (:func:`mixed_compensator`):

* ``multivariable``: the inverse multiplicative law
  ``U(t) = U(t-T) + K^-1 (Yr(t) - Gamma(U(t-T)))`` with Gamma the model's own
  forward operator (every component, cross-couplings included), the states
  committed at ``U(t-T)``; K as for the PI: ``"secant"`` (default, the
  direct paths' secant gains over the model's amplitude), ``"midpoint"``
  (``(S_min + S_max) / 2`` of the slopes along each direct path's major
  loop), ``"identity"`` or a matrix [µm/V]. One step per sample
  (``iterations = 1``) and the one-sample delay feedback.
* ``diagonal``: the same law on the direct paths only (cross-couplings left,
  their constant output at rest kept: :func:`diagonal_model`).
* ``per-axis``: the exact inverse of each direct path alone (a monotone
  scalar root per sample, cross-couplings left as for ``diagonal``): the analogue of the
  per-axis analytic inverse PI of Kuhnen and Janocha.
* ``static-gain``: ``U = K^-1 (Yr - c)``, K the direct secant gains and c the
  centre of each direct path's major loop at zero input (no hysteresis
  compensation, the reference case).

The convergence of the law (``rho(I - K^-1 J) < 1``, docs/compensator.md)
is checked on the corners of the slope intervals of every component along
its major loop (``check = "error" | "warn" | "ignore"``).
"""

from __future__ import annotations

import itertools
import warnings

import numpy as np

from hammerstein.models.preisach import MultivariableHysteresis, Polynomial
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.exceptions import CompensatorError, ConvergenceWarning

__all__ = ["MIXED_KINDS", "LinearInverseCompensator", "diagonal_model", "loop_slopes",
           "mixed_compensator", "mixed_gain"]

#: The kinds :func:`mixed_compensator` builds.
MIXED_KINDS = ("multivariable", "diagonal", "per-axis", "static-gain")
#: Samples per period of the major loops the gains and slopes are read from.
_LOOP_SAMPLES = 2000


def _amplitude(model):
    if model.input_amplitude is None:
        raise CompensatorError("model: expected an input_amplitude [V] (the range the gains are "
                               "read over), found none")
    return np.asarray(model.input_amplitude, dtype=float)


def _major_loop(model, k):
    """Input k on two periods of a sine of its amplitude: (u (n,), y (p, n)) of the second period."""
    A = _amplitude(model)[k]
    n = _LOOP_SAMPLES
    u = np.zeros((model.n_inputs, 2 * n + 1))
    u[k] = A * np.sin(2 * np.pi * np.arange(2 * n + 1) / n)
    y, _ = model.simulate(u)
    return u[k, n:], y[:, n:]


def loop_slopes(model):
    """Slopes dGamma_lk/du_k along the major loops [µm/V]: (lowest, highest), each (p, m).

    Input k alone runs a sine of its amplitude ``input_amplitude[k]`` from
    the model's rest state; the slopes are finite differences over the
    second period, both branches.

    Parameters
    ----------
    model : MultivariableHysteresis
        With ``input_amplitude``.

    Returns
    -------
    lowest, highest : numpy.ndarray, shape (p, m)
        [µm/V].

    Raises
    ------
    CompensatorError
        Without an ``input_amplitude``.
    """
    p, m = model.n_outputs, model.n_inputs
    lo, hi = np.zeros((p, m)), np.zeros((p, m))
    for k in range(m):
        u, y = _major_loop(model, k)
        du = np.diff(u)
        ok = np.abs(du) > 1e-9 * max(np.max(np.abs(u)), 1e-300)
        s = np.diff(y, axis=1)[:, ok] / du[ok]
        lo[:, k], hi[:, k] = s.min(axis=1), s.max(axis=1)
    return lo, hi


def _secant_and_centre(model):
    """Direct secant gains ``(max - min) / 2A`` and loop centres at u = 0 [µm], each (m,)."""
    m = model.n_inputs
    K, c = np.zeros(m), np.zeros(m)
    for k in range(m):
        u, y = _major_loop(model, k)
        A = _amplitude(model)[k]
        K[k] = np.ptp(y[k]) / (2 * A)
        zero = np.flatnonzero(np.diff(np.sign(u)) != 0)   # both crossings of u = 0
        c[k] = float(np.mean(y[k, zero]))
    return K, c


def mixed_gain(model, gain="secant"):
    """The gain K of the inverse multiplicative law over a non-PI model (m, m) [µm/V].

    Parameters
    ----------
    model : MultivariableHysteresis
        Square, with ``input_amplitude``.
    gain : {'secant', 'midpoint', 'identity'} or array_like, shape (m, m)
        ``secant``: diagonal, the direct paths' secant gains over their
        major loops; ``midpoint``: diagonal, ``(S_min + S_max) / 2`` of each
        direct path's slopes along its major loop (:func:`loop_slopes`;
        the classical optimal relaxation of a fixed-point step);
        ``identity``: the paper's literal law; or a matrix [µm/V].

    Returns
    -------
    numpy.ndarray, shape (m, m)

    Raises
    ------
    CompensatorError
        On an unknown gain, a wrongly shaped or singular matrix, or a
        non-positive secant gain.
    """
    m = model.n_inputs
    if isinstance(gain, str):
        if gain == "identity":
            return np.eye(m)
        if gain == "secant":
            K = _secant_and_centre(model)[0]
        elif gain == "midpoint":
            lo, hi = loop_slopes(model)
            K = 0.5 * (np.diag(lo) + np.diag(hi))
        else:
            raise CompensatorError(f"gain: expected 'secant', 'midpoint', 'identity' or an {m}x{m} "
                                   f"matrix [µm/V], found {gain!r}")
        if not np.all(K > 0):
            raise CompensatorError(f"gain: the direct paths' {gain} gains are {K.tolist()} µm/V; "
                                   f"expected positive gains (increasing direct paths)")
        return np.diag(K)
    K = np.asarray(gain, dtype=float)
    if K.shape != (m, m) or not np.all(np.isfinite(K)) or abs(np.linalg.det(K)) < 1e-300:
        raise CompensatorError(f"gain: expected an invertible {m}x{m} finite matrix [µm/V], found "
                               f"{np.asarray(gain).tolist()}")
    return K


def _rest_output(component):
    """A component's output at zero input from its rest state [µm] (0 for an absent one)."""
    if component is None:
        return 0.0
    if isinstance(component, (int, float)):
        return 0.0                           # a gain
    return float(np.asarray(component.simulate(np.zeros(1))[0]).ravel()[0])


def diagonal_model(model):
    """The model with its direct paths only (cross-couplings' variation removed).

    Each cross-coupling (l, k), k != l, is replaced by its output at zero
    input from rest, a constant: an identified model may carry a large
    constant in a cross-coupling (a Preisach coupling's demagnetised
    hysterons, balanced by the direct path's offset), which is part of the
    output at rest, not of the coupling the diagonal kinds leave out.

    Parameters
    ----------
    model : MultivariableHysteresis
        Square.

    Returns
    -------
    MultivariableHysteresis
        Same names, amplitude and ``input_range``; component (l, k), k != l,
        None or a constant ``Polynomial([0], offset=c_lk)``.
    """
    m = model.n_inputs
    grid = [[None] * m for _ in range(m)]
    for l in range(m):
        for k in range(m):
            c = model.components[l][k]
            if k == l:
                grid[l][k] = c
            elif _rest_output(c) != 0.0:
                grid[l][k] = Polynomial([0.0], offset=_rest_output(c))
    out = MultivariableHysteresis(grid, model.input_names, model.output_names,
                                  model.input_amplitude)
    # the records' input range: the exact inverse keeps its inputs (and flags its clamp) there,
    # not at +-1.2 amplitude (per-axis on a 0..40 V stage searched down to -48 V)
    out.input_range = getattr(model, "input_range", None)
    return out


def _corner_radius(lo, hi, K):
    """Largest ``rho(I - K^-1 J)`` over the corners J of the slope intervals [lo, hi]."""
    Kinv = np.linalg.inv(K)
    m = K.shape[0]
    worst = 0.0
    for corner in itertools.product((0, 1), repeat=m * m):
        J = np.where(np.reshape(corner, (m, m)) == 0, lo, hi)
        worst = max(worst, float(np.max(np.abs(np.linalg.eigvals(np.eye(m) - Kinv @ J)))))
    return worst


def _check_law(model, K, check, kind):
    """``rho(I - K^-1 J)`` on the corners of the major-loop slope intervals.

    Past 1 the message names ``gain = 'midpoint'`` only where its radius is lower
    than K's (it was named for every gain, the midpoint's own included, also where it
    raised the radius: 1.6 -> 1.74 on an identified generalised PI).
    """
    if check == "ignore":
        return None
    lo, hi = loop_slopes(model)
    worst = _corner_radius(lo, hi, K)
    if worst >= 1.0:
        mid = np.diag(0.5 * (np.diag(lo) + np.diag(hi)))
        if np.allclose(K, mid, rtol=1e-12, atol=0):
            advice = "with gain = 'midpoint'"
        elif not np.all(np.diag(mid) > 0):
            advice = "no midpoint gain: a direct path's slopes are not positive"
        else:
            r_mid = _corner_radius(lo, hi, mid)
            advice = (f"gain = 'midpoint' lowers it to {r_mid:.3g}" if r_mid < worst else
                      f"gain = 'midpoint' does not lower it: {r_mid:.3g}")
        advice += ("; kinds without the law, preisach-inverse and per-axis, do not need it; "
                   if "lowers" not in advice else "; ")
        text = (f"compensator.kind = {kind!r} over a {type(model).__name__}: the inverse "
                f"multiplicative law may not converge, rho(I - K^-1 J) reaches {worst:.3g} >= 1 on "
                f"the corners of the slopes along the major loops ({advice}"
                f"check = 'warn' runs it anyway)")
        if check == "error":
            raise CompensatorError(text)
        warnings.warn(text, ConvergenceWarning, stacklevel=3)
    return worst


class LinearInverseCompensator:
    """No hysteresis compensation over any model: ``U = K^-1 (Yr - c)``.

    K holds the secant gains of the direct paths over their major loops
    (input k a sine of amplitude ``input_amplitude[k]``, ``K_kk = (max - min)
    / 2A_k``) and c the centre of each major loop at zero input (the mean of
    its two branches there), so that a linear actuator ``y = K u + c`` is
    inverted exactly; the reference case of the ``static-gain`` kind.

    Parameters
    ----------
    model : MultivariableHysteresis
        Square model with ``input_amplitude``.
    name : str
        Label used in reports.

    Attributes
    ----------
    K : numpy.ndarray, shape (m, m)
        Diagonal gain [µm/V].
    centre : numpy.ndarray, shape (m,)
        c [µm].

    Raises
    ------
    CompensatorError
        Not square, no ``input_amplitude``, or a non-positive secant gain.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
    >>> direct = PreisachModel.from_density(np.linspace(-12, 12, 25), total=20.0, tilt=0.4,
    ...                                     coercivity=1.0, coercivity_width=2.0, reversible=[1.0])
    >>> comp = LinearInverseCompensator(MultivariableHysteresis([[direct]], input_amplitude=[10.0]))
    >>> u, _ = comp.simulate(np.array([[comp.centre[0], comp.centre[0] + comp.K[0, 0]]]))
    >>> np.round(u, 12).tolist()
    [[0.0, 1.0]]
    """

    n_states = 0

    def __init__(self, model, name="static gain"):
        _square(model, "static-gain")
        K, self.centre = _secant_and_centre(model)
        if not np.all(K > 0):
            raise CompensatorError(f"model: the direct paths' secant gains are {K.tolist()} µm/V; "
                                   f"expected positive gains")
        self.model, self.name = model, name
        self.K, self.K_inv = np.diag(K), np.diag(1.0 / K)

    def __repr__(self):
        return (f"LinearInverseCompensator(name={self.name!r}, K diagonal "
                f"[{', '.join(f'{v:.4g}' for v in np.diag(self.K))}] µm/V)")

    def initial_state(self, initial_state=None):
        """The (empty) state.

        Parameters
        ----------
        initial_state : None or array_like, shape (0,)

        Returns
        -------
        numpy.ndarray, shape (0,)

        Raises
        ------
        CompensatorError
            A non-empty state.
        """
        s = np.zeros(0) if initial_state is None else np.asarray(initial_state, dtype=float)
        if s.shape != (0,):
            raise CompensatorError(f"initial_state: the static-gain compensator has no state, "
                                   f"found shape {s.shape}")
        return s

    def simulate(self, reference, initial_state=None):
        """Input voltages ``U = K^-1 (Yr - c)``.

        Parameters
        ----------
        reference : array_like, shape (m, n_samples)
            [µm].
        initial_state : None or empty array

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            [V].
        final_state : numpy.ndarray, shape (0,)
        """
        self.initial_state(initial_state)
        yr = self.model.check_inputs(reference, "reference")
        return self.K_inv @ (yr - self.centre[:, None]), np.zeros(0)


def _square(model, kind):
    if not isinstance(model, MultivariableHysteresis):
        raise CompensatorError(f"model: expected a MultivariableHysteresis for {kind}, found "
                               f"{type(model).__name__}")
    if model.n_inputs != model.n_outputs:
        raise CompensatorError(f"model: {kind} needs as many inputs as outputs, found "
                               f"{model.n_inputs} and {model.n_outputs}")


def mixed_compensator(model, kind, gain="secant", iterations=1, check="error", feedback="delay",
                      inverse=PreisachInverseCompensator):
    """A rate-independent kind over a model that is not a classical PI (module notes).

    Parameters
    ----------
    model : MultivariableHysteresis
        Square, monotone direct paths, with ``input_amplitude``.
    kind : {'multivariable', 'diagonal', 'per-axis', 'static-gain'}
    gain : str or array_like
        ``multivariable`` / ``diagonal``: see :func:`mixed_gain`.
    iterations : int
        Must be 1 (one step of the law per sample).
    check : {'error', 'warn', 'ignore'}
        Convergence check of the law (module notes).
    feedback : {'delay'}
        The one-sample delay (the low-pass feedback is the PI law's).
    inverse : callable
        ``inverse(model, method=..., name=...)`` returns a compensator over a
        model with a forward operator and an exact inverse:
        ``method = "root"`` its exact per-sample inverse, ``"multiplicative"``
        the law with Gamma the model's forward operator and settable ``K``,
        ``K_inv`` [µm/V]. Default the Preisach model's
        (:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`);
        another model class passes its own.

    Returns
    -------
    PreisachInverseCompensator or LinearInverseCompensator
        (or what ``inverse`` returns)
        ``name`` the kind; ``actuator_model`` the whole ``model`` (its
        ``model`` is the diagonal one ``per-axis`` and ``diagonal`` invert):
        the drive's fade-in starts at the whole model's rest output, as
        ``compensate``'s does.

    Raises
    ------
    CompensatorError
        On an unknown kind, an option the law over this model does not have,
        a model it cannot invert, or (``check = "error"``) a law that may not
        converge.

    Examples
    --------
    The law over a one-input Preisach model holds a constant reference
    exactly once it has converged (its fixed point is ``Gamma(u) = y_r``):

    >>> import numpy as np
    >>> from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
    >>> direct = PreisachModel.from_density(np.linspace(-12, 12, 25), total=20.0, tilt=0.4,
    ...                                     coercivity=1.0, coercivity_width=2.0, reversible=[1.0])
    >>> model = MultivariableHysteresis([[direct]], input_amplitude=[10.0])
    >>> comp = mixed_compensator(model, "multivariable", gain="midpoint")
    >>> u, _ = comp.simulate(np.full((1, 300), 12.0))
    >>> bool(abs(model.simulate(u)[0][0, -1] - 12.0) < 1e-9)
    True
    """
    if kind not in MIXED_KINDS:
        raise CompensatorError(f"kind: expected one of {', '.join(MIXED_KINDS)}, found {kind!r}")
    _square(model, f"compensator.kind = {kind!r}")
    if kind == "static-gain":
        return LinearInverseCompensator(model, name="static-gain")
    if kind == "per-axis":
        comp = inverse(diagonal_model(model), method="root", name="per-axis")
        comp.actuator_model = model        # the whole model: what the drive's fade starts on
        return comp
    if iterations != 1:
        raise CompensatorError(f"iterations: the inverse multiplicative law over a "
                               f"{type(model).__name__} runs one step per sample (iterations = 1), "
                               f"found {iterations}")
    if feedback != "delay":
        raise CompensatorError(f"feedback: only 'delay' over a {type(model).__name__}, found "
                               f"{feedback!r}")
    target = model if kind == "multivariable" else diagonal_model(model)
    K = mixed_gain(target, gain)
    comp = inverse(target, method="multiplicative", name=kind)
    comp.K, comp.K_inv = K, np.linalg.inv(K)
    comp.convergence_radius = _check_law(target, K, check, kind)
    comp.actuator_model = model            # the whole model, where ``model`` may be its diagonal
    return comp
