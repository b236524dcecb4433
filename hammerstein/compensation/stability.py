"""Convergence of the inverse multiplicative compensator against gain scaling.

The normalised law ``U(t) = U(t-T) + (s K)^-1 (Yr(t) - Gamma(U(t-T)))``
converges when ``rho(I - (s K)^-1 J) < 1`` for every reachable slope matrix
J of the model (docs/compensator.md). With K the diagonal secant gains of the direct
transfers, ``s = 1`` is the normalised law; the paper's literal law (K = I)
sits at ``s_l = 1/K_ll`` on each axis, summarised by
:func:`literal_gain_equivalent_scale`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from hammerstein.compensation.compensators import CompensatorError, convergence_report
from hammerstein.models.hysteresis import MultivariablePI

__all__ = ["stability_map", "literal_gain_equivalent_scale"]


def _secant_diag(model):
    if not isinstance(model, MultivariablePI) and isinstance(getattr(model, "model", None), MultivariablePI):
        model = model.model  # a compensator: analyse the model it was built on
    if not isinstance(model, MultivariablePI):
        raise CompensatorError(f"model: expected a MultivariablePI, found {type(model).__name__}")
    if model.n_inputs != model.n_outputs:
        raise CompensatorError(
            f"model: expected a square model, found {model.n_outputs} outputs and {model.n_inputs} inputs")
    if model.input_amplitude is None:
        raise CompensatorError("model: input_amplitude: needed for the secant gains K")
    return np.diag(np.diag(model.secant_gains()))


def literal_gain_equivalent_scale(model: MultivariablePI) -> float:
    """Scale s of the secant gain at which ``s K`` best stands for K = I.

    The literal law of Theorem 4.1 uses K = I; with the diagonal secant gain
    K it corresponds to ``s_l = 1/K_ll`` per axis. The single scale returned
    is their geometric mean, ``(prod_l K_ll)^(-1/m)``, exact when the axes'
    secant gains are equal (preset: about 0.184, i.e. the literal law
    under-normalises by a factor of about 5.4).

    Parameters
    ----------
    model : MultivariablePI
        Square model with ``input_amplitude``.

    Returns
    -------
    float
        Scale s [-] (K in µm/V, so ``s K`` is I in µm/V).

    Raises
    ------
    CompensatorError
        If the model is not square, has no ``input_amplitude`` or a
        non-positive direct secant gain.
    """
    k = np.diag(_secant_diag(model))
    if np.any(k <= 0):
        raise CompensatorError(f"model: direct secant gains must be > 0 µm/V, found {k.tolist()}")
    return float(np.exp(-np.mean(np.log(k))))


def stability_map(model: MultivariablePI, gain_scales) -> pd.DataFrame:
    """Spectral radius of the compensator iteration against a gain scaling.

    For each scale s, :func:`~hammerstein.compensation.compensators.convergence_report`
    with the gain ``s K`` (K the diagonal secant gains of the direct
    transfers over ``model.input_amplitude``, docs/compensator.md) gives the largest
    and smallest ``rho(I - (s K)^-1 J)`` over the reachable slope matrices
    (dead band excluded).

    Parameters
    ----------
    model : MultivariablePI or compensator
        Identified square model with ``input_amplitude``, or a compensator
        built on one (e.g. :func:`~hammerstein.compensation.compensators.diagonal_compensator`:
        its direct-transfer-only model is analysed).
    gain_scales : array_like, shape (n_scales,)
        Scales s > 0 [-]; s = 1 is the normalised law.

    Returns
    -------
    pandas.DataFrame
        One row per scale: ``scale``, ``max_radius``, ``min_radius``,
        ``converges`` (max_radius < 1), and ``K_<output>`` the scaled
        diagonal gains [µm/V]. ``attrs`` holds ``literal_scale``
        (:func:`literal_gain_equivalent_scale`), ``literal_max_radius`` and
        ``literal_min_radius`` (K = I exactly), and ``normalised_max_radius``
        (s = 1).

    Raises
    ------
    CompensatorError
        If the model is not square or has no ``input_amplitude``, or a scale
        is not a positive finite number.
    """
    K = _secant_diag(model)
    model = getattr(model, "model", model)
    s = np.atleast_1d(np.asarray(gain_scales, dtype=float))
    if s.ndim != 1 or s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise CompensatorError(f"gain_scales: expected positive finite numbers, found {np.asarray(gain_scales).tolist()}")
    rows = []
    for scale in s:
        rep = convergence_report(model, scale * K)
        row = {"scale": scale, "max_radius": rep.max_radius, "min_radius": rep.min_radius,
               "converges": rep.converges}
        row.update({f"K_{name}": scale * K[l, l] for l, name in enumerate(model.output_names)})
        rows.append(row)
    df = pd.DataFrame(rows)
    literal = convergence_report(model, "identity")
    df.attrs.update(literal_scale=literal_gain_equivalent_scale(model),
                    literal_max_radius=literal.max_radius, literal_min_radius=literal.min_radius,
                    normalised_max_radius=convergence_report(model, K).max_radius)
    return df
