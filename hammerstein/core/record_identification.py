"""Identification of a PI model from a measured record (train / held-out split).

:func:`identify_record` fits a classical PI model on the training part of a
:class:`~hammerstein.core.datafiles.Record` and reports the fit on the
held-out rest. Used by the ``identify`` command and by the ``identification``
scenario kind (both import it from here: core, not cli).
"""

from __future__ import annotations

__all__ = ["identify_record"]


def identify_record(record, method="least-squares", n_hysterons=15, thresholds=None,
                    partition="time", bounds=None, train_fraction=0.7, skip_seconds=None):
    """Identify a classical PI model on the start of a record, validate on the rest.

    Parameters
    ----------
    record : hammerstein.datafiles.Record
    method : {"closed-form", "least-squares"}
    n_hysterons : int
    thresholds : array_like, shape (n,), optional
        Explicit thresholds [V] (override ``n_hysterons`` and ``partition``).
    partition : {"time", "input"}
    bounds : None or "nonnegative"
        Least-squares weight bounds.
    train_fraction : float
        Fraction (0, 1] of the samples used for training.
    skip_seconds : float, optional
        Least-squares burn-in [s]; default: up to the first complete ascending
        branch of the training samples.

    Returns
    -------
    identifier : ClosedFormPI or LeastSquaresPI
        Fitted.
    train : dict
        :func:`~hammerstein.identification.fit_report` on the training
        samples after the virgin curve / burn-in.
    validation : dict or None
        The same on the held-out samples (``None`` if ``train_fraction`` = 1).

    Raises
    ------
    IdentificationError
    """
    from hammerstein.core.identification import IdentificationError, fit_report
    if not 0 < train_fraction <= 1:
        raise IdentificationError(f"train_fraction: expected in (0, 1], found {train_fraction}")
    n_train = int(round(train_fraction * record.n_samples))
    u, y = record.u, record.y
    ut, yt = u[:n_train], y[:n_train]
    partition_arg = thresholds if thresholds is not None else partition
    try:
        ident, start = _fit(record, ut, yt, method, n_hysterons, thresholds, partition_arg,
                            partition, bounds, skip_seconds)
    except IdentificationError as exc:
        raise IdentificationError(
            f"{record.source}: training samples 0..{n_train - 1}: {exc}") from None
    train = fit_report(ident.model_, ut, yt, ident.offset_, start=int(start))
    validation = None
    if n_train < record.n_samples - 1:
        validation = fit_report(ident.model_, u, y, ident.offset_, start=n_train)
    return ident, train, validation


def _fit(record, ut, yt, method, n_hysterons, thresholds, partition_arg, partition, bounds,
         skip_seconds):
    from hammerstein.core.identification import (ClosedFormPI, IdentificationError, LeastSquaresPI,
                                 ascending_branches)
    if method == "closed-form":
        ident = ClosedFormPI(n_hysterons, partition_arg).fit(ut, yt)
        start = ident.branches_[0][0]
    elif method == "least-squares":
        ident = LeastSquaresPI(thresholds=thresholds, n_hysterons=n_hysterons,
                               partition=partition, bounds=bounds)
        if skip_seconds is not None:
            ident.fit(ut, yt, skip_seconds=skip_seconds, sampling_period=record.sampling_period)
            start = int(round(skip_seconds / record.sampling_period))
        else:
            ident.fit(ut, yt, skip="auto")
            start = ascending_branches(ut)[0][0]
    else:
        raise IdentificationError(
            f"method: expected 'closed-form' or 'least-squares', found {method!r}")
    return ident, start
