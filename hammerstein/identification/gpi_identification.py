"""Identification of a multivariable generalised Prandtl-Ishlinskii model from records.

:class:`GeneralizedPIIdentifier` fits, per output l, every component
``Gamma_lk`` (input k to output l) of a
:class:`~hammerstein.models.preisach.MultivariableHysteresis` whose components
are generalised PI operators
(:class:`~hammerstein.models.generalized_pi.GeneralizedPI`: play operators
under one envelope function per side, Al Janaideh, Rakheja and Su [1]_ [2]_),
from the same records and the same training / held-out split as the classical
PI and the Preisach class
(:func:`hammerstein.identification.record_identification.split_record`: whole amplitude
levels of a decreasing-amplitude sine are held out, so the validation is on
minor loops not trained on).

The model of output l is

``y_l(t) = sum_k [ sum_j w^{lk}_j s^{lk}_j(t) + sum_n c^{lk}_n u_k(t)^n ] + offset_l``,

``s_j(t) = max(gamma_l(u(t)) - r_j, min(gamma_r(u(t)) + r_j, s_j(t - T)))``,
``gamma(u) = a0 tanh(a1 u + a2) + a3`` ([1]_, eqs. (4)-(6)).

It is linear in the weights ``w``, ``c`` and the offset once the envelope
parameters are given, so the fit is a *variable projection* (Golub and
Pereyra [3]_): :func:`scipy.optimize.least_squares` adjusts the envelope
parameters of the components of output l, and for each of its trial values
the weights are the bounded linear least-squares solution
(:func:`hammerstein.identification.lsq.bounded_lstsq`) on the training samples.
Its Jacobian is analytic (:mod:`hammerstein.identification._gpi_sensitivity`),
not 7 residual evaluations per component. On the realistic 2 x 2 records of
``benchmarks/identify.py`` (no creep): 132 residuals and 106 Jacobians against
1040 residuals, 1.46 -> 0.95 s CPU; costs +0.35/0.6 % (the optimum lies on a
kink, where a weight's bound turns active), held-out RMS x 0.1577 -> 0.1585 µm,
y 0.1289 -> 0.1285 µm.

Parametrisation of a component from input k (amplitude ``A`` [V], the largest
measured ``|u_k|``): ``gamma_l = [A, b_l / A, a2_l, 0]`` and ``gamma_r = [rho A,
b_r / A, a2_r, d A]`` (a common scale and a common shift of both envelopes are
the weights' and the offset's business); the thresholds are ``r_j = S j / n``
(``threshold_spacing="uniform"``, the default, 16 plays; ``S (j / n)^1.5``, denser
near zero, with ``"power"``; either by held-out error with ``"auto"``),
``j = 0 .. n - 1``, with ``S`` half the span of the mean envelope over the
measured input range, so that they follow the envelopes. Bounds: ``b`` in
[0.02, 4], ``a2`` in [-2, 2], ``rho`` in [0.3, 3], ``d`` in [-1, 1].

**Where the plays start: demagnetised** (``record_start``, docs/identification.md,
"Every record starts demagnetised"). Every record is played after
``excitation``'s ``demagnetise.csv``; by default the plays of every component of
input k start where it leaves them: from rest, through the turning points of
that cycle from input k's full amplitude around the centre of its range
(:func:`~hammerstein.models.demagnetisation.demagnetising_turning_points`), in
the fit, its Jacobian and the model
(:class:`~hammerstein.models.generalized_pi.GeneralizedPI` ``demagnetised``).
The plays' rest value is not seen after the cycle (fitted, it wandered along a
flat cost: records in nm and in µm gave models 3 % apart); its parameter ``q``
shifts the cycle's centre by ``q A`` instead (``demagnetised_centre``), so that
a model outside the actuator's class places the staircase the cycle leaves
where the records' first rise and idle inputs show it. Its Jacobian column is a
central difference (the cycle's inputs move with ``q``).

**Rest value of the plays** (``record_start="rest"``, records taken without
the cycle). Where the two envelopes are apart at ``u = 0``,
a play at rest may sit anywhere in its band ``[gamma_l(0) - r_j, gamma_r(0) +
r_j]``; the model's rest state is ``clip(sigma, ...)`` with ``sigma = q A``,
``q`` in [-0.5, 0.5] a 7th nonlinear parameter of each component
(:class:`~hammerstein.models.generalized_pi.GeneralizedPI` ``rest``). It
decides the initial loading curve and every small loop from rest that never
wipes it out (a 10 µm circle from rest on a ±12 µm actuator), and a
play whose rest is wrong shifts those loops by a constant, not their
amplitude. The burn-in of every record (its initial loading curve from its
start, left out of the split's training samples) is fitted in either case. Measured on
the 2 x 2 generalised-PI test actuator of the test suite (8 plays, 10-20 nm
noise, three noise seeds, the true dynamics, a Hammerstein compensator): a
10 µm circle at 50 Hz from rest ends within 1.25-1.57 % of the radius at
worst, against 1.6-3.3 % with the rest at 0 and the burn-in left out; the
never-recorded 15 % and 30 % loops from rest are within 0.7 % (0.2-5.2 %
before, the 5.2 % a fit whose rest value was wrong).

* **Direct paths** (k = l) are monotone, hence exactly invertible
  (:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`):
  ``w_j >= 0`` and a quadratic reversible term ``c_1 u + c_2 u^2`` whose slope
  is at least ``10^-3`` times the path's secant slope on the measured input
  range and on ``[-1.2 A, 1.2 A]`` (``A`` the input amplitude; the exact
  inverse keeps its inputs there), so the path increases wherever the
  inverse may drive it (the envelopes increase with u, so every play does).
  The quadratic is fitted by its slopes at the two ends of that range
  (:func:`monotone_quadratic_columns`): its slope is linear in u, so bounds on
  those two coefficients are exactly a bound on the slope everywhere between.
  A real actuator's anhysteretic curve is not odd (``realistic-gpi``'s paths
  have ``+0.02 u^2`` and ``-0.025 u^2``); with a linear term only, the fit
  bent the envelopes to mimic the curvature: on the y path alone, noiseless,
  with 10 power-spaced plays, it ended at envelopes ``(b_l, a2_l, rho, b_r,
  a2_r) = (0.47, 0.06, 1.0, 0.50, 0.25)`` against the true (0.9, -0.08, 1.15,
  0.75, 0.06), 15 % loops 0.48 µm off in shape; with the quadratic the same
  fit recovered the true envelopes and ``c_2`` within 1 % (with the default
  16 uniform plays, ``c_2`` within 5 % and the 15 % and 30 % loops within
  1 % of their range: ``tests/core/test_gpi_identification.py``).
* **Cross-couplings** (k != l) may be non-monotone or even: signed weights and
  a signed reversible polynomial ``c_1 u + c_2 u^2 + c_3 u^3``.

**Reversal curves.** With ``hammerstein excitation --reversals``, the
hysteresis records end with first-order reversal curves after the decreasing
sine's levels (:func:`hammerstein.signals.excitation.reversal_curves`); the fit
leaves them out (:func:`~hammerstein.identification.record_identification.levels_part`
cuts each record where it leaves its last level). Fitted on them too, on the
outside actuators of ``benchmarks/route_defaults.py``, the plays' shared
envelopes bent to the off-centre curves and the small centred loops paid:
gpi-5's worst feedforward circle went from 3.06 to 6.22 % of the radius,
gpi-11's from 3.84 to 5.3 %, and three rasters from 1.4-1.5 to 2.0-2.4 %.
The Preisach class, whose density is free over the whole plane, trains on
them.

**Level weighting.** Each training row of an amplitude level is scaled by
``A_max / A_level`` (``level_weighting="amplitude"``, the default): the fit
minimises each level's residual relative to its amplitude, as ``identify
--model auto`` scores the held-out levels, so that the 20 % level counts as
much as the full one. A 15 µm circle on a ±55 µm actuator lives in loops
about that small. See ``GeneralizedPIIdentifier``'s ``level_weighting`` for
what it changed on the outside actuators.

A cross-coupling that does not lower the held-out error of its output by
more than the noise can explain
(:func:`hammerstein.identification.record_identification.weak_couplings`) is
dropped by ``components="auto"``; every other one stays.

Length: the identifier's notes keep the measurements behind each default (plays,
spacing, starts, evaluation budget) next to it, and the regression and its Jacobian's
bookkeeping belong together.

References
----------
.. [1] M. Al Janaideh, S. Rakheja, C.-Y. Su, "An analytical generalized
   Prandtl-Ishlinskii model inversion for hysteresis compensation in
   micropositioning control", IEEE/ASME Trans. Mechatronics 16(4), 734-744,
   2011.
.. [2] M. Al Janaideh, S. Rakheja, C.-Y. Su, "A generalized Prandtl-Ishlinskii
   model for characterizing the hysteresis and saturation nonlinearities of
   smart actuators", Smart Materials and Structures 18(4), 045001, 2009; and
   "Experimental characterization and modeling of rate-dependent hysteresis
   of a piezoceramic actuator", Mechatronics 19(5), 656-670, 2009.
.. [3] G. H. Golub and V. Pereyra, "Separable nonlinear least squares: the
   variable projection method and its applications", Inverse Problems 19(2),
   R1-R26, 2003.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.optimize

from hammerstein.models.demagnetisation import (RECORD_STARTS, demagnetising_cycle_of_range,
                                                demagnetising_turning_points)
from hammerstein.models.generalized_pi import GeneralizedPI, envelope
from hammerstein.identification._gpi_sensitivity import (play_sensitivities, span_gradient,
                                                          vp_jacobian)
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification.lsq import bounded_lstsq
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial
from hammerstein.identification.record_identification import (
    RecordFit, _window_metrics, level_errors, level_weights, levels_part, parse_components,
    split_level_records, weak_couplings)
from hammerstein.simulation import generalized_play_states

__all__ = ["GeneralizedPIIdentifier", "identify_gpi_records"]

#: Rows of the regression kept per record (quasi-static records are decimated to this).
MAX_ROWS_PER_RECORD = 3000
#: Lower bound of a direct path's reversible slope on the input range, fraction of the secant.
MIN_SLOPE_FRACTION = 1e-3
#: The exact inverse keeps inputs within this many times the model's input amplitude
#: (:class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`): a direct path's
#: reversible slope is kept positive there, not only on the measured range.
INVERSE_RANGE = 1.2
#: Degree of the signed reversible polynomial of a cross-coupling.
CROSS_DEGREE = 3
#: Thresholds ``r_j = S (j / n)^power`` of the ``"power"`` spacing: denser near 0, where the
#: small minor loops live.
THRESHOLD_POWER = 1.5
#: Threshold spacings tried by ``threshold_spacing="auto"``, in this order (a tie keeps the first).
THRESHOLD_SPACINGS = ("power", "uniform")
#: Row weightings of the fit (``GeneralizedPIIdentifier``'s ``level_weighting``).
LEVEL_WEIGHTINGS = ("amplitude", "none")
_SPACING_LABEL = {"power": f"r_j = S (j/n)^{THRESHOLD_POWER:g}", "uniform": "r_j = S j/n"}
#: Normalised parameters ``(b_l, a2_l, rho, b_r, a2_r, d, q)`` of a component: the envelopes
#: and the plays' rest value ``sigma = q A``; start, lower and upper bounds.
THETA0 = np.array([0.3, 0.0, 1.0, 0.3, 0.0, 0.0, 0.0])
THETA_LO = np.array([0.02, -2.0, 0.3, 0.02, -2.0, -1.0, -0.5])
THETA_HI = np.array([4.0, 2.0, 3.0, 4.0, 2.0, 1.0, 0.5])
#: Parameters per component.
N_THETA = THETA0.size
#: Starts of the envelope fit, ``THETA0`` first (``n_starts`` of them are screened, the
#: lowest training cost fitted on): steeper envelopes with a narrower span, flatter ones with
#: a wider span, and curved ones. The variable projection is not convex in the envelopes; from
#: ``THETA0`` alone it stopped in another minimum on several outside actuators (see
#: ``GeneralizedPIIdentifier``'s ``n_starts``).
#: Steps each start gets before the lowest cost is chosen and fitted on (the rest of
#: ``max_evaluations``): a full fit from every start doubled the identification's CPU.
START_SCREEN = 20
THETA_STARTS = (THETA0,
                np.array([1.0, 0.0, 0.6, 1.0, 0.0, 0.0, 0.0]),
                np.array([0.1, 0.0, 1.6, 0.1, 0.0, 0.0, 0.0]),
                np.array([0.6, 0.5, 1.0, 0.6, -0.5, 0.0, 0.0]))


def envelopes(theta, amplitude):
    """Envelope coefficients ``gamma_l, gamma_r`` of the normalised parameters.

    Parameters
    ----------
    theta : array_like, shape (6,) or (7,)
        ``(b_l, a2_l, rho, b_r, a2_r, d)`` (see the module notes); a 7th
        entry (the rest value) is ignored.
    amplitude : float
        Input amplitude A [V].

    Returns
    -------
    gamma_l, gamma_r : numpy.ndarray, shape (4,)
        ``a0 tanh(a1 u + a2) + a3`` coefficients.
    """
    b_l, a2_l, rho, b_r, a2_r, d = np.asarray(theta, dtype=float)[:6]
    a = float(amplitude)
    return (np.array([a, b_l / a, a2_l, 0.0]), np.array([rho * a, b_r / a, a2_r, d * a]))


def play_thresholds(gamma_l, gamma_r, lo, hi, n, spacing="power"):
    """Thresholds ``r_j = S (j / n)^1.5`` or ``S j / n`` following the envelopes.

    Parameters
    ----------
    gamma_l, gamma_r : array_like, shape (4,)
        Envelope coefficients.
    lo, hi : float
        Measured input range [V].
    n : int
        Number of plays.
    spacing : {"power", "uniform"}
        ``r_j = S (j / n)^THRESHOLD_POWER`` (denser near 0) or ``S j / n``
        (see the module notes).

    Returns
    -------
    numpy.ndarray, shape (n,)
        Thresholds, strictly increasing from 0.

    Raises
    ------
    ValueError
        On another ``spacing``.
    """
    mid = lambda u: 0.5 * (envelope(gamma_l, u) + envelope(gamma_r, u))  # noqa: E731
    span = max(0.5 * float(mid(hi) - mid(lo)), 1e-9)
    if spacing not in THRESHOLD_SPACINGS:
        raise ValueError(f"spacing: expected one of {THRESHOLD_SPACINGS}, found {spacing!r}")
    return span * _threshold_fractions(n, spacing)


def _threshold_fractions(n, spacing):
    """``c_j`` of :func:`play_thresholds`' ``r_j = S c_j``."""
    return (np.arange(n) / n) ** (THRESHOLD_POWER if spacing == "power" else 1.0)


def monotone_quadratic_columns(u, lo, hi):
    """Columns of a quadratic whose coefficients are its slopes at the ends of [lo, hi].

    ``p(u) = g_lo (hi u - u^2 / 2) / (hi - lo) + g_hi (u^2 / 2 - lo u) / (hi - lo)``
    has ``p(0) = 0`` and the slope ``p'(u) = g_lo (hi - u) / (hi - lo) + g_hi (u - lo) /
    (hi - lo)``, linear in u and equal to ``g_lo`` at ``lo`` and ``g_hi`` at ``hi``; so
    ``g_lo, g_hi >= m`` (bounds of the linear least squares) is exactly ``p' >= m`` on
    the whole of [lo, hi]: a monotone reversible term with curvature (e.g. ``c_1 u +
    c_2 u^2``, the even part of a real actuator's anhysteretic curve).

    Parameters
    ----------
    u : numpy.ndarray, shape (n_samples,)
        Input (any unit, here normalised by the amplitude).
    lo, hi : float
        Range of the input, ``lo < hi``.

    Returns
    -------
    numpy.ndarray, shape (n_samples, 2)
        The columns multiplying ``g_lo`` and ``g_hi``.
    """
    span = hi - lo
    return np.column_stack([(hi * u - 0.5 * u ** 2) / span, (0.5 * u ** 2 - lo * u) / span])


def quadratic_coefficients(slopes, lo, hi):
    """Monomial coefficients ``(c_1, c_2)`` of :func:`monotone_quadratic_columns`' quadratic.

    Parameters
    ----------
    slopes : array_like, shape (2,)
        ``g_lo, g_hi``, the slopes at ``lo`` and ``hi``.
    lo, hi : float
        Range of the input, ``lo < hi``.

    Returns
    -------
    numpy.ndarray, shape (2,)
        ``c_1 = (g_lo hi - g_hi lo) / (hi - lo)``, ``c_2 = (g_hi - g_lo) / (2 (hi - lo))``:
        ``p(u) = c_1 u + c_2 u^2``.

    Examples
    --------
    >>> import numpy as np
    >>> u = np.linspace(-1.0, 1.0, 5)
    >>> c = quadratic_coefficients([3.0, 1.0], -1.0, 1.0)
    >>> c.tolist(), bool(np.allclose(monotone_quadratic_columns(u, -1.0, 1.0) @ [3.0, 1.0],
    ...                               c[0] * u + c[1] * u ** 2))
    ([2.0, -0.5], True)
    """
    g_lo, g_hi = np.asarray(slopes, dtype=float)
    span = hi - lo
    return np.array([(g_lo * hi - g_hi * lo) / span, (g_hi - g_lo) / (2.0 * span)])


def _kept_rows(rec, m):
    """Every ``step``-th sample plus each reversal of any input (exact play states there)."""
    step = max(1, int(np.ceil(rec.n_samples / MAX_ROWS_PER_RECORD)))
    keep = np.zeros(rec.n_samples, dtype=bool)
    keep[::step] = True
    keep[-1] = True
    for k in range(m):
        d = np.diff(rec.u[k])
        nz = np.flatnonzero(d)
        flip = np.flatnonzero(np.diff(np.sign(d[nz])) != 0)
        keep[nz[flip] + 1] = True
    return keep


def _burn_in(split):
    """Samples of a record before its first training or held-out sample (its burn-in)."""
    used = split.train | split.held_out
    first = int(np.argmax(used)) if used.any() else used.size
    return np.arange(used.size) < first


def _play_states(u, thresholds, gamma_l, gamma_r, rest, prefix):
    """Play trajectories (n_samples, n) from the model's initial state.

    The plays at rest at u = 0 (``GeneralizedPI.rest_state``), driven through ``prefix``
    (the demagnetising cycle's turning points, or nothing) before ``u``.
    """
    s0 = np.maximum(envelope(gamma_l, 0.0) - thresholds,
                    np.minimum(envelope(gamma_r, 0.0) + thresholds, rest))
    if prefix.size:
        s0 = generalized_play_states(prefix, thresholds, gamma_l, gamma_r, s0)[1]
    return generalized_play_states(u, thresholds, gamma_l, gamma_r, s0)[0]


class GeneralizedPIIdentifier:
    """Fit a multivariable generalised PI model to records (see the module notes).

    Parameters
    ----------
    n_plays : int
        Play operators per component (thresholds: see ``threshold_spacing``);
        16 by default (see ``threshold_spacing`` for why).
    components : "auto", "all", str or dict
        As :func:`hammerstein.identification.record_identification.parse_components`;
        ``"gain"`` components are fitted as a linear term, ``"none"`` left out.
        ``"auto"`` drops a cross-coupling whose contribution is below twice
        the noise.
    max_evaluations : int
        Largest number of steps tried per output (``max_nfev`` of
        :func:`scipy.optimize.least_squares`), at most one analytic Jacobian
        per step (about two residuals of CPU; the notes count both). With
        finite differences (7 uncounted trials per component and step), on
        ``scenarios/presets/realistic-gpi.toml`` identified
        through ``hammerstein identify --model generalized --creep-records``,
        60 trials left the fit short of its minimum (circles 2.3-4.7 % of the
        radius); 300 gave 1.06-2.59 %.
    n_starts : int
        Starts of each output's envelope fit (``THETA_STARTS``, from 1 to 4;
        default 4): each gets ``START_SCREEN`` steps, and the one with the
        lowest training cost is fitted on with the rest of
        ``max_evaluations``. The variable projection is not convex in the
        envelopes. On the ten generalised-PI-type actuators of
        ``benchmarks/route_defaults.py`` (every default, the same records),
        the default start alone stopped in another minimum on several
        outputs (gpi-11's x: cost 4.9e-3 against 4.0e-3 from the second
        start); with four screened starts their worst feedforward circle
        went from 5.14 to 4.02 % of the radius (3.88 % with every start
        fitted to the end, which took ``identify --model generalized`` from
        3.6 to 8.7-9.1 s of scaled CPU; screened 4.7 s) and the raster
        against the shaped reference from a median of 2.66 to 1.56 %; one
        member's worst circle went the other way (gpi-7, 2.06 to 3.63 %).
    threshold_spacing : {"uniform", "power", "auto"}
        Play thresholds ``r_j = S j / n`` (``"uniform"``, the default),
        ``S (j / n)^1.5`` (``"power"``: dense near zero), or both fitted and
        the one with the lower mean held-out minor-loop RMS error (Euclidean,
        every output, % of each held-out level's range; without held-out
        levels the mean
        held-out RMS, without any held-out sample the first, ``"power"``)
        kept, like the partition ``"auto"`` of the classical PI (twice the
        CPU). Why 16 uniform plays by default, measured on three
        generalised-PI actuators outside the fitted class (their thresholds,
        envelopes and reversible terms are not the identifier's), all with
        the quadratic reversible term of the direct paths:
        ``scenarios/presets/realistic-gpi.toml`` (records of ``hammerstein
        excitation``, 40 nm noise, identified and compensated through the
        CLI, ``benchmarks/real_actuators.py --creep --model generalized``,
        noise seeds 17, 18, 19): 15 µm circle at 20 Hz 1.81, 1.86, 1.89 % of
        the radius with 16 uniform plays, against 0.87, 4.18, 0.69 % with
        10 uniform plays and 2.39 % (seed 17) with 10 power-spaced plays; the
        test suite's CLI actuator (``tests/gpi_actuator.py``): loops at 15 %
        and 30 % within 0.3 % with 16 uniform plays, the y loop at 30 % 2.2 %
        off with 10 power-spaced ones; the test suite's noiseless-reversible
        actuator (10 nm noise, seeds 0-2): the never-recorded 15 % loop of
        y 6.6-6.7 % off with 8 uniform plays, 2.8 % with 10, 1.3-1.4 % with
        16 (power-spaced 8: 0.1 %). Fewer uniform plays leave the small loops
        to a coarse grid near zero, and which grid point lands near the
        actuator's own thresholds decides them (the seed-to-seed spread of
        10 plays); 16 make that spread small. Cross-couplings with 10
        power-spaced plays instead (a few µm near the noise, signed weights:
        tried to leave them less room to fit the records' creep) put that
        circle at 1.01, 2.11, 2.34 % over the same seeds: not kept. The held-out levels (40 % and
        80 %) hardly tell the spacings apart (score differences of 1-8 %,
        of the order of the seed-to-seed spread), which is why ``"auto"`` is
        not the default.
    level_weighting : {"amplitude", "none"}
        Rows of the fit. ``"amplitude"`` (the default) scales the rows of
        each amplitude level by ``A_max / A_level``
        (:func:`~hammerstein.identification.record_identification.level_weights`):
        the fit minimises each level's residual relative to its amplitude,
        the measure of ``identify --model auto``'s held-out score.
        ``"none"`` weighs every row alike; the full-amplitude levels, whose
        residuals are the largest in µm, then decide the small loops. On the
        20 outside actuators of ``benchmarks/route_defaults.py`` (every
        default, the same records), the seven where ``auto`` keeps the
        generalised PI, worst feedforward circle with ``"none"`` →
        ``"amplitude"``: gpi-1 2.67 → 1.71, gpi-7 3.63 → 2.45, gpi-9 2.49 →
        2.28, gpi-11 3.84 → 1.86, gpi-13 4.02 → 2.46, gpi-15 2.12 → 1.62,
        gpi-17 1.32 → 0.85 % of the radius; the 40 x 40 µm raster against
        the shaped reference rose on gpi-1 (1.44 → 1.99 %) and gpi-7 (1.53 →
        2.16 %) and fell on the other five (to 0.94-1.57 %).
    record_start : {"demagnetised", "rest"}
        The state every record starts from: after ``excitation``'s
        ``demagnetise.csv`` (``"demagnetised"``, the default; module notes),
        or the plays at their rest value (``"rest"``: records taken without
        the cycle). On the 20 outside actuators of
        ``benchmarks/route_defaults.py`` (every default): worst feedforward
        circle 3.33 → 2.66 % of the radius, median 0.748 → 0.758 %; the
        bundled real record, taken without the cycle: held-out RMS 0.081 µm
        at rest, 0.099 µm demagnetised (docs/identification.md).

    Attributes
    ----------
    model_ : MultivariableHysteresis
        The identified model; components
        :class:`~hammerstein.models.generalized_pi.GeneralizedPI`, gains or None.
    envelope_parameters_ : list of list of numpy.ndarray or None
        Normalised parameters ``(b_l, a2_l, rho, b_r, a2_r, d, q)`` per
        (output, input): the envelopes and the rest value ``q A`` of the plays
        (with ``record_start="demagnetised"``, the shift ``q A`` of the
        demagnetising cycle's centre).
    structure_ : list of list of str
        ``"generalized"``, ``"gain"`` or ``"none"`` per (output, input).
    notes_ : list of str
        What was decided automatically.
    fit_ : RecordFit
        Records, splits, predictions, training and held-out errors and
        per-level errors (:func:`hammerstein.identification.record_identification.level_errors`);
        its ``partition`` is the threshold spacing used and ``partition_scores``
        the held-out score [%] of each spacing fitted.
    threshold_spacing_ : {"power", "uniform"}
        The threshold spacing used (``threshold_spacing``, or auto's choice).
    spacing_scores_ : dict of str to float or None
        Held-out score [%] of each spacing fitted (see ``threshold_spacing``);
        None without held-out samples.

    Raises
    ------
    IdentificationError
        On bad parameters or records that cannot be split.

    Examples
    --------
    A one-input actuator with asymmetric, saturating envelopes and other
    thresholds than the identifier's, identified from a decreasing-amplitude
    sine; the held-out levels (minor loops) are predicted to a fraction of a
    percent of their range:

    >>> import numpy as np
    >>> from hammerstein.io.datafiles import MultiRecord
    >>> from hammerstein.signals.excitation import decreasing_sine
    >>> from hammerstein.models.generalized_pi import GeneralizedPI
    >>> true = GeneralizedPI([0.0, 0.7, 1.9, 3.5], [1.2, 0.4, 0.25, 0.2],
    ...                      gamma_l=[16.0, 0.07, 0.1, 0.0], gamma_r=[14.0, 0.08, -0.05, 0.4])
    >>> t, u, _ = decreasing_sine(1e-3, 10.0)
    >>> y, _ = true.simulate(u)
    >>> rec = MultiRecord(t, u[np.newaxis], y[np.newaxis], ("u",), ("y",), 1e-3, "sim")
    >>> est = GeneralizedPIIdentifier(n_plays=8).fit(rec)
    >>> bool(est.fit_.validation[0]["rms_percent"] < 0.5)
    True
    """

    def __init__(self, n_plays=16, components="auto", max_evaluations=300,
                 threshold_spacing="uniform", n_starts=len(THETA_STARTS),
                 level_weighting="amplitude", record_start="demagnetised"):
        if isinstance(n_plays, bool) or not isinstance(n_plays, (int, np.integer)) \
                or not 2 <= n_plays <= 40:
            raise IdentificationError(f"n_plays: expected an integer from 2 to 40, found {n_plays!r}")
        if isinstance(max_evaluations, bool) or not isinstance(max_evaluations, (int, np.integer)) \
                or max_evaluations < 1:
            raise IdentificationError(f"max_evaluations: expected a positive integer, found "
                                      f"{max_evaluations!r}")
        if threshold_spacing not in ("auto",) + THRESHOLD_SPACINGS:
            raise IdentificationError(f"threshold_spacing: expected 'auto', 'power' or 'uniform', "
                                      f"found {threshold_spacing!r}")
        if isinstance(n_starts, bool) or not isinstance(n_starts, (int, np.integer)) \
                or not 1 <= n_starts <= len(THETA_STARTS):
            raise IdentificationError(f"n_starts: expected an integer from 1 to {len(THETA_STARTS)}, "
                                      f"found {n_starts!r}")
        if level_weighting not in LEVEL_WEIGHTINGS:
            raise IdentificationError(f"level_weighting: expected one of {LEVEL_WEIGHTINGS}, "
                                      f"found {level_weighting!r}")
        if record_start not in RECORD_STARTS:
            raise IdentificationError(f"record_start: expected one of {RECORD_STARTS}, "
                                      f"found {record_start!r}")
        self.level_weighting, self.record_start = level_weighting, record_start
        self.n_starts = int(n_starts)
        self.n_plays, self.components = int(n_plays), components
        self.max_evaluations = int(max_evaluations)
        self.threshold_spacing = threshold_spacing

    def __repr__(self):
        return (f"GeneralizedPIIdentifier(n_plays={self.n_plays}, components={self.components!r}, "
                f"max_evaluations={self.max_evaluations}, "
                f"threshold_spacing={self.threshold_spacing!r}, n_starts={self.n_starts}, "
                f"level_weighting={self.level_weighting!r}, "
                f"record_start={self.record_start!r})")

    # -- the regression ----------------------------------------------------------------
    def _start(self, k, q):
        """(rest value, cycle centre, input before the records) [V] of input k's plays at q.

        Demagnetised: the plays at rest at 0, then the demagnetising cycle's turning
        points around the centre of the range shifted by ``q A``; at rest: the rest value
        ``q A``, no cycle.
        """
        amp, centre = self._demagnetised[k]
        if not amp:
            return float(q) * self._amp[k], 0.0, np.zeros(0)
        centre = centre + float(q) * self._amp[k]
        return 0.0, centre, demagnetising_turning_points(amp, centre)

    def _slope_range(self, k):
        """Normalised range on which a direct path's reversible slope is bounded below."""
        return (min(self._lo[k] / self._amp[k], -INVERSE_RANGE),
                max(self._hi[k] / self._amp[k], INVERSE_RANGE))

    def _component_width(self, kind, direct):
        """Columns of a component of ``kind`` in the regression (plays, then polynomial)."""
        if kind == "generalized":
            return self.n_plays + (2 if direct else CROSS_DEGREE)
        return 1 if kind == "gain" else 0

    def _training_input(self, k):
        """Input k on the kept training rows, every record end to end, normalised."""
        return np.concatenate([u[k][tr] for u, tr in zip(self._u, self._train)]) / self._amp[k]

    def _polynomial_columns(self, k, direct):
        """Reversible-term columns of input k (the same at every envelope trial: cached)."""
        key = (k, direct)
        if key not in self._poly_cache:
            u = self._training_input(k)
            if direct:
                poly = monotone_quadratic_columns(u, *self._slope_range(k))
            else:
                poly = np.column_stack([u ** d for d in range(1, CROSS_DEGREE + 1)])
            self._poly_cache[key] = poly * self._w[:, None]
        return self._poly_cache[key]

    def _component_columns(self, k, theta, direct, out):
        """Play and polynomial columns of input k on the kept training rows, into ``out``.

        ``out`` (n_rows, n_plays + n_poly) receives the plays of each record (its
        training rows) one record after the other, then the polynomial columns.
        Returns the thresholds and envelopes ``(r, gl, gr)``.
        """
        gl, gr = envelopes(theta, self._amp[k])
        r = play_thresholds(gl, gr, self._lo[k], self._hi[k], self.n_plays, self._spacing)
        rest, _, prefix = self._start(k, theta[6])
        row = 0
        for u, tr in zip(self._u, self._train):
            states = _play_states(u[k], r, gl, gr, rest, prefix)[tr]
            np.multiply(states, self._w[row:row + states.shape[0], None],
                        out=out[row:row + states.shape[0], :self.n_plays])
            row += states.shape[0]
        out[:, self.n_plays:] = self._polynomial_columns(k, direct)
        return r, gl, gr

    def _solve(self, l, kinds, thetas):
        """Bounded least-squares weights of output l for given envelopes; (x, A, pieces).

        The regression matrix ``A`` (training rows, the components' columns then a
        column of ones) is written into one buffer per output, reused by every
        envelope trial (the same values as stacking the columns, without the copies).
        """
        m = len(kinds)
        lbs, pieces = [], []
        y = self._y[l]
        widths = [self._component_width(kinds[k], k == l) for k in range(m)]
        shape = (y.size, sum(widths) + 1)
        A, layout, written = self._buffers.get(l, (None, None, None))
        if A is None or A.shape != shape or layout != tuple(kinds):
            A, written = np.empty(shape), {}
            self._buffers[l] = (A, tuple(kinds), written)
        c = 0
        for k in range(m):
            block = A[:, c:c + widths[k]]
            if kinds[k] == "generalized":
                # a component whose envelopes are those its columns hold (the other
                # component's finite-difference steps) is not stepped again
                theta = np.asarray(thetas[k], dtype=float).tobytes()
                if k in written and written[k][0] == theta:
                    r, gl, gr = written[k][1]
                else:
                    written.pop(k, None)
                    r, gl, gr = self._component_columns(k, thetas[k], k == l, block)
                    written[k] = (theta, (r, gl, gr))
                lb = np.full(widths[k], -np.inf)
                if k == l:
                    lb[:self.n_plays] = 0.0
                    secant = np.ptp(y / self._w) / max(self._hi[k] - self._lo[k], 1e-300)
                    lb[self.n_plays:] = MIN_SLOPE_FRACTION * abs(secant) * self._amp[k]
                pieces.append((r, gl, gr, widths[k]))
            elif kinds[k] == "gain":
                block[:, 0] = np.concatenate([u[k][tr] for u, tr in zip(self._u, self._train)]) \
                    * self._w
                lb = np.array([-np.inf])
                pieces.append((None, None, None, 1))
            else:
                lb = np.zeros(0)
                pieces.append((None, None, None, 0))
            lbs.append(lb)
            c += widths[k]
        A[:, c] = self._w
        lb = np.concatenate(lbs + [[-np.inf]])
        col = np.linalg.norm(A, axis=0)
        col = np.where(col > 0, col, 1.0)
        # ||A x - y|| = ||R x - Q^T y|| + const: R of [A | y] holds Q^T y in its last column
        # (no Q formed); the bounded solver works on the small R. R is the Cholesky factor of
        # the Gram matrix of [A | y] (a tiny ridge for a record fitted exactly), by far cheaper
        # than a QR of the tall matrix; QR when the Gram matrix is too ill-conditioned.
        # y to unit RMS: the ridge, relative to the trace, is then the same whatever the
        # output's unit (with y in nm it was 1e6 times the µm one, 1e-13 |y|^2 on unit columns)
        ny = max(float(np.sqrt(np.mean(y ** 2))), 1e-300)
        Ay = np.empty((y.size, A.shape[1] + 1))
        np.divide(A, col, out=Ay[:, :-1])
        Ay[:, -1] = y / ny
        gram = Ay.T @ Ay
        gram[np.diag_indices_from(gram)] += 1e-13 * np.trace(gram)
        try:
            R = scipy.linalg.cholesky(gram, lower=False)
        except np.linalg.LinAlgError:
            R = np.linalg.qr(Ay, mode="r")
        self._bounds = (lb, col)
        return bounded_lstsq(R[:-1, :-1], R[:-1, -1], lb * col / ny) * (ny / col), A, pieces

    def _jacobian(self, l, kinds, thetas, free, solved=None):
        """Output l's residual's Jacobian (:func:`vp_jacobian`); ``solved``: last (x, A) there."""
        x, A = solved if solved is not None else self._solve(l, kinds, thetas)[:2]
        lb, col = self._bounds
        y = self._y[l]
        r = A @ x - y
        Dx = np.zeros((y.size, N_THETA * len(free)))
        DTr = np.zeros((A.shape[1], Dx.shape[1]))
        starts = np.cumsum([0] + [self._component_width(kd, k == l) for k, kd in enumerate(kinds)])
        for i, k in enumerate(free):
            theta = np.asarray(thetas[k], dtype=float)
            gl, gr = envelopes(theta, self._amp[k])
            rr = play_thresholds(gl, gr, self._lo[k], self._hi[k], self.n_plays, self._spacing)
            frac = _threshold_fractions(self.n_plays, self._spacing)
            dspan = span_gradient(theta, self._amp[k], self._lo[k], self._hi[k])
            plays, row = slice(starts[k], starts[k] + self.n_plays), 0
            sl = slice(N_THETA * i, N_THETA * (i + 1))
            rest, _, prefix = self._start(k, theta[6])
            kernel_theta = np.r_[theta[:6], rest / self._amp[k]]
            # after a cycle, q moves the cycle's inputs: its column by central differences
            h = 1e-6
            shifted = ([self._start(k, theta[6] + d)[2] for d in (h, -h)]
                       if self._demagnetised[k][0] else None)
            for u, tr in zip(self._u, self._train):
                sens = play_sensitivities(u[k], rr, frac, kernel_theta, self._amp[k], dspan,
                                          prefix)[1][tr]
                if shifted is not None:
                    up, down = (_play_states(u[k], rr, gl, gr, 0.0, p)[tr] for p in shifted)
                    sens[..., 6] = (up - down) / (2 * h)
                rows = slice(row, row + sens.shape[0])
                sens *= self._w[rows, None, None]
                Dx[rows, sl] = np.einsum("tjp,j->tp", sens, x[plays])
                DTr[plays, sl] += np.einsum("tjp,t->jp", sens, r[rows])
                row += sens.shape[0]
        return vp_jacobian(A, x, r, lb, col, Dx, DTr) / np.sqrt(y.size)

    def _fit_output(self, l, kinds):
        """Envelopes by least_squares, weights projected out; the output's components."""
        m = len(kinds)
        free = [k for k in range(m) if kinds[k] == "generalized"]
        y = self._y[l]
        # the residual in units of y's RMS: least_squares' gradient tolerance (gtol) is
        # absolute, and stopped the fit of y in metres after a third of the µm one's steps
        scale = np.sqrt(y.size) * max(float(np.sqrt(np.mean(y ** 2))), 1e-300)

        def unpack(z):
            thetas = [None] * m
            for i, k in enumerate(free):
                thetas[k] = z[N_THETA * i:N_THETA * (i + 1)]
            return thetas

        last = {}

        def residual(z):
            self._evaluations += 1
            x, A, _ = self._solve(l, kinds, unpack(z))
            last.clear()       # A is the buffer, valid until the next solve
            last[np.asarray(z, dtype=float).tobytes()] = (x, A)
            return (A @ x - y) / scale

        def jacobian(z):           # least_squares asks at the step it just evaluated: no re-solve
            self._jacobians += 1
            return self._jacobian(l, kinds, unpack(z), free,
                                  last.get(np.asarray(z, float).tobytes())) * (np.sqrt(y.size) / scale)

        if free:
            def run(z0, budget):
                return scipy.optimize.least_squares(
                    residual, z0, jac=jacobian,
                    bounds=(np.tile(THETA_LO, len(free)), np.tile(THETA_HI, len(free))),
                    method="trf", x_scale=np.tile(THETA_HI - THETA_LO, len(free)),
                    max_nfev=budget)

            if self.n_starts == 1:
                best = run(np.tile(THETA0, len(free)), self.max_evaluations)
            else:       # each start screened, the lowest cost (a tie: the first) fitted on
                screen = min(START_SCREEN, self.max_evaluations)
                best = min((run(np.tile(t, len(free)), screen) for t in THETA_STARTS[:self.n_starts]),
                           key=lambda r: r.cost)
                if best.status == 0 and self.max_evaluations > screen:     # its budget ran out
                    best = run(best.x, self.max_evaluations - screen)
            z = best.x
        else:
            z = np.zeros(0)
        thetas = unpack(z)
        x, _, pieces = self._solve(l, kinds, thetas)
        comps, c = [], 0
        for k, (r, gl, gr, size) in enumerate(pieces):
            xk = x[c:c + size]
            c += size
            if kinds[k] == "none":
                comps.append(None)
            elif kinds[k] == "gain":
                comps.append(float(xk[0]))
            else:
                w = xk[:self.n_plays]
                poly = xk[self.n_plays:]
                if k == l:
                    w = np.maximum(w, 0.0)
                    poly = quadratic_coefficients(poly, *self._slope_range(k))
                rev = poly / self._amp[k] ** np.arange(1, xk.size - self.n_plays + 1)
                rest, centre, _ = self._start(k, thetas[k][6])
                comps.append(GeneralizedPI(r, w, gl, gr, 0.0, rev, rest,
                                           self._demagnetised[k][0], centre))
        return comps, float(x[-1]), thetas

    @staticmethod
    def _model(grid, offsets, in_names, out_names, amplitude):
        grid = [list(row) for row in grid]
        for l, off in enumerate(offsets):        # the output offset goes to the direct path
            ks = ([l] if l < len(grid[l]) and grid[l][l] is not None else []) + \
                [k for k, c in enumerate(grid[l]) if c is not None]
            if not ks:
                grid[l][0] = Polynomial([0.0], off)
                continue
            c = grid[l][ks[0]]
            if isinstance(c, GeneralizedPI):
                grid[l][ks[0]] = c.replace(offset=c.offset + off)
            else:
                grid[l][ks[0]] = Polynomial([float(c)], off)
        return MultivariableHysteresis(grid, in_names, out_names, amplitude)

    # -- public --------------------------------------------------------------------------
    def fit(self, records, splits=None, input_names=None, output_names=None, hold_out="auto",
            train_fraction=None, skip_seconds=None):
        """Identify the model from records.

        Parameters
        ----------
        records : MultiRecord, Record or sequence of them
            Inputs shape (m, n_samples) [V], outputs shape (p, n_samples) [µm].
        splits : list of Split, optional
            Training / held-out samples per record; by default
            :func:`~hammerstein.identification.record_identification.split_record`
            with ``hold_out``, ``train_fraction`` and ``skip_seconds``.
        input_names, output_names : sequence of str, optional
            Names in the model (default: the records' column names).
        hold_out, train_fraction, skip_seconds
            See :func:`~hammerstein.identification.record_identification.split_record`.

        Returns
        -------
        GeneralizedPIIdentifier
            ``self``, with the fitted attributes.

        Raises
        ------
        IdentificationError
            On records that cannot be split or a model that cannot be fitted.
        """
        records, splits = split_level_records(records, hold_out, train_fraction, skip_seconds,
                                              splits, "a generalised PI model")
        # the first-order reversal curves after the levels are left to the Preisach class
        # (module notes, "Reversal curves")
        records, splits, n_cut = levels_part(records, splits)
        m, p = records[0].u.shape[0], records[0].y.shape[0]
        in_names = list(input_names or records[0].input_names)
        out_names = list(output_names or records[0].output_names)
        kinds0, auto = parse_components(self.components, in_names, out_names)
        kinds = [["generalized" if kd == "pi" else kd for kd in row] for row in kinds0]
        lo = np.min([r.u.min(axis=1) for r in records], axis=0)
        hi = np.max([r.u.max(axis=1) for r in records], axis=0)
        self._lo, self._hi = lo, hi
        self._amp = np.maximum(np.maximum(np.abs(lo), np.abs(hi)), 1e-12)
        # each record starts after the demagnetising cycle of its input's range (or at rest)
        self._demagnetised = [demagnetising_cycle_of_range(a, b)
                              if self.record_start == "demagnetised"
                              else (0.0, 0.0) for a, b in zip(lo, hi)]
        # after the cycle the plays' rest value is not seen (a play the cycle moves forgets
        # it, one the cycle never moves is constant in the records too): q shifts the
        # cycle's centre instead (_start)
        for k in range(m):                    # an input that never moves: no component
            if hi[k] <= lo[k]:
                for l in range(p):
                    if kinds[l][k] == "generalized":
                        kinds[l][k] = "none"
        keeps = [_kept_rows(r, m) for r in records]
        self._u = [r.u[:, keep] for r, keep in zip(records, keeps)]
        # the burn-in (the initial loading curve from the start) is fitted too: it is what
        # places the plays' rest value (with record_start="rest") and checks the start
        self._train = [(s.train | _burn_in(s))[keep] for s, keep in zip(splits, keeps)]
        if not any(tr.any() for tr in self._train):
            raise IdentificationError("records: no training samples")
        # every training row scaled by its level's weight (the rows, the output and, in the
        # Jacobian, the sensitivities): each level's residual relative to its amplitude
        self._w = np.concatenate([
            (level_weights(s, r.u.shape[1]) if self.level_weighting == "amplitude"
             else np.ones(r.u.shape[1]))[keep][tr]
            for r, s, keep, tr in zip(records, splits, keeps, self._train)])
        self._y = [np.concatenate([r.y[l][keep][tr] for r, keep, tr in
                                   zip(records, keeps, self._train)]) * self._w for l in range(p)]
        self._poly_cache, self._buffers = {}, {}
        held = any(s.held_out.any() for s in splits)
        tried = list(THRESHOLD_SPACINGS) if self.threshold_spacing == "auto" \
            else [self.threshold_spacing]
        fits, evaluations = {}, {}
        for spacing in tried:
            fits[spacing], evaluations[spacing] = self._fit_spacing(
                spacing, records, splits, [list(row) for row in kinds], auto, in_names,
                out_names, held)
        scores = {sp: _spacing_score(f) for sp, f in fits.items()}
        if all(v is not None for v in scores.values()):
            best = min(tried, key=lambda sp: scores[sp])      # ties: the first, power
            basis = ("mean held-out minor-loop RMS (Euclidean), % of each level's range"
                     if any(r["held_out"] for r in fits[best][0].levels)
                     else "mean held-out RMS, % of the output range")
        else:
            best, basis = tried[0], "nothing held out"
        fit, thetas = fits[best]
        notes = fit.notes
        notes.insert(0, f"generalized PI: {self.n_plays} plays per component, envelopes by "
                        f"variable projection ({evaluations[best][0]} residual evaluations, "
                        f"{evaluations[best][1]} analytic Jacobians), thresholds "
                        f"{_SPACING_LABEL[best]}")
        demag = [f"{a:.4g} V" + (f" around {c:.4g} V" if c else "")
                 for a, c in self._demagnetised if a]
        notes.insert(1, "generalized PI: every record taken as starting after the "
                        f"demagnetising cycle (demagnetise.csv) from {', '.join(demag)} "
                        f"; the model starts there (--record-start rest would take the "
                        f"plays at rest instead)"
                     if self.record_start == "demagnetised" and demag else
                     "generalized PI: every record starts from the plays at rest")
        if n_cut:
            notes.insert(2, f"generalized PI: fitted on the amplitude levels of {n_cut} record"
                            f"{'s' if n_cut != 1 else ''}, not the reversal curves after them")
        if len(tried) > 1:
            notes.insert(0, "threshold spacing auto: chose " + best + " (" + ", ".join(
                f"{sp} {scores[sp]:.3g} %" if scores[sp] is not None else f"{sp} -"
                for sp in tried) + f"; {basis})")
        fit.partition = best
        fit.partition_scores = {sp: v for sp, v in scores.items() if v is not None}
        self.model_, self.envelope_parameters_ = fit.model, thetas
        self.structure_, self.notes_, self.fit_ = fit.structure, notes, fit
        self.threshold_spacing_ = best
        self.spacing_scores_ = dict(scores)
        del self._u, self._y, self._w, self._train, self._poly_cache, self._buffers
        return self

    def _fit_spacing(self, spacing, records, splits, kinds, auto, in_names, out_names, held):
        """The whole fit with one threshold spacing: ((RecordFit, thetas), (residuals, Jacobians))."""
        self._spacing = spacing
        self._buffers = {}          # the columns held were for the previous spacing's thresholds
        self._evaluations = self._jacobians = 0
        p = len(kinds)

        def fit_all():
            grid, offs, thetas = [], [], []
            for l in range(p):
                comps, off, th = self._fit_output(l, kinds[l])
                grid.append(comps)
                offs.append(off)
                thetas.append(th)
            model = self._model(grid, offs, in_names, out_names, self._amp)
            return model, thetas, [model.simulate(r.u)[0] for r in records]

        model, thetas, pred = fit_all()

        def contribution(c, u):               # without its offset: what varies with the input
            if isinstance(c, GeneralizedPI):
                return c.replace(offset=0.0).simulate(u)[0]
            return c * u

        # drop the cross-couplings the held-out samples do not support
        absent, notes = weak_couplings(records, auto, model.components, contribution,
                                       in_names, out_names, splits, pred)
        for l, k in absent:
            kinds[l][k] = "none"
        if absent:
            model, thetas, pred = fit_all()
        train = _window_metrics(records, splits, pred, "train")
        val = _window_metrics(records, splits, pred, "held_out") if held else None
        structure = [["generalized" if isinstance(c, GeneralizedPI) else
                      ("gain" if c is not None else "none")
                      for c in row] for row in model.components]
        score = float(np.mean([w["rms_percent"] for w in (val or train)]))
        fit = RecordFit(model, "generalized-pi", spacing, {spacing: score}, structure,
                        notes, records, splits, train, val, pred, "none")
        fit.levels = level_errors(fit)
        return (fit, thetas), (self._evaluations, self._jacobians)


def _spacing_score(fit_thetas):
    """Held-out error of one spacing's fit [%]: minor loops, else windows, else None."""
    fit = fit_thetas[0]
    loops = fit.minor_loop_error
    if loops is not None:
        return loops
    if fit.validation:
        return float(np.mean([w["rms_percent"] for w in fit.validation]))
    return None


def identify_gpi_records(records, n_plays=16, components="auto", hold_out="auto",
                         train_fraction=None, skip_seconds=None, input_names=None,
                         output_names=None, threshold_spacing="uniform",
                         level_weighting="amplitude", record_start="demagnetised"):
    """Identify a multivariable generalised PI model; a :class:`RecordFit` like the PI's.

    Parameters
    ----------
    records : MultiRecord, Record or sequence of them
        Inputs shape (m, n_samples) [V], outputs shape (p, n_samples) [µm].
    n_plays, components, threshold_spacing, level_weighting, record_start
        See :class:`GeneralizedPIIdentifier`.
    hold_out, train_fraction, skip_seconds
        See :func:`hammerstein.identification.record_identification.split_record`.
    input_names, output_names : sequence of str, optional
        Names in the model.

    Returns
    -------
    RecordFit
        ``method = "generalized-pi"``, ``model`` a
        :class:`~hammerstein.models.preisach.MultivariableHysteresis`.

    Raises
    ------
    IdentificationError
        See :meth:`GeneralizedPIIdentifier.fit`.
    """
    est = GeneralizedPIIdentifier(n_plays, components, threshold_spacing=threshold_spacing,
                                  level_weighting=level_weighting,
                                  record_start=record_start).fit(
        records, None, input_names, output_names, hold_out, train_fraction, skip_seconds)
    return est.fit_
