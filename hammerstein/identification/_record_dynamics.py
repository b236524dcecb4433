"""Linear dynamics and creep behind a fitted hysteresis model, from records.

The private half of :mod:`hammerstein.identification.record_identification`
(which re-exports :func:`identify_record_dynamics`, :class:`RecordDynamics`,
:func:`dynamics_tables`, :func:`identify_record_creep` and
:data:`DYNAMICS_DEFAULTS`): G identified by the subspace method on the model's
outputs, the creep from staircase records after the model and G.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from hammerstein.models import lti
from hammerstein.models.creep import creep_matrices
from hammerstein.identification.creep_identification import CreepIdentifier, hysteresis_frequency
from hammerstein.simulation import linear_steps
from hammerstein.identification.identification import IdentificationError
from hammerstein.identification._record_split import _as_records, _excitation
from hammerstein.identification._broadband_check import broadband_conditions, records_cause

#: Defaults of the dynamics identified from records (:func:`identify_record_dynamics`).
DYNAMICS_DEFAULTS = {"max_order": 10, "unit_dc_gain": True, "low_pole_fraction": 0.5,
                     "cancel_tolerance": 0.01, "require_continuous": True,
                     "lag_tolerance": 3.0}


@dataclass
class RecordDynamics:
    """Linear dynamics G identified from broadband records (:func:`identify_record_dynamics`).

    Parameters
    ----------
    identifier : hammerstein.models.lti.DynamicsIdentifier
        The fitted identifier (``system_`` is the discrete G, G(1) = I by default).
    continuous : control.StateSpace
        G in continuous time (inverse ZOH map), p x p.
    tables : dict
        ``preset`` and ``dynamics`` tables of a preset file.
    summary : dict
        Plain data for the ``[identification.dynamics]`` table: ``order``,
        ``chosen_on`` (the held-out data), ``band_hz``, ``candidates``
        (order, held-out fit [%], kept modes, what was dropped or why the
        order was rejected), ``modes`` (frequency [Hz], damping [-] and the
        share of each axis), ``dc_gain_unconstrained`` (p, p),
        ``dc_gain`` (p, p), ``held_out_fit_percent`` and ``fit_percent``
        per output.
    frf_frequency_hz : numpy.ndarray, shape (n_freq,)
        Frequencies of the measured H1 estimate [Hz].
    frf : numpy.ndarray, shape (p, p, n_freq)
        Measured H1 frequency-response estimate of G (complex) [µm/µm].
    conditions : dict, optional
        Band, amplitude and noise of the broadband records
        (:func:`hammerstein.identification._broadband_check.broadband_conditions`).
    """

    identifier: object
    continuous: object
    tables: dict
    summary: dict
    frf_frequency_hz: np.ndarray = field(repr=False)
    frf: np.ndarray = field(repr=False)
    conditions: dict = field(default=None, repr=False)


def _held_out_records(records):
    """Indices of the last record of each excited input when every input has two or more."""
    by_input = {}
    for i, rec in enumerate(records):
        by_input.setdefault(_excitation(rec), []).append(i)
    m = records[0].u.shape[0]
    if len(by_input) == m and all(len(v) >= 2 for v in by_input.values()):
        return tuple(sorted(v[-1] for v in by_input.values()))
    return ()


def identify_record_dynamics(fit, records, name="identified", creep=None, **options):
    """Identify the linear dynamics G behind a fitted PI from broadband records.

    The Hammerstein structure ``y = G(Gamma(u)) + c`` is identified in two
    steps: ``Gamma`` and ``c`` from the (slow) hysteresis records
    (:func:`identify_records`), then G from broadband records: the PI outputs
    ``H = Gamma(u)`` are the inputs of G and ``y - c`` its outputs
    (:class:`hammerstein.models.lti.DynamicsIdentifier`, subspace method).

    What makes G trustworthy (defaults :data:`DYNAMICS_DEFAULTS`):

    * **unit static gain**: the PI, identified quasi-statically, holds the
      static gain of the actuator, so G is fitted under the constraint
      ``G(0) = I``; the unconstrained G(0) is reported;
    * **order on held-out data**: when every input has two or more
      broadband records, the last record of each input is held out whole and
      the order is chosen on it (else the last 30 % of each record);
    * **no pole outside what the data show**: poles below half the lowest
      excited frequency (estimated from the input spectrum) and modes
      whose largest gain in the band is below 1 % of G's (near pole-zero
      cancellations) are removed and B refitted; unstable orders are rejected,
      and so are orders with a real pole at z <= 0, which has no continuous
      ZOH equivalent for the preset (a mode at or beyond Nyquist, or noise).

    Parameters
    ----------
    fit : RecordFit
        Square p x p model.
    records : sequence of MultiRecord
        Broadband records with the same columns, one sampling period.
    name : str
        Preset name.
    creep : sequence of (Creep or None), optional
        Identified creep per output (:func:`identify_record_creep`): G's
        inputs are then the PI outputs through the creep, ``(I + C) H``
        (each record from rest), so that G(0) = I holds for the cascade the
        compensator inverts. Without it, the part of the creep faster than
        the hysteresis records but slower than the broadband band (a few %)
        would be fitted into G.
    **options
        Options of :class:`~hammerstein.models.lti.DynamicsIdentifier`
        (``order``, ``max_order``...), overriding the defaults.

    Returns
    -------
    RecordDynamics

    Raises
    ------
    IdentificationError
        On a non-square model, no records, differing sampling periods, or a
        failed identification.
    """
    model = fit.model
    if model.n_inputs != model.n_outputs:
        raise IdentificationError(
            f"dynamics: expected a square model (one displacement per PI output), found "
            f"{model.n_outputs} outputs x {model.n_inputs} inputs")
    records = _as_records(records)
    T = records[0].sampling_period
    if any(not np.isclose(r.sampling_period, T, rtol=0.01) for r in records):
        raise IdentificationError("dynamics records: expected one sampling period for all")
    off = np.zeros((model.n_outputs, 1)) if model.output_offset is None \
        else model.output_offset[:, None]
    ins = [model.simulate(r.u)[0] - off for r in records]
    if creep is not None and any(c is not None for c in creep):
        mats = creep_matrices(list(creep), T)
        ins = [linear_steps(h, mats, np.zeros(mats[0].shape[0]))[0] for h in ins]
    outs = [r.y - off for r in records]
    opts = dict(DYNAMICS_DEFAULTS)
    opts["validation_records"] = _held_out_records(records)
    opts.update({k: v for k, v in options.items() if v is not None or k == "order"})
    try:
        ident = lti.DynamicsIdentifier(**opts).fit(ins, outs, T)
        cont = lti.continuous_system(ident.system_)
        frf_f, frf = lti.frf_h1(ins, outs, T)
        in_band = (frf_f >= 0.9 * ident.band_hz_[0]) & (frf_f <= 1.1 * ident.band_hz_[1])
        frf_f, frf = frf_f[in_band], frf[:, :, in_band]
    except (ValueError, np.linalg.LinAlgError) as exc:
        cause = records_cause(broadband_conditions(records, getattr(fit, "records", ())))
        raise IdentificationError(f"dynamics: {exc}" + (f": {cause}" if cause else "")) from None
    held = opts["validation_records"]
    chosen_on = (("held-out records " + ", ".join(records[i].source for i in held)) if held
                 else ident.validation_)
    summary = _dynamics_summary(ident, cont, chosen_on, model.output_names)
    mat = lambda M: [[float(v) for v in row] for row in np.atleast_2d(np.asarray(M))]
    tables = {"preset": {"name": name, "sampling_period": float(T),
                         "description": "PI identified from records + identified linear dynamics"},
              "dynamics": {"kind": "state_space", "A": mat(cont.A), "B": mat(cont.B),
                           "C": mat(cont.C), "D": mat(cont.D)}}
    return RecordDynamics(ident, cont, tables, summary, frf_f, frf,
                          broadband_conditions(records, getattr(fit, "records", ())))


def _dynamics_summary(ident, cont, chosen_on, names):
    """Plain data of an identified G for ``[identification.dynamics]``."""
    p = cont.noutputs
    lam, V = np.linalg.eig(np.asarray(cont.A))
    C = np.asarray(cont.C)
    modes = []
    f_all = np.abs(lam) / (2 * np.pi)
    for i in np.argsort(f_all):
        if lam[i].imag < -1e-9 * max(abs(lam[i]), 1.0):
            continue
        share = np.abs(C @ V[:, i])
        share = share / max(share.sum(), 1e-300)
        modes.append({"frequency_hz": float(f_all[i]),
                      "damping_ratio": float(-lam[i].real / max(abs(lam[i]), 1e-300)),
                      "axis_share": {n: float(v) for n, v in zip(names, share)}})
    cands = []
    for c in ident.candidates_:
        entry = {"order": int(c["order"])}
        if "validation_fit_percent" in c:
            entry["held_out_fit_percent"] = float(c["validation_fit_percent"])
            entry["modes_hz"] = [float(m[0]) for m in c["modes"]]
        if c.get("rejected"):
            entry["rejected"] = str(c["rejected"])
        if c.get("dropped"):
            entry["dropped"] = [str(d) for d in c["dropped"]]
        cands.append(entry)
    pick = np.flatnonzero(np.asarray(ident.orders_) == ident.candidate_order_)
    held_fit = float(ident.validation_fit_[pick[0]]) if pick.size else float("nan")
    return {"order": int(ident.order_), "candidate_order": int(ident.candidate_order_),
            "chosen_on": str(chosen_on),
            "band_hz": [float(v) for v in ident.band_hz_],
            "candidates": cands, "modes": modes,
            "dc_gain_unconstrained": [[float(v) for v in row] for row in ident.dc_gain_unconstrained_],
            "dc_gain": [[float(v) for v in row] for row in lti.dc_gain(cont)],
            "unit_dc_gain": bool(ident.unit_dc_gain),
            "dc_gain_scaled": bool(getattr(ident, "dc_gain_scaled_", False)),
            "dc_gain_step": getattr(ident, "dc_gain_step_", None),
            "held_out_fit_percent": float(held_fit),
            "fit_percent": [float(v) for v in ident.fit_percent_]}


def dynamics_tables(fit, records, name="identified", **options):
    """Identify the linear dynamics behind a fitted PI and return preset tables.

    :func:`identify_record_dynamics` without the report: its ``tables``.

    Parameters
    ----------
    fit : RecordFit
        Square p x p model.
    records : sequence of MultiRecord
        Broadband records with the same columns, one sampling period.
    name : str
        Preset name.
    **options
        Options of :class:`~hammerstein.models.lti.DynamicsIdentifier`.

    Returns
    -------
    dict
        ``{"preset": {...}, "dynamics": {"kind": "state_space", "A", "B",
        "C", "D"}}`` for :func:`hammerstein.io.presets.save_model`.

    Raises
    ------
    IdentificationError
        On a non-square model, no records, differing sampling periods, or a
        failed identification.
    """
    return identify_record_dynamics(fit, records, name, **options).tables


def identify_record_creep(fit, records, dynamics=None, outputs=None, **options):
    """Identify the creep after a fitted hysteresis model from staircase records.

    :class:`hammerstein.identification.creep_identification.CreepIdentifier` on the
    fitted model, normalised at the frequency of the hysteresis records of
    ``fit`` (:func:`hammerstein.identification.creep_identification.hysteresis_frequency`).

    Parameters
    ----------
    fit : RecordFit
        The fitted hysteresis model and its records.
    records : sequence of MultiRecord
        Staircase records with the same columns.
    dynamics : control.StateSpace, optional
        Identified discrete dynamics G (e.g. ``RecordDynamics.identifier.system_``).
    outputs : sequence of array_like, optional
        The model's outputs on the records when already simulated
        (:meth:`~hammerstein.identification.creep_identification.CreepIdentifier.fit`).
    **options
        Options of :class:`~hammerstein.identification.creep_identification.CreepIdentifier`.

    Returns
    -------
    CreepIdentifier
        Fitted.

    Raises
    ------
    IdentificationError
        On records that are not staircases or do not match the model.
    """
    opts = {"hysteresis_frequency_hz": hysteresis_frequency(fit.records)}
    opts.update({k: v for k, v in options.items() if v is not None})
    return CreepIdentifier(**opts).fit(fit.model, _as_records(records), dynamics, outputs)


# -- modified PI: static output map ---------------------------------------------------
