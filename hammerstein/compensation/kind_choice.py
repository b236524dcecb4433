"""The compensator kind chosen for a model, and the gain of the inverse multiplicative law.

The default kind (:func:`choose_kind`): the Hammerstein compensator where
dynamics were identified (G inverted, then the static part); without
dynamics the exact inverse where the class has one (Preisach, generalised
PI); otherwise the inverse multiplicative law of Theorem 4.1 with the gain
whose convergence radius ``rho(I - K^-1 J)`` is smallest among the
candidates of :data:`GAIN_CANDIDATES` (docs/compensator.md), and the
per-axis analytic inverse when none of them converges. The law's gain and
check are one decision (:func:`law_check`) that ``compensate``, ``learn``
and ``export`` share, also for a kind the user named (:func:`explicit_law`).
What each class supports is the registry's,
:mod:`hammerstein.compensation.model_classes`.
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from hammerstein.compensation.compensators import convergence_report, midpoint_gains
from hammerstein.compensation.mixed_compensators import loop_slopes, mixed_gain
from hammerstein.compensation.model_classes import model_class, square_problem
from hammerstein.exceptions import CompensatorDivergence, CompensatorError
from hammerstein.models.hysteresis import MultivariablePI

__all__ = ["KindChoice", "GAIN_CANDIDATES", "KIND_GAINS", "SELF_TEST_SAMPLES", "LawCheck",
           "law_radius", "convergent_gain", "law_self_test", "law_check", "choose_kind",
           "explicit_law"]

#: Samples of the test reference :func:`law_self_test` runs the law over (each input a
#: raised cosine over [0, A], 2, 3, ... periods: the model's own outputs, reachable)
SELF_TEST_SAMPLES = 4000

#: Gains of the inverse multiplicative law tried by :func:`convergent_gain`, in order of
#: preference at equal radius: the per-axis midpoint of the slopes (the optimal scalar
#: relaxation), the direct secant gains, then the midpoint scaled up (a smaller step: the
#: radius of ``I - K^-1 J`` shrinks where coupled slopes push it past 1).
GAIN_CANDIDATES = ("midpoint", "secant", 1.25, 1.5, 2.0)

#: The gain each kind runs the law with when built without one (the scenario tables'
#: default): what :func:`explicit_law` replaces when it does not converge.
KIND_GAINS = {"multivariable": "secant", "hammerstein": "midpoint"}


def law_radius(model, gain):
    """Largest ``rho(I - K^-1 J)`` of the inverse multiplicative law over the model's slopes.

    For a classical PI, over every reachable slope matrix
    (:func:`hammerstein.compensation.compensators.convergence_report`); for another
    class, over the corners of the slope intervals along the major loops
    (:func:`hammerstein.compensation.mixed_compensators.loop_slopes`). The law
    converges where the radius is below 1 (docs/compensator.md).

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Square, with ``input_amplitude``.
    gain : str, float or array_like
        ``'secant'``, ``'midpoint'``, ``'identity'``, a matrix [µm/V], or a
        number c: c times the midpoint gains.

    Returns
    -------
    float
        [-]; ``inf`` when the gain cannot be formed (e.g. a non-positive slope).

    Raises
    ------
    CompensatorError
        A model that is not square (:func:`square_problem`).
    """
    square = square_problem(model)
    if square:
        raise CompensatorError(square)
    try:
        K = _gain_matrix(model, gain)
        if isinstance(model, MultivariablePI):
            return float(convergence_report(model, K).max_radius)
        lo, hi = loop_slopes(model)
    except CompensatorError:
        return float("inf")
    m = model.n_inputs
    Kinv = np.linalg.inv(K)
    worst = 0.0
    for corner in itertools.product((0, 1), repeat=m * m):
        J = np.where(np.reshape(corner, (m, m)) == 0, lo, hi)
        worst = max(worst, float(np.max(np.abs(np.linalg.eigvals(np.eye(m) - Kinv @ J)))))
    return worst


def _gain_matrix(model, gain):
    """K (m, m) [µm/V] of a gain name, matrix or midpoint scale."""
    if isinstance(gain, (int, float)) and not isinstance(gain, bool):
        mid = (np.diag(midpoint_gains(model)) if isinstance(model, MultivariablePI)
               else mixed_gain(model, "midpoint"))
        return float(gain) * mid
    if isinstance(model, MultivariablePI):
        if isinstance(gain, str):
            if gain == "secant":
                return np.diag(np.diag(model.secant_gains()))
            if gain == "midpoint":
                return np.diag(midpoint_gains(model))
            if gain == "identity":
                return np.eye(model.n_inputs)
            raise CompensatorError(f"gain: expected 'secant', 'midpoint', 'identity' or a "
                                   f"matrix, found {gain!r}")
        return np.asarray(gain, dtype=float)
    return mixed_gain(model, gain)


def convergent_gain(model, candidates=GAIN_CANDIDATES):
    """The gain of the inverse multiplicative law with the smallest convergence radius.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Square, with ``input_amplitude``.
    candidates : sequence
        Gains as :func:`law_radius` takes them; a number c stands for c times
        the midpoint gains. The first candidate whose radius is below 1 and
        within 5 % of the smallest wins (the named gains before the scaled
        ones).

    Returns
    -------
    gain : str or numpy.ndarray
        A gain name, or the matrix K (m, m) [µm/V] of a scaled midpoint.
    radius : float
        Its ``rho(I - K^-1 J)``; >= 1 when no candidate converges.
    radii : dict
        Radius of each candidate (keys as given).
    """
    radii = {c: law_radius(model, c) for c in candidates}
    best = min(radii.values())
    for c, r in radii.items():
        if r < 1.0 and r <= best * 1.05:
            gain = c if isinstance(c, str) else _gain_matrix(model, c)
            return gain, r, radii
    c = min(radii, key=radii.get)
    return (c if isinstance(c, str) else _gain_matrix(model, c)), radii[c], radii


@dataclass
class KindChoice:
    """The compensator kind chosen for a model, with its options and the reason.

    Parameters
    ----------
    kind : str
        A compensator kind.
    options : dict
        Options of the kind (e.g. ``gain``: name or matrix K [µm/V]).
    reason : str
        Why, one line (``note: kind = <kind> because <reason>``).
    """

    kind: str
    options: dict
    reason: str

    def note(self):
        """The one-line note the commands print on stderr.

        Returns
        -------
        str
            ``note: kind = <kind> because <reason>``.
        """
        return f"note: kind = {self.kind} because {self.reason}"


def _gain_name(gain, units=("V", "µm")):
    """A named gain as is, a matrix as ``K = [...] µm/V (scaled midpoint)``: K in the
    model's (input, output) ``units``."""
    return gain if isinstance(gain, str) else "K = [" + ", ".join(
        f"{v:.4g}" for v in np.diag(gain)) + f"] {units[1]}/{units[0]} (scaled midpoint)"


def _gain_words(gain, radius, units=("V", "µm")):
    """``gain K = [...] µm/V (scaled midpoint), rho(...) 0.9 < 1``."""
    return f"gain {_gain_name(gain, units)}, rho(I - K^-1 J) {radius:.3g} < 1"


def law_self_test(model, gain):
    """Whether the inverse multiplicative law follows the model's own outputs, or why not.

    The radius ``rho(I - K^-1 J)`` over the corners of the slopes is a
    sufficient condition; a law beyond it may still follow (a 3-input
    piston stage at 1.75) or run away within a few hundred samples (a
    tip-tilt-piston platform at 5.5). The test: each input k a raised cosine
    over ``[0, A_k]`` (``input_amplitude``), k + 2 periods over
    :data:`SELF_TEST_SAMPLES` samples; the law (``check = 'ignore'``) on the
    model's outputs for it, a reference the model reaches by construction;
    the model driven by the law's inputs.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Square, with ``input_amplitude``.
    gain : str or array_like
        As :func:`law_radius`.

    Returns
    -------
    str or None
        None when the law follows (after the first tenth of the samples, no
        output off by more than half its peak-to-peak on more than half the
        samples, the inputs finite and within 10 A); else why, one phrase.
    """
    m = model.n_inputs
    amp = np.asarray(model.input_amplitude, dtype=float)
    n = SELF_TEST_SAMPLES
    t = np.arange(n) / n
    u = np.vstack([0.5 * amp[k] * (1.0 - np.cos(2 * np.pi * (k + 2) * t)) for k in range(m)])
    with warnings.catch_warnings():      # a test of the law: the range's words are the run's
        warnings.simplefilter("ignore")
        return _self_test(model, u, gain)


def _self_test(model, u, gain):
    n = u.shape[1]
    amp = np.asarray(model.input_amplitude, dtype=float)
    y, _ = model.simulate(u)
    try:
        comp = model_class(model).compensator(model, "multivariable", gain=gain, check="ignore")
        with np.errstate(all="ignore"):
            v, _ = comp.simulate(y)
    except CompensatorDivergence as exc:
        return f"the law diverges on the model's own outputs ({' '.join(str(exc).split())})"
    start = n // 10
    v = v[:, start:]
    if not np.all(np.isfinite(v)) or np.any(np.abs(v) > 10 * amp[:, None]):
        far = np.nanmax(np.where(np.isfinite(v), np.abs(v), np.inf) / amp[:, None])
        return (f"the law diverges on the model's own outputs (its inputs reach {far:.3g} times "
                f"the input amplitude)")
    got, _ = model.simulate(np.hstack([u[:, :start], v]))
    err = np.abs(got[:, start:] - y[:, start:])
    half = 0.5 * np.ptp(y[:, start:], axis=1)
    share = np.mean(err > half[:, None], axis=1)
    l = int(np.argmax(share))
    if share[l] > 0.5:
        return (f"the law does not follow the model's own outputs ({model.output_names[l]} off "
                f"by more than half its span on {100 * share[l]:.3g} % of the samples)")
    return None


@dataclass
class LawCheck:
    """The gain and check the inverse multiplicative law runs with (:func:`law_check`).

    Parameters
    ----------
    gain : str or numpy.ndarray
        A gain name or K (m, m) [µm/V].
    radius : float
        Its ``rho(I - K^-1 J)`` [-].
    check : {'error', 'warn', 'ignore'} or None
        The check to run the law with; None: the compensator's default (error).
    reason : str
        Why, one phrase (empty when the law provably converges or the user chose).
    """

    gain: Any
    radius: float
    check: Any
    reason: str = ""


def law_check(model, gain=None, check=None, label=None):
    """The one decision of the law's gain and convergence check the commands share.

    ``compensate``, ``learn`` and ``export`` (and :func:`choose_kind`) call it
    with the user's ``--gain`` and ``--check``, so that they agree. With
    neither given: the gain of :func:`convergent_gain`; when its radius is
    below 1 the default check (error, never triggered); when it is not, the
    law is tried on the model's own outputs (:func:`law_self_test`): it runs
    with ``check = 'warn'`` if it follows them, and is refused if not.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Square, with ``input_amplitude``.
    gain : str or array_like, optional
        The user's gain (then only its radius is measured).
    check : {'error', 'warn', 'ignore'}, optional
        The user's check (then kept).
    label : str, optional
        The model class's name in messages (default its registry label).

    Returns
    -------
    LawCheck

    Raises
    ------
    CompensatorError
        With neither gain nor check given, when no gain makes the law
        provably converge and it does not follow the model's own outputs
        (the message gives the radius and what to try).
    """
    label = label or model_class(model).label
    user = gain is not None
    if gain is None:
        gain, radius, _ = convergent_gain(model)
    else:
        radius = law_radius(model, gain)
    if check is not None or radius < 1.0:
        return LawCheck(gain, radius, check)
    name = gain if isinstance(gain, str) else "a scaled midpoint"
    problem = law_self_test(model, gain)
    # the user's gain: another may converge, and "no gain makes it converge" sent the user
    # to measure and identify again (gain identity at rho 8.96 where midpoint has 0.458)
    best = convergent_gain(model)[1] if user else radius
    if best < 1.0:
        why = (f"gain {name} does not make the {label} law provably converge (rho(I - K^-1 J) "
               f"{radius:.3g}; without --gain the law takes one with {best:.3g})")
        if problem:
            raise CompensatorError(f"{why} and {problem}: leave out --gain, or give --check warn "
                                   f"to run the law anyway")
        return LawCheck(gain, radius, "warn", f"{why}, but it follows the model's own outputs: "
                                              f"it runs without that guarantee, as with --check warn")
    if problem:
        raise CompensatorError(
            f"no gain makes the {label} law converge (smallest rho(I - K^-1 J) {radius:.3g} "
            f"with gain {name}, where < 1 is needed) and {problem}: its outputs mix the inputs "
            f"more than the direct paths carry them (a diagonal gain cannot undo that); measure "
            f"outputs that each input drives most (each stack's own displacement) and identify "
            f"again, or give --check warn to run the law anyway")
    return LawCheck(gain, radius, "warn",
                    f"no gain makes the {label} law provably converge (smallest rho(I - K^-1 J) "
                    f"{radius:.3g}), but it follows the model's own outputs: it runs without that "
                    f"guarantee, as with --check warn")


def choose_kind(model, has_dynamics, gain=None, inversion="zpetc", check=None,
                units=("V", "µm")):
    """The compensator kind that works best for a model when the user names none.

    Rules (module notes): dynamics -> ``hammerstein``; no dynamics and an
    exact inverse -> that kind (``preisach-inverse``); otherwise the
    ``multivariable`` law with :func:`convergent_gain` (or ``gain`` when
    given), and ``per-axis`` when no gain makes it converge. A classical PI
    in the Hammerstein compensator gets the convergent gain too.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
    has_dynamics : bool
        The actuator file carries linear dynamics G.
    gain : str or array_like, optional
        The user's gain (then only checked, not chosen).
    inversion : {'zpetc', 'stable'}
        The inverse of G the command builds (named in the reason).
    check : {'error', 'warn', 'ignore'}, optional
        The user's check (:func:`law_check` decides the default).
    units : tuple of str
        The model's (input, output) units (``HammersteinPlant.units``), in which the reason
        gives a gain K.

    Returns
    -------
    KindChoice

    Raises
    ------
    CompensatorError
        A model that is not square (:func:`square_problem`); with dynamics,
        a classical PI static part and neither gain nor check given, when
        :func:`law_check` refuses the law.
    """
    square = square_problem(model)
    if square:
        raise CompensatorError(square)
    entry = model_class(model)
    by = "the stable inversion" if inversion == "stable" else "ZPETC"
    if has_dynamics:
        if entry.exact_inverse_kind is not None:
            return KindChoice("hammerstein", {},
                              f"the model has dynamics (G inverted by {by}) and its "
                              f"{entry.label} static part an exact inverse")
        law = law_check(model, gain, check, entry.label)
        g, r = law.gain, law.radius
        if r < 1.0:
            return KindChoice("hammerstein", {"gain": g},
                              f"the model has dynamics (G inverted by {by}); static part the "
                              f"multivariable law, {_gain_words(g, r, units)}")
        if gain is not None or check is not None:   # the user's: the law's check decides
            return KindChoice("hammerstein", {"gain": g},
                              f"the model has dynamics (G inverted by {by}); static part the "
                              f"multivariable law with the gain given")
        return KindChoice("hammerstein", {"gain": g, "check": law.check},
                          f"the model has dynamics (G inverted by {by}); {law.reason}")
    if entry.exact_inverse_kind is not None:
        return KindChoice(entry.exact_inverse_kind, {},
                          f"the model has no dynamics and its {entry.label} hysteresis an exact "
                          f"per-sample inverse")
    if gain is None and model.n_inputs == 1 and model.n_outputs == 1 \
            and not getattr(model, "has_output_map", False):
        # one direct transfer, no cross-coupling: its analytic inverse is exact, where the
        # multivariable law lags it by its one-step fixed point (a one-axis stack's 20 Hz
        # sine: 0.14 µm on the model's own prediction, against 1e-14)
        return KindChoice("per-axis", {},
                          "the model has no dynamics and one direct transfer, no cross-coupling: "
                          "its analytic inverse (Kuhnen & Janocha) is exact")
    g, r = (gain, law_radius(model, gain)) if gain is not None else convergent_gain(model)[:2]
    if r < 1.0:
        return KindChoice("multivariable", {"gain": g},
                          f"the model has no dynamics; the multivariable law converges with "
                          f"{_gain_words(g, r, units)}")
    if gain is not None:
        return KindChoice("multivariable", {"gain": g},
                          "the model has no dynamics and no exact inverse: the multivariable law "
                          "with the gain given")
    return KindChoice("per-axis", {},
                      f"the model has no dynamics and no gain makes the multivariable law "
                      f"converge (smallest rho(I - K^-1 J) {r:.3g}): the per-axis analytic "
                      f"inverse")


def explicit_law(model, kind, gain=None, check=None, units=("V", "µm")):
    """The law's gain and check for a kind the user named, and the note that says so.

    ``--kind hammerstein`` (a classical-PI static part) or ``--kind
    multivariable`` without ``--gain`` ran the kind's own default gain (the
    midpoint, or the secant), which need not converge: on an outside stage's
    identified classical PI the midpoint reached ``rho(I - K^-1 J) = 1.17``
    and ``--kind hammerstein`` was refused, while the default kind chose the
    secant gain at 0.904. When the kind's own gain (:data:`KIND_GAINS`) does
    not converge and the user gave no ``--gain``, the gain and check are
    :func:`law_check`'s with the user's check, the decision the default kind
    makes.

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        Square, with ``input_amplitude``.
    kind : str
        The kind the user named.
    gain : str or array_like, optional
        The user's gain (then kept, no note).
    check : {'error', 'warn', 'ignore'}, optional
        The user's check (kept; the gain is still chosen).
    units : tuple of str
        The model's (input, output) units (``HammersteinPlant.units``), in which the note
        gives the gain K.

    Returns
    -------
    options : dict
        ``gain`` and ``check`` to build the kind with (empty: the kind's defaults,
        for a kind without the law, a gain the user gave, or a kind's own gain
        that converges).
    note : str or None
        ``note: kind ... runs the multivariable law with gain ...`` when the
        gain was chosen here.

    Raises
    ------
    CompensatorError
        As :func:`law_check`, when no gain makes the law converge and it does
        not follow the model's own outputs.
    """
    law_kind = kind == "multivariable" or (
        kind == "hammerstein" and model_class(model).exact_inverse_kind is None)
    if not law_kind or gain is not None or square_problem(model):
        return {}, None
    own = KIND_GAINS[kind]
    own_radius = law_radius(model, own)
    if own_radius < 1.0:
        return {}, None                 # the kind's own gain converges: nothing to change
    law = law_check(model, None, check)
    options = {"gain": law.gain}
    if law.check is not None:
        options["check"] = law.check
    if law.radius < 1.0:
        words = f"{_gain_words(law.gain, law.radius, units)}, the convergent gain"
    else:
        words = (f"gain {_gain_name(law.gain, units)}, the smallest rho(I - K^-1 J) of the gains tried, "
                 f"{law.radius:.3g}" + (f" ({law.reason})" if law.reason else ""))
    return options, (f"note: kind {kind} runs the multivariable law with {words}: the kind's "
                     f"{own} gain reaches rho(I - K^-1 J) {own_radius:.3g} (--gain sets another)")
