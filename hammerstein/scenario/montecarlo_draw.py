"""Monte-Carlo studies: the drawn plants.

Each varied quantity is multiplied by a factor of mean 1 (:func:`draw_factors`,
distributions in :mod:`hammerstein.scenario.montecarlo`); :func:`case_plant`
builds case i's plant of the nominal plant's class from them, scaling each
class's hysteron weights (classical and generalised PI play weights, Preisach
hysteron weights) and re-sampling the bending modes in closed form
(:func:`sampled_modes`). Re-exported by :mod:`hammerstein.scenario.montecarlo`.
"""

from __future__ import annotations

import math

import numpy as np

from hammerstein.models.dynamics import SampledSystem
from hammerstein.models.generalized_pi import GeneralizedPI
from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
from hammerstein.models.plant import HammersteinPlant
from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel

__all__ = ["draw_factors", "case_plant", "sampled_modes", "oscillating_modes", "scaled_modes",
           "MIN_FACTOR", "MAX_MODAL_DAMPING"]

#: Smallest factor of a natural frequency or damping ratio.
MIN_FACTOR = 0.05
#: Largest damping ratio a varied mode of state-space dynamics takes (it stays a complex pair).
MAX_MODAL_DAMPING = 0.99


def _factor(z, spec, positive=False):
    """Factors of mean 1 and relative sd ``spec['relative_sd']`` from standard normals ``z``."""
    s, dist = spec["relative_sd"], spec.get("distribution", "normal")
    if dist == "normal":
        f = 1.0 + s * z
    elif dist == "uniform":
        from scipy.special import ndtr   # scipy is loaded lazily by the project
        f = 1.0 + s * math.sqrt(3.0) * (2.0 * ndtr(z) - 1.0)
    else:
        sigma = math.sqrt(math.log1p(s * s))
        f = np.exp(sigma * z - 0.5 * sigma * sigma)
    return np.maximum(f, MIN_FACTOR) if positive else f


def draw_factors(study, i):
    """The multiplicative factors of case ``i`` (depend only on ``(seed, i)`` and the study).

    Parameters
    ----------
    study : MonteCarloStudy
    i : int
        Case index, ``0 <= i < study.cases``.

    Returns
    -------
    dict
        ``weights`` (one array per component ``(l, k)`` of its hysteron
        weights' factors: a classical PI's or a generalised PI's play
        weights, a Preisach model's hysteron weights mu_ij in the order of
        its state; empty for a gain or a polynomial), ``cross_coupling``
        ((p, m) array, 1 on the diagonal), ``natural_frequency`` and
        ``damping_ratio`` (one per mode of ``study.modes``: p bending modes,
        or the oscillating modes of state-space dynamics); 1 where the
        quantity is not varied.
    """
    model = study.plant.hysteresis
    p, m = model.n_outputs, model.n_inputs
    rng = np.random.default_rng([study.seed, i])
    comps = [(l, k, c) for l, row in enumerate(model.components) for k, c in enumerate(row)]
    sizes = [_n_weights(c) for _, _, c in comps]
    z_w = rng.standard_normal(sum(sizes))
    z_c = rng.standard_normal(p * m).reshape(p, m)
    n_modes = p if study.modes is None else len(study.modes[0])
    z_f = rng.standard_normal(n_modes)
    z_d = rng.standard_normal(n_modes)
    v = study.vary
    fw = _factor(z_w, v["weights"]) if "weights" in v else np.ones_like(z_w)
    cut = np.cumsum([0] + sizes)
    weights = {(l, k): fw[cut[j]:cut[j + 1]] for j, (l, k, _) in enumerate(comps)}
    fc = _factor(z_c, v["cross_coupling"]) if "cross_coupling" in v else np.ones((p, m))
    if p == m:
        np.fill_diagonal(fc, 1.0)
    return {"weights": weights, "cross_coupling": fc,
            "natural_frequency": _factor(z_f, v["natural_frequency"], True)
            if "natural_frequency" in v else np.ones(n_modes),
            "damping_ratio": _factor(z_d, v["damping_ratio"], True)
            if "damping_ratio" in v else np.ones(n_modes)}


def case_plant(study, i):
    """The plant of case ``i``: the nominal plant with the factors of :func:`draw_factors`.

    Parameters
    ----------
    study : MonteCarloStudy
    i : int

    Returns
    -------
    HammersteinPlant
        Of the nominal plant's class. The hysteron weights w of component
        (l, k) become ``w * f_weights * f_cross[l, k]`` (a classical or
        generalised PI's play weights, a Preisach model's mu_ij: a factor
        below 0 is taken as 0 for an unsigned Preisach model, whose weights
        must stay non-negative); a component's reversible polynomial and a
        linear gain component are scaled by ``f_cross[l, k]``; a generalised
        PI's or Preisach model's offset moves so that the component rests
        where the nominal one does (its plays and relays rest away from 0).
        The bending modes' natural frequencies and damping ratios
        are scaled by their factors and re-sampled (zero-order hold,
        :func:`sampled_modes`; the nominal sampled modes when neither is
        varied); state-space dynamics get the factors mode by mode
        (:func:`scaled_modes`); creep and units (``units``, the preset's
        ``input_unit`` and ``output_unit``) are the nominal ones.
    """
    nominal = study.plant
    model = nominal.hysteresis
    f = draw_factors(study, i)
    rows = [[_scaled(c, f["weights"][(l, k)], f["cross_coupling"][l, k]) for k, c in enumerate(row)]
            for l, row in enumerate(model.components)]
    if isinstance(model, MultivariablePI):
        hyst = model.replace(components=rows)     # its names, range, offset, map and start
    else:
        hyst = MultivariableHysteresis(rows, input_names=model.input_names,
                                       output_names=model.output_names,
                                       input_amplitude=model.input_amplitude)
    lin = nominal.sampled_dynamics
    if (study.modes is not None and nominal.sampled_dynamics is not None
            and ("natural_frequency" in study.vary or "damping_ratio" in study.vary)):
        fn, zeta = study.modes
        if study.modal:        # state-space dynamics: mode by mode
            lin = scaled_modes(lin, f["natural_frequency"], f["damping_ratio"])
        else:
            lin = sampled_modes(fn * f["natural_frequency"], zeta * f["damping_ratio"],
                                nominal.sampling_period, lin)
    plant = HammersteinPlant(hyst, nominal.sampling_period, lin, name=f"{nominal.name}-case{i}",
                             creep=nominal.creep)
    plant.units = nominal.units      # what its inputs take and its outputs give, the nominal's
    return plant


def _n_weights(c):
    """Number of hysteron weights of a component that ``weights`` varies."""
    if isinstance(c, (PrandtlIshlinskii, GeneralizedPI)):
        return len(c.weights)
    if isinstance(c, PreisachModel):
        return c.n_states
    return 0


def _scaled(c, fw, g):
    """Component ``c`` with its hysteron weights times ``fw * g``, the rest of it times ``g``."""
    if c is None:
        return None
    if isinstance(c, PrandtlIshlinskii):
        return PrandtlIshlinskii(c.thresholds, np.asarray(c.weights) * fw * g)
    if isinstance(c, GeneralizedPI):
        return _same_rest(c, c.replace(weights=c.weights * fw * g, reversible=c.reversible * g))
    if isinstance(c, PreisachModel):
        rows, cols = np.tril_indices(c.n_levels)
        factor = fw * g if c.signed else np.maximum(fw * g, 0.0)
        w = np.zeros_like(c.weights)
        w[rows, cols] = c.weights[rows, cols] * factor
        return _same_rest(c, c.replace(weights=w, reversible=c.reversible * g))
    if isinstance(c, Polynomial):
        return Polynomial(c.coefficients * g, offset=c.offset)
    return float(c) * g


def _same_rest(nominal, drawn):
    """``drawn`` with its offset moved so that it rests where ``nominal`` does.

    A generalised PI's plays rest at their envelopes' values at 0 V (tens of volts), which
    its offset cancels; a Preisach model's relays rest at +-1. Scaling the weights alone
    moved the rest output by the factor times that sum (0.5 µm for 1 % on an identified
    generalised PI, whose offset was 47.65 µm): a gain drawn became a position offset. The
    weights vary the response about the rest position, as a classical PI's plays, which
    rest at 0, do.
    """
    y0, _ = nominal.simulate(np.zeros(1))
    y1, _ = drawn.simulate(np.zeros(1))
    return drawn.replace(offset=drawn.offset + float(y0[0] - y1[0]))


def sampled_modes(natural_frequency, damping_ratio, sampling_period, nominal):
    """Zero-order hold of decoupled second-order bending modes, in closed form.

    The same system as
    :func:`hammerstein.models.dynamics.sampled_bending_modes` (states: position
    and velocity / omega_n of each mode, ``dx/dt = A x + B u`` with the block
    ``A = [[0, w], [-w, -2 zeta w]]``, ``B = [0, w]^T``), without a matrix
    exponential: with ``s = zeta w``, ``q = w^2 (1 - zeta^2)``, ``c = cos(sqrt(q) T)``
    and ``S = sin(sqrt(q) T) / sqrt(q)`` (``cosh``/``sinh`` of ``sqrt(-q) T``
    for an overdamped mode, ``c = 1``, ``S = T`` for a critically damped one),
    ``exp(A T) = exp(-s T) (c I + S (A + s I))`` (Cayley-Hamilton: ``(A + s
    I)^2 = -q I``) and ``B_d = int_0^T exp(A t) dt B = [1 - exp(-s T) (c + s
    S), w exp(-s T) S]^T`` (the unit-step response; e.g. Franklin, Powell &
    Workman, *Digital Control of Dynamic Systems*, Sec. 4.3.3). It agrees
    with the Pade-based ``scipy.linalg.expm`` of the ZOH definition within a
    few 1e-16 of the matrices' norm, uses no BLAS (no thread pool, whatever
    ``OPENBLAS_NUM_THREADS``) and takes a few microseconds per mode.

    Parameters
    ----------
    natural_frequency : numpy.ndarray, shape (p,)
        [Hz], > 0.
    damping_ratio : numpy.ndarray, shape (p,)
        > 0 (above 1: an overdamped mode).
    sampling_period : float
        T [s], > 0.
    nominal : SampledSystem
        The nominal sampled modes (gives C, D, the names and the sampling
        period).

    Returns
    -------
    SampledSystem
        A_d, shape (2p, 2p), block diagonal; B_d, shape (2p, p); C, D of
        ``nominal``.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.models.dynamics import sampled_bending_modes
    >>> from hammerstein.scenario.montecarlo import sampled_modes
    >>> ref = sampled_bending_modes([900.0, 1100.0], [0.05, 0.2], ["x", "y"], 1e-4)
    >>> got = sampled_modes(np.array([900.0, 1100.0]), np.array([0.05, 0.2]), 1e-4, ref)
    >>> bool(np.abs(got.A - ref.A).max() < 1e-15 and np.abs(got.B - ref.B).max() < 1e-15)
    True
    """
    T = float(sampling_period)
    p = len(natural_frequency)
    A, B = np.zeros((2 * p, 2 * p)), np.zeros((2 * p, p))
    for l in range(p):
        w = 2.0 * math.pi * float(natural_frequency[l])
        z = float(damping_ratio[l])
        sig = z * w
        q = w * w * (1.0 - z * z)
        if q > 0.0:
            wd = math.sqrt(q)
            c, S = math.cos(wd * T), math.sin(wd * T) / wd
        elif q < 0.0:
            g = math.sqrt(-q)
            c, S = math.cosh(g * T), math.sinh(g * T) / g
        else:
            c, S = 1.0, T
        e = math.exp(-sig * T)
        i = 2 * l
        A[i, i], A[i, i + 1] = e * (c + sig * S), e * w * S
        A[i + 1, i], A[i + 1, i + 1] = -e * w * S, e * (c - sig * S)
        B[i, l], B[i + 1, l] = 1.0 - e * (c + sig * S), w * e * S
    return SampledSystem(A, B, nominal.C, nominal.D, nominal.dt, inputs=nominal.inputs,
                         outputs=nominal.outputs, states=nominal.states, name=nominal.name)


def _modal_split(system):
    """Eigenvalues, eigenvectors and their inverse of ``system.A``, and the continuous poles."""
    z, V = np.linalg.eig(np.asarray(system.A, dtype=float))
    lam = np.log(z.astype(complex)) / float(system.dt)
    return z, V, np.linalg.inv(V), lam


def _pairs(z, lam):
    """Indices of the oscillating poles (Im z > 0), by natural frequency."""
    idx = [i for i in range(len(z)) if z[i].imag > 1e-12 * max(abs(z[i]), 1e-300)]
    return sorted(idx, key=lambda i: abs(lam[i]))


def oscillating_modes(system):
    """Natural frequencies and damping ratios of a sampled system's oscillating modes.

    Parameters
    ----------
    system : hammerstein.models.dynamics.SampledSystem
        Sampled linear dynamics (sampling period ``dt`` [s]).

    Returns
    -------
    natural_frequency : numpy.ndarray, shape (n_modes,)
        [Hz], increasing; from each complex pole pair z of ``A``,
        ``lambda = ln(z) / dt``, ``f = |lambda| / (2 pi)``.
    damping_ratio : numpy.ndarray, shape (n_modes,)
        ``-Re(lambda) / |lambda|``.
    """
    z, _, _, lam = _modal_split(system)
    idx = _pairs(z, lam)
    return (np.array([abs(lam[i]) / (2 * math.pi) for i in idx]),
            np.array([-lam[i].real / abs(lam[i]) for i in idx]))


def scaled_modes(system, frequency_factors, damping_factors):
    """Sampled dynamics whose oscillating modes have scaled frequencies and damping ratios.

    Each complex pole pair z of ``A`` (mode ``n`` in the order of
    :func:`oscillating_modes`) moves to ``exp(lambda' dt)`` with
    ``|lambda'| = f_n |lambda|`` and damping ratio ``min(d_n zeta,``
    :data:`MAX_MODAL_DAMPING` ``)``, in the eigenbasis of ``A``
    (``A' = V diag(z') V^-1``). Its input direction is that of the
    continuous mode (``b_c = b lambda / (z - 1)``, the inverse of the
    zero-order hold) times ``kappa = |lambda'|^2 Im(lambda) / (|lambda|^2
    Im(lambda'))``, held again: ``b' = kappa b (lambda / (z - 1)) ((z' - 1) /
    lambda')``. A mode whose continuous numerator is constant (a bending
    mode, ``omega^2 / (s^2 + 2 zeta omega s + omega^2)``) becomes exactly
    the zero-order hold of the mode with the new frequency and damping, its
    static gain kept (as :func:`sampled_modes`); a mode with an ``s`` term
    in its numerator keeps its static gain when only its frequency is
    scaled. Real poles (creep, sensor lags) are kept.

    Parameters
    ----------
    system : hammerstein.models.dynamics.SampledSystem
        With ``A`` diagonalisable (distinct poles).
    frequency_factors, damping_factors : array_like, shape (n_modes,)
        Positive factors per oscillating mode.

    Returns
    -------
    hammerstein.models.dynamics.SampledSystem
        Same C, D, names and sampling period.

    Examples
    --------
    >>> import numpy as np
    >>> from hammerstein.models.dynamics import sampled_bending_modes
    >>> from hammerstein.scenario.montecarlo_draw import oscillating_modes, scaled_modes
    >>> sys = sampled_bending_modes([900.0, 1100.0], [0.05, 0.2], ["x", "y"], 1e-4)
    >>> fn, zeta = oscillating_modes(scaled_modes(sys, [1.1, 1.0], [1.0, 2.0]))
    >>> np.round(fn, 6), np.round(zeta, 6)
    (array([ 990., 1100.]), array([0.05, 0.4 ]))
    """
    z, V, W, lam = _modal_split(system)
    idx = _pairs(z, lam)
    ff = np.asarray(frequency_factors, dtype=float)
    fd = np.asarray(damping_factors, dtype=float)
    z_new, gain = z.astype(complex).copy(), np.ones(len(z), dtype=complex)
    for n, i in enumerate(idx):
        w = abs(lam[i]) * ff[n]
        zeta = min(-lam[i].real / abs(lam[i]) * fd[n], MAX_MODAL_DAMPING)
        new = complex(-zeta * w, w * math.sqrt(1.0 - zeta * zeta))
        j = int(np.argmin(np.abs(z - np.conj(z[i]))))      # its conjugate
        kappa = abs(new) ** 2 / abs(lam[i]) ** 2 * lam[i].imag / new.imag
        for k, pole in ((i, new), (j, new.conjugate())):
            z_new[k] = np.exp(pole * float(system.dt))
            # continuous residue times kappa, between the zero-order holds of the old and new pole
            gain[k] = kappa * lam[k] / (z[k] - 1.0) * (z_new[k] - 1.0) / pole
    A = (V * z_new) @ W
    B = (V * gain) @ (W @ np.asarray(system.B, dtype=float))
    return SampledSystem(np.ascontiguousarray(A.real), np.ascontiguousarray(B.real), system.C,
                         system.D, system.dt, inputs=system.inputs, outputs=system.outputs,
                         states=system.states, name=system.name)
