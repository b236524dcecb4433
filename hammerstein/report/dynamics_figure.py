"""Bode comparison of identified and true linear dynamics G (all p x p entries).

python-control draws it, imported on first use (a run without identified
dynamics does not load it). :func:`state_space_data` and
:func:`dynamics_bode_figure_from_data` carry the systems to a figure worker
process as arrays (``control.StateSpace`` objects do not pickle).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from hammerstein.report.figures import _title_height, fixed_layout, suptitle  # noqa: E402

__all__ = ["dynamics_bode_figure", "dynamics_bode_figure_from_data", "state_space_data"]


def state_space_data(system):
    """A ``control.StateSpace`` as a picklable dict (matrices, sampling period, signal names).

    Parameters
    ----------
    system : control.StateSpace
        n states, m inputs, p outputs.

    Returns
    -------
    dict
        ``A`` (n, n), ``B`` (n, m), ``C`` (p, n), ``D`` (p, m) arrays,
        ``dt`` (None, 0 or the sampling period [s]), ``inputs`` and
        ``outputs`` (names). Not the system's name: python-control numbers
        unnamed systems as they are made, and the figure labels the curves
        itself, so equal systems give equal data (and the renderer draws
        their figure once).
    """
    return {"A": np.asarray(system.A), "B": np.asarray(system.B), "C": np.asarray(system.C),
            "D": np.asarray(system.D), "dt": system.dt, "inputs": list(system.input_labels),
            "outputs": list(system.output_labels)}


def dynamics_bode_figure_from_data(identified, true, **kwargs):
    """:func:`dynamics_bode_figure` of two systems given by :func:`state_space_data`.

    Parameters
    ----------
    identified, true : dict
        From :func:`state_space_data`.
    **kwargs
        Passed to :func:`dynamics_bode_figure`.

    Returns
    -------
    matplotlib.figure.Figure
    """
    import control  # lazy: python-control only for runs with identified dynamics

    systems = [control.ss(d["A"], d["B"], d["C"], d["D"], d["dt"], inputs=d["inputs"],
                          outputs=d["outputs"]) for d in (identified, true)]
    return dynamics_bode_figure(*systems, **kwargs)


def dynamics_bode_figure(identified, true, frequencies_hz=None, labels=("identified", "true"),
                         title="Linear dynamics G: identified vs true"):
    """Bode plot of every entry of two p x p systems, overlaid.

    Uses python-control's frequency-response plotting
    (``control.frequency_response(...).plot()``): one magnitude and one
    phase row per output, one column per input.

    Parameters
    ----------
    identified, true : control.StateSpace
        p x p systems (continuous or discrete).
    frequencies_hz : array_like, shape (n_freq,), optional
        [Hz]; default 300 log-spaced points from 1 Hz to 0.45 / T (5 kHz
        for continuous systems).
    labels : tuple of str
        Legend labels of the two systems.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> from hammerstein.core.dynamics import bending_modes, discretize
    >>> G = discretize(bending_modes([310.0, 290.0], [0.15, 0.2]), 5e-5)
    >>> fig = dynamics_bode_figure(G, G)
    >>> len(fig.axes) >= 8
    True
    """
    import control  # lazy: python-control only for runs with identified dynamics

    dts = [s.dt for s in (identified, true) if s.isdtime(strict=True)]
    if frequencies_hz is None:
        f_hi = 0.45 / min(dts) if dts else 5000.0
        frequencies_hz = np.logspace(0, np.log10(f_hi), 300)
    w = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
    if (identified.ninputs, identified.noutputs) == (true.ninputs, true.noutputs):
        # the identified model knows no signal names: give it the true system's
        identified = control.ss(identified.A, identified.B, identified.C, identified.D,
                                identified.dt, inputs=true.input_labels,
                                outputs=true.output_labels)
    responses = [control.frequency_response(identified, w), control.frequency_response(true, w)]
    for resp, label in zip(responses, labels):
        resp.sysname = label
    p, m = true.noutputs, true.ninputs
    title_h = _title_height(title, 4.0 * m + 1.5)
    # python-control's fonts (it sets them when it makes the axes itself)
    with plt.rc_context(control.config.defaults["ctrlplot.rcParams"]):
        fig, ax = plt.subplots(2 * p, m, figsize=(4.0 * m + 1.5, 3.0 * p + 1.0 + title_h),
                               squeeze=False)
        # margins in inches, set before python-control draws: it places the "To <output>"
        # labels from the axes' positions, and with its own axes it would run tight_layout
        # (two extra draws of the whole figure)
        fixed_layout(fig, 2 * p, m, left=1.35, right=0.25, bottom=0.6, top=title_h + 0.35,
                     wspace=0.45, hspace=0.35)
        with np.errstate(divide="ignore"):        # exact zeros (decoupled entries): -inf dB
            cplt = control.bode_plot(responses, Hz=True, dB=True, deg=True, ax=ax,
                                     wrap_phase=True, share_magnitude="row",
                                     share_phase="row", share_frequency="col")
    suptitle(fig, title)
    fig = cplt.figure
    for ax in np.ravel(cplt.axes):       # the true system dashed over the identified one
        for line in ax.get_lines():
            if line.get_label() == labels[1]:
                line.set_linestyle("--")
        legend = ax.get_legend()
        if legend is not None:           # python-control drew it with the solid style
            handles = {ln.get_label(): ln for ln in ax.get_lines()}
            ax.legend([handles[t.get_text()] for t in legend.get_texts()],
                      [t.get_text() for t in legend.get_texts()], loc=legend._loc,
                      fontsize=legend.get_texts()[0].get_fontsize())
    axes = np.asarray(cplt.axes).reshape(2 * true.noutputs, true.ninputs)
    mag = np.abs(responses[1].magnitude)                             # (p, m, n_freq)
    zero = np.max(mag, axis=-1) <= 1e-12 * np.max(mag)               # (p, m): 0 up to round-off
    for i, j in zip(*np.nonzero(zero)):
        # an exactly-zero true entry (no dynamic coupling) has no magnitude in dB and
        # no phase: draw nothing for it rather than a meaningless 0 deg line
        for ax in axes[2 * i:2 * i + 2, j]:
            for line in [ln for ln in ax.get_lines() if ln.get_label() == labels[1]]:
                line.remove()
        axes[2 * i, j].text(0.02, 0.04, f"{labels[1]}: 0 (no coupling)",
                            transform=axes[2 * i, j].transAxes, fontsize=8)
    if zero.any():                          # scales without the removed curves
        for ax in axes.ravel():
            ax.relim()
            ax.autoscale_view(scalex=False)
    return fig
