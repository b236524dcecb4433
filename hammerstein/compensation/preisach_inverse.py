"""Exact per-sample inverse of a multivariable Preisach or generalised-PI model.

A Preisach model with non-negative weights and an increasing reversible part
is, at every sample, a monotone map of the input from the states of the
previous sample: each hysteron state ``max(rho_i(u), min(rho_j(u), s))`` is
non-decreasing in u (see :mod:`hammerstein.models.preisach`). So is a
generalised PI operator with non-negative weights (Al Janaideh, Rakheja and
Su, IEEE/ASME Trans. Mechatronics 16(4), 2011): each play
``max(gamma_l(u) - r, min(gamma_r(u) + r, s))`` under increasing envelopes
is non-decreasing in u (see :mod:`hammerstein.models.generalized_pi`); both
run in the same compiled kernel, a direct path of either class. So the input that
makes the model output equal a reference is a scalar root per direct path:

* per sample t, Gauss-Seidel over the outputs l: solve
  ``Gamma_ll(u_l) = y_r,l - sum_{k != l} Gamma_lk(u_k)`` for u_l (the
  cross-couplings at the current estimate of the other inputs). The root: a
  Newton probe on the secant of the path's last two values in the sample
  (each component is piecewise linear in u with the states frozen, so on one
  piece that is the root), else bracketed from the current estimate of u_l
  by steps to the secant root of the last two probes (overshot by 2 %), up to
  the input bounds, then Illinois false position inside the bracket, to
  ``tolerance`` (1e-12 µm). After the third sweep each input is extrapolated
  once by Aitken's delta-squared (the sweeps contract by a nearly constant
  factor). Until no input moves by more than 1e-11 V;
* then commit every state at the solution (the trial evaluations never
  change the memory).

The model's output then equals the reference to the root tolerance whenever
the reference is reachable (major and minor loops alike) and the sweeps
settle; an unreachable reference gives the bound. Where a direct path is flat
at the solution while a cross-coupling still moves its output (a generalised
PI without a reversible part inside its envelopes' band), the sweeps have no
local gain and may stop short: :meth:`PreisachInverseCompensator.simulate`
then warns (:class:`~hammerstein.exceptions.ConvergenceWarning`) with the
largest miss, when above ``UNSETTLED_MISS``. The sweeps converge only where the linearised
sweep over the secant gains of every path contracts (:func:`sweep_radius`
< 1; diagonal dominance suffices): a model whose outputs each mix the inputs
beyond that (a tip-tilt-piston platform's, 199 undamped and 1.14 at best) is
refused at construction, where the sweeps ran to the bounds on every sample. For comparison the same kernel runs the inverse
multiplicative law of the paper (Theorem 4.1, delay form)
``u_t = u_{t-1} + K^-1 (y_r(t) - Gamma(u_{t-1}))`` with the secant gain K
(``method = "multiplicative"``), which lags the reference by one sample.
"""

from __future__ import annotations

import warnings

import numpy as np

from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.exceptions import CompensatorError, ConvergenceWarning
from hammerstein.compensation.reference_check import check_reference
from hammerstein.simulation import preisach_inverse_kernel, state_vector

__all__ = ["PreisachInverseCompensator", "component_arrays", "sweep_radius", "RELAXATIONS"]

METHODS = ("root", "multiplicative")

#: A miss [µm] of the model's output on samples whose sweeps did not settle above which
#: :meth:`PreisachInverseCompensator.simulate` warns (1 pm: below any sensor; the sweeps
#: that stop on a raster's turns of an identified model miss by 1e-11 to 1e-9 µm).
UNSETTLED_MISS = 1e-6


def component_arrays(model, direct_required=False):
    """Flat arrays of a multivariable Preisach / generalised-PI / polynomial model for the kernels.

    Parameters
    ----------
    model : MultivariableHysteresis
        Components Preisach, generalised PI, polynomial, gain or None.
    direct_required : bool
        Refuse a direct path (l == k) that is not Preisach or generalised PI
        (the exact inverse needs one).

    Returns
    -------
    tuple
        ``(E, e_off, row, col, mu, q_off, pr, pw, p_off, env, s_off, rev, off,
        present)``, the fields of
        :class:`hammerstein.simulation.ComponentArrays` (component ``c = l m + k``).

    Raises
    ------
    CompensatorError
        On a component class the kernels cannot step (a classical PI).
    """
    p, m = model.n_outputs, model.n_inputs
    edges, rows, cols, mus, e_off, q_off = [], [], [], [], [0], [0]
    prs, pws, p_off = [], [], [0]
    nc = 1
    comps = []
    for l in range(p):
        for k in range(m):
            c = model.components[l][k]
            where = f"model.components[{l}][{k}] ({model.output_names[l]} <- {model.input_names[k]})"
            if direct_required and l == k and not isinstance(c, (PreisachModel, GeneralizedPI)):
                raise CompensatorError(f"{where}: expected a PreisachModel or GeneralizedPI "
                                       f"direct path for the exact inverse, found "
                                       f"{type(c).__name__}")
            if isinstance(c, (int, float)) and not isinstance(c, bool):
                c = Polynomial([float(c)])
            if c is not None and not isinstance(c, (PreisachModel, GeneralizedPI, Polynomial)):
                raise CompensatorError(f"{where}: the exact inverse handles Preisach, "
                                       f"generalised-PI, polynomial and gain cross-couplings, "
                                       f"found {type(c).__name__}")
            comps.append(c)
            if isinstance(c, (PreisachModel, GeneralizedPI)):
                nc = max(nc, c.reversible.size)
            elif isinstance(c, Polynomial):
                nc = max(nc, c.coefficients.size)
    rev = np.zeros((p * m, nc))
    off = np.zeros(p * m)
    env = np.zeros((p * m, 8))
    present = np.zeros(p * m, dtype=np.bool_)
    s_off = np.zeros(p * m, np.int64)
    start = 0                                # the model's flat state: components in (l, k) order
    for idx, c in enumerate(comps):
        s_off[idx] = start
        start += 0 if c is None else int(getattr(c, "n_states", 0))
        if isinstance(c, PreisachModel):
            r, q, w = c.hysteron_arrays
            edges.append(c.edges)
            rows.append(r)
            cols.append(q)
            mus.append(w)
            rev[idx, :c.reversible.size] = c.reversible
            off[idx] = c.offset
        else:
            edges.append(np.array([0.0, 1.0]))
            rows.append(np.zeros(0, np.int64))
            cols.append(np.zeros(0, np.int64))
            mus.append(np.zeros(0))
        if isinstance(c, GeneralizedPI):
            prs.append(c.thresholds)
            pws.append(c.weights)
            env[idx] = np.r_[c.gamma_l, c.gamma_r]
            rev[idx, :c.reversible.size] = c.reversible
            off[idx] = c.offset
        else:
            prs.append(np.zeros(0))
            pws.append(np.zeros(0))
        if isinstance(c, Polynomial):
            rev[idx, :c.coefficients.size] = c.coefficients
            off[idx] = c.offset
        present[idx] = c is not None
        e_off.append(e_off[-1] + edges[-1].size)
        q_off.append(q_off[-1] + mus[-1].size)
        p_off.append(p_off[-1] + pws[-1].size)
    if start != model.n_hysterons:
        raise CompensatorError(f"model: its state has {model.n_hysterons} values, the "
                               f"kernels count {start} (a component it cannot step)")
    return (np.concatenate(edges), np.array(e_off, np.int64), np.concatenate(rows),
            np.concatenate(cols), np.concatenate(mus), np.array(q_off, np.int64),
            np.concatenate(prs), np.concatenate(pws), np.array(p_off, np.int64), env,
            s_off, rev, off, present)


#: The relaxation factors the kernel's sweeps use (1, then rounds under-relaxed by 1/2 .. 1/16)
RELAXATIONS = (1.0, 0.5, 0.25, 0.125, 0.0625)


def sweep_radius(K, relaxations=RELAXATIONS):
    """Smallest spectral radius of the exact inverse's sweep over the gains K [-].

    The exact inverse solves ``Gamma_ll(u_l) = y_r,l - sum_{k != l} Gamma_lk(u_k)``
    for each l in turn (Gauss-Seidel over the direct paths, under-relaxed by
    w when the sweeps do not settle). Linearised with slopes K that is SOR
    over ``K u = y``, whose error contracts by
    ``M_w = (D / w + L)^-1 ((1 / w - 1) D - U)`` (D, L, U: diagonal, strictly
    lower and upper parts of K); it converges only where ``rho(M_w) < 1``
    for some w. Diagonal dominance (each direct path's gain above the sum of
    its output's cross-couplings) is sufficient.

    Parameters
    ----------
    K : array_like, shape (m, m)
        Gains [µm/V] (the secant gains of every path, signed).
    relaxations : sequence of float
        The factors w tried.

    Returns
    -------
    float
        ``min_w rho(M_w)`` [-]; ``inf`` on a zero direct gain.

    Examples
    --------
    >>> import numpy as np
    >>> bool(sweep_radius(np.array([[2.0, 0.5], [0.5, 2.0]])) < 1)
    True
    >>> bool(sweep_radius(np.array([[1.0, 5.0], [-5.0, 1.0]])) < 1)   # skew: damped sweeps
    True
    >>> bool(sweep_radius(np.array([[1.0, 5.0], [5.0, 1.0]])) >= 1)
    True
    """
    K = np.asarray(K, dtype=float)
    D = np.diag(np.diag(K))
    if np.any(np.diag(K) == 0):
        return float("inf")
    L, U = np.tril(K, -1), np.triu(K, 1)
    return float(min(np.max(np.abs(np.linalg.eigvals(
        np.linalg.solve(D / w + L, (1.0 / w - 1.0) * D - U)))) for w in relaxations))


class PreisachInverseCompensator:
    """Feedforward inverse of a multivariable Preisach model (exact per-sample root).

    Parameters
    ----------
    model : MultivariableHysteresis
        Square (m = p) model whose direct paths are
        :class:`~hammerstein.models.preisach.PreisachModel` or
        :class:`~hammerstein.models.generalized_pi.GeneralizedPI` with
        non-negative weights and a reversible part increasing on the input
        bounds; cross-couplings Preisach, generalised PI,
        :class:`~hammerstein.models.preisach.Polynomial`, gains or absent.
    method : {'root', 'multiplicative'}
        Exact root per sample, or the inverse multiplicative law (for comparison).
    input_bound : array_like, shape (m,), optional
        Inputs are kept in ``[-input_bound, input_bound]`` [V] when given.
        Default: the model's ``input_range`` ``[low, high]`` per input (the
        records' range, which need not be symmetric, e.g. 0..100 V for a
        unipolar stack: below it the identified reversible terms are
        extrapolated and may turn back), else ``[-b, b]`` with b 1.2 x its
        ``input_amplitude``, else the switching grid's extent.
    tolerance : float
        Root tolerance on each direct path's output [µm] (default 1e-12: the
        exported C then equals this compensator to a few 1e-13 relative, the
        roots' own spread; at 1e-10 it was 1.8e-12 on the Hammerstein kind).
    max_sweeps : int
        Gauss-Seidel sweeps per sample (the cross-couplings); when they do not
        settle, up to four more rounds under-relaxed by 1/2, 1/4, 1/8, 1/16.
    name : str
        Label used in reports.

    Raises
    ------
    CompensatorError
        On a model it cannot invert (not square, a direct path that is not a
        Preisach model or not increasing, an unsupported cross-coupling), or,
        with ``method = 'root'``, one whose sweeps over the direct paths
        cannot converge (:func:`sweep_radius` >= 1: outputs that each mix the
        inputs more than their direct path carries them).

    Examples
    --------
    One Preisach direct path: the model driven by the compensator's inputs
    follows a reference with minor loops to the root tolerance:

    >>> import numpy as np
    >>> from hammerstein.models.preisach import MultivariableHysteresis, PreisachModel
    >>> from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
    >>> direct = PreisachModel.from_density(np.linspace(-10, 10, 21), total=20.0,
    ...                                     coercivity=1.0, coercivity_width=2.0, reversible=[2.0])
    >>> model = MultivariableHysteresis([[direct]], input_amplitude=[10.0])
    >>> t = np.linspace(0, 1, 2000)
    >>> yr = (30 * np.sin(2 * np.pi * 2 * t) * np.exp(-2 * t))[np.newaxis]
    >>> u, _ = PreisachInverseCompensator(model).simulate(yr)
    >>> bool(np.max(np.abs(model.simulate(u)[0] - yr)) < 1e-8)
    True
    """

    def __init__(self, model, method="root", input_bound=None, tolerance=1e-12, max_sweeps=50,
                 name="preisach-inverse"):
        if not isinstance(model, MultivariableHysteresis):
            raise CompensatorError(f"model: expected a MultivariableHysteresis with Preisach direct "
                                   f"paths, found {type(model).__name__}")
        if method not in METHODS:
            raise CompensatorError(f"method: expected one of {METHODS}, found {method!r}")
        m, p = model.n_inputs, model.n_outputs
        if m != p:
            raise CompensatorError(f"model: expected as many inputs as outputs, found {m} and {p}")
        self.model, self.method, self.name = model, method, name
        self.tolerance, self.max_sweeps = float(tolerance), int(max_sweeps)
        self._unsettled_said = 0.0       # the largest miss said so far [µm]
        rng = model.input_range if input_bound is None else None
        if rng is not None:
            bound = np.asarray(rng, dtype=float)[:, 1].copy()
        elif input_bound is None:
            if model.input_amplitude is not None:
                bound = 1.2 * model.input_amplitude
            else:
                bound = np.array([np.max(np.abs(model.components[l][l].edges))
                                  if isinstance(model.components[l][l], PreisachModel) else 1.0
                                  for l in range(p)])
        else:
            bound = np.broadcast_to(np.asarray(input_bound, dtype=float), (m,)).copy()
        if rng is not None:
            self.lo = np.asarray(rng, dtype=float)[:, 0].copy()
            if not (np.all(np.isfinite(self.lo)) and np.all(self.lo < bound)):
                raise CompensatorError(f"model.input_range: expected {m} ranges [low, high] V "
                                       f"with low < high, found {np.asarray(rng).tolist()}")
        elif not (np.all(np.isfinite(bound)) and np.all(bound > 0)):
            raise CompensatorError(f"input_bound: expected {m} positive voltages [V], found "
                                   f"{np.asarray(bound).tolist()}")
        else:
            self.lo = -bound
        self.hi = bound.copy()
        self._ranged = rng is not None
        self._pack()
        self.K = self._secant_gain()
        self.K_inv = np.linalg.inv(self.K)
        self.sweep_radius = sweep_radius(self.K)
        if method == "root" and self.sweep_radius >= 1.0:
            raise CompensatorError(self._sweep_problem())

    def _sweep_problem(self):
        """Why the Gauss-Seidel sweeps over the direct paths cannot solve the model."""
        K = np.abs(self.K)
        names = self.model.output_names
        rows = [(names[l], K[l, l], K[l].sum() - K[l, l]) for l in range(K.shape[0])]
        weak = [r for r in rows if r[1] <= r[2]] or rows
        return (f"model: the exact inverse cannot solve it: it solves each output on its own "
                f"input (Gauss-Seidel over the direct paths, under-relaxed down to 1/16), which "
                f"converges only where the spectral radius of that sweep over the secant gains "
                f"is below 1 (direct paths that dominate their outputs make it so); here it is "
                f"{self.sweep_radius:.3g} at best ({sweep_radius(self.K, (1.0,)):.3g} undamped; "
                + ", ".join(f"{o}: direct {d:.3g} µm/V against {x:.3g} from the others"
                            for o, d, x in weak)
                + "), so its voltages run to the bounds. Measure outputs that each input drives "
                  "most (each stack's own displacement) and identify again")

    def _pack(self):
        model = self.model
        p = model.n_inputs
        self._arrays = component_arrays(model, direct_required=True)
        for l in range(p):                       # the exact root needs increasing direct paths
            d = model.components[l][l]
            grid = np.linspace(self.lo[l], self.hi[l], 201)
            slope = np.polyval(np.polyder(np.r_[d.reversible[::-1], 0.0]), grid) \
                if d.reversible.size else np.zeros_like(grid)
            if isinstance(d, GeneralizedPI):
                if np.any(d.weights < 0) or np.any(slope < 0) or \
                        (np.all(d.weights <= 0) and np.any(slope <= 0)):
                    raise CompensatorError(
                        f"model.components[{l}][{l}]: the generalised-PI direct path is not "
                        f"increasing on [{self.lo[l]:g}, {self.hi[l]:g}] V (weights from "
                        f"{d.weights.min():.3g}, reversible slope from {slope.min():.3g} µm/V): "
                        f"no exact inverse")
                continue
            diag = np.diag(d.weights)
            if np.any(slope < 0) or (np.any(slope <= 0) and np.any(diag <= 0)):
                raise CompensatorError(
                    f"model.components[{l}][{l}]: the direct path is not increasing on "
                    f"[{self.lo[l]:g}, {self.hi[l]:g}] V (its reversible part's slope reaches "
                    f"{slope.min():.3g} µm/V): no exact inverse")

    def _secant_gain(self):
        """Secant gains ``(Gamma(+A) - Gamma(-A)) / 2A`` of every component [µm/V] (m x m).

        A is ``input_amplitude`` about 0 V, or half the records' range about
        its centre when they were not centred on 0 V (``model.input_range``).
        """
        model = self.model
        p = m = model.n_inputs
        K = np.zeros((p, m))
        ranged = self._ranged
        centre = (self.lo + self.hi) / 2 if ranged else np.zeros(m)
        for k in range(m):          # +-A about 0, or over the records' range about its centre
            a = (self.hi[k] - self.lo[k]) / 2 if ranged else self.hi[k] / 1.2
            u = np.repeat(centre[:, None], 400, axis=1)
            u[k] += a * np.sin(np.linspace(0, 4 * np.pi, 400))
            y, _ = model.simulate(u)
            K[:, k] = (y[:, 250:].max(axis=1) - y[:, 250:].min(axis=1)) / (2 * a)
            # sign of the slope: of the outputs' covariance with the input over the last period
            # (samples 200 and 300 are both at u = 0, where the difference was the loop's width)
            du = u[k, 200:] - u[k, 200:].mean()
            K[:, k] *= np.where((y[:, 200:] - y[:, 200:].mean(axis=1, keepdims=True)) @ du < 0,
                                -1.0, 1.0)
        K[np.diag_indices(p)] = np.abs(np.diag(K))
        return K

    def __repr__(self):
        return f"PreisachInverseCompensator(method={self.method!r}, name={self.name!r})"

    @property
    def n_states(self) -> int:
        """Length of the state: the last inputs (m) then the model's states."""
        return self.model.n_inputs + self.model.n_hysterons

    def initial_state(self, initial_state=None):
        """Validated copy of a state; zero inputs and the model's default states by default.

        Parameters
        ----------
        initial_state : array_like, shape (n_states,), optional
            Last inputs [V] then the model's states.

        Returns
        -------
        numpy.ndarray, shape (n_states,)

        Raises
        ------
        HysteresisError
            On a wrong length or model states.
        """
        if initial_state is None:
            return np.concatenate([np.zeros(self.model.n_inputs), self.model.initial_state()])
        s = state_vector(initial_state, self.n_states, "initial_state")
        self.model.initial_state(s[self.model.n_inputs:])
        return s

    def simulate(self, reference, initial_state=None):
        """Input voltages that make the model follow a reference.

        Parameters
        ----------
        reference : array_like, shape (p, n_samples)
            Reference displacements [µm].
        initial_state : array_like, shape (n_states,), optional
            See :meth:`initial_state`.

        Returns
        -------
        inputs : numpy.ndarray, shape (m, n_samples)
            Input voltages [V].
        final_state : numpy.ndarray, shape (n_states,)
            State after the last sample.

        Raises
        ------
        HysteresisError
            On a wrongly shaped or non-finite reference (the first sample named) or state.
        CompensatorError
            On a reference sample the exported C skips with status 4, the first one
            named; nothing is run, the caller's state stays valid
            (:func:`~hammerstein.compensation.reference_check.check_reference`).
        """
        yr = np.ascontiguousarray(check_reference(self, reference))
        s = self.initial_state(initial_state)
        m = self.model.n_inputs
        u_prev, hs = s[:m].copy(), s[m:].copy()
        u = np.empty((m, yr.shape[1]))
        unsettled = preisach_inverse_kernel(yr, *self._arrays, hs, self.lo, self.hi,
                                            self.method == "root", self.K_inv, u_prev, u,
                                            self.tolerance, self.max_sweeps)
        if unsettled and self.method == "root":
            # judged where no input is at a bound; said again only for a miss more than twice
            # the largest said (compensate runs it several times, a chunked caller once per
            # chunk: five to twelve lines of one miss; a second reference missed worse is said)
            inside = np.all((u > self.lo[:, None]) & (u < self.hi[:, None]), axis=0)
            miss = np.abs(self.model.simulate(u, s[m:])[0] - yr)[:, inside].max(initial=0.0)
            if miss > max(UNSETTLED_MISS, 2.0 * self._unsettled_said):
                again = " (said again only for a miss twice as large)" if not self._unsettled_said \
                    else " (more than twice the miss said before)"
                self._unsettled_said = miss
                warnings.warn(f"exact inverse: the Gauss-Seidel sweeps did not settle on {unsettled} "
                              f"of {yr.shape[1]} samples, where a direct path is flat or nearly "
                              f"so (a band between a generalised PI's envelopes, no reversible "
                              f"part) while a cross-coupling still moves its output; the model's "
                              f"output misses the reference there by up to {miss:.2g} µm"
                              f"{again}", ConvergenceWarning, stacklevel=2)
        return u, np.concatenate([u_prev, hs])
