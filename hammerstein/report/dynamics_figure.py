"""Bode comparison of identified and true linear dynamics G (all p x p entries).

python-control draws it, imported on first use (a run without identified
dynamics does not load it). :func:`state_space_data` and
:func:`dynamics_bode_figure_from_data` carry the systems to a figure worker
process as arrays (``control.StateSpace`` objects do not pickle).
"""

from __future__ import annotations

import numpy as np

from hammerstein.report.figures import _title_height, fixed_layout, suptitle
from hammerstein.report.figures import pyplot as plt  # matplotlib on first use

__all__ = ["dynamics_bode_figure", "dynamics_bode_figure_from_data", "measured_bode_figure",
           "state_space_data"]


def _major_grid(axes):
    """A light grid on the major ticks alone: python-control's bode_plot also draws one
    on every minor tick of its log axes, a dense mesh that clutters the curves."""
    for a in np.ravel(axes):
        a.grid(False, which="minor")
        a.grid(True, which="major", color="0.8", linewidth=0.7, linestyle="-")


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


#: Imported on first use (see :mod:`hammerstein.report.render`: a figure worker
#: forked once the run has loaded them draws this figure).
dynamics_bode_figure_from_data.imports = ("control",)


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
    >>> from hammerstein.models.dynamics import bending_modes, discretize
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
        fig, ax = plt.subplots(2 * p, m, figsize=(4.0 * m + 1.5, 3.0 * p + 1.3 + title_h),
                               squeeze=False)
        # margins in inches, set before python-control draws: it places the "To <output>"
        # labels from the axes' positions, and with its own axes it would run tight_layout
        # (two extra draws of the whole figure)
        fixed_layout(fig, 2 * p, m, left=1.35, right=0.25, bottom=0.6, top=title_h + 0.65,
                     wspace=0.45, hspace=0.35)
        with np.errstate(divide="ignore"):        # exact zeros (decoupled entries): -inf dB
            cplt = control.bode_plot(responses, Hz=True, dB=True, deg=True, ax=ax,
                                     wrap_phase=False, share_magnitude="row",
                                     share_phase="row", share_frequency="col")
    suptitle(fig, title)
    fig = cplt.figure
    _major_grid(cplt.axes)
    _physical_labels(fig, true.input_labels, true.output_labels)
    nyquist = [0.5 / dt for dt in dts]
    for ax in np.ravel(cplt.axes):
        for line in ax.get_lines():
            x = np.asarray(line.get_xdata(), dtype=float)
            if x.size and np.all(x == x[0]) and np.any(np.isclose(x[0], nyquist)):
                # python-control's Nyquist-frequency marker, drawn in each system's colour and
                # style: a thin grey dotted reference line, so it does not read as a curve
                line.set(color="0.55", linestyle=":", linewidth=0.9,
                         label=f"Nyquist frequency ({min(nyquist):g} Hz)")
            elif line.get_label() == labels[1]:
                line.set_linestyle("--")   # the true system dashed over the identified one
        if ax.get_legend() is not None:    # one legend for the figure, off the data
            ax.get_legend().remove()
    axes = np.asarray(cplt.axes).reshape(2 * true.noutputs, true.ninputs)
    mag = np.abs(responses[1].magnitude)                             # (p, m, n_freq)
    zero = np.max(mag, axis=-1) <= 1e-12 * np.max(mag)               # (p, m): 0 up to round-off
    for i, j in zip(*np.nonzero(zero)):
        # an exactly-zero true entry (no dynamic coupling) has no magnitude in dB and
        # no phase: draw nothing for it rather than a meaningless 0 deg line
        for ax in axes[2 * i:2 * i + 2, j]:
            for line in [ln for ln in ax.get_lines() if ln.get_label() == labels[1]]:
                line.remove()
        both = np.max(np.abs(responses[0].magnitude[i, j])) <= 1e-12 * np.max(mag)
        note = (f"no data: {labels[0]} and {labels[1]} are 0 (no coupling)" if both
                else f"{labels[1]}: 0 (no coupling)")
        axes[2 * i, j].text(0.02, 0.04, note, transform=axes[2 * i, j].transAxes, fontsize=8)
    if zero.any():                          # scales without the removed curves
        for ax in axes.ravel():
            ax.relim()
            ax.autoscale_view(scalex=False)
    drawn = {}
    for ax in axes.ravel():
        for line in ax.get_lines():
            if line.get_label() in labels:
                drawn.setdefault(line.get_label(), line)
    handles = [drawn[k] for k in labels if k in drawn]
    names = [h.get_label() for h in handles]
    if nyquist:
        handles.append(next(ln for ax in axes.ravel() for ln in ax.get_lines()
                            if ln.get_label().startswith("Nyquist")))
        names.append(handles[-1].get_label())
    W, H = fig.get_size_inches()
    fig.legend(handles, names, loc="lower center", ncol=len(names), fontsize=8, frameon=False,
               bbox_to_anchor=(0.5, fig.subplotpars.top + 0.3 / H))
    return fig


def _physical_labels(fig, inputs, outputs):
    """Column and row labels in the actuator's words, not python-control's signal names.

    G's inputs are the hysteresis outputs (``x_h``: the displacement the
    hysteresis alone would give, µm) and its outputs the displacements; its
    entries are lettered (a), (b), ... row by row.
    """
    def words(name):
        base = name[:-2] if name.endswith("_h") else name
        return f"hysteresis output {base}_h [µm]" if name.endswith("_h") else f"input {name}"

    cols = {f"From {name}": name for name in inputs}
    rows = {f"To {name}": name for name in outputs}
    axes = [ax for ax in fig.axes if ax.get_title() in cols]
    for ax in axes:
        ax.set_title(f"from {words(cols[ax.get_title()])}", fontsize=ax.title.get_fontsize())
    for text in fig.texts:
        key = text.get_text().strip()
        if key in rows:
            text.set_text(f"to displacement {rows[key]} [µm]\n")
    mags = [ax for ax in fig.axes if ax.get_subplotspec() is not None
            and ax.get_subplotspec().rowspan.start % 2 == 0]
    mags.sort(key=lambda a: (a.get_subplotspec().rowspan.start, a.get_subplotspec().colspan.start))
    m = len(inputs)
    for k, ax in enumerate(mags):
        i, j = divmod(k, m)
        ax.text(0.99, 0.95, f"({chr(ord('a') + k)}) {outputs[i]} from {inputs[j]}",
                transform=ax.transAxes, fontsize=8, va="top", ha="right",
                bbox=dict(facecolor="white", edgecolor="none", pad=1.0, alpha=0.85))


def measured_bode_figure(identified, frequency_hz, frf, names=None,
                         title="Identified G and its measured frequency response"):
    """Bode plot of an identified p x p G over the measured frequency-response estimate.

    The measured estimate (e.g. H1 from multisines,
    :func:`hammerstein.models.lti.frf_h1`) is drawn as grey dots behind the
    identified model (solid), both by python-control's ``bode_plot`` (the
    estimate as a ``control.FrequencyResponseData``).

    Parameters
    ----------
    identified : control.StateSpace
        p x p system (continuous or discrete).
    frequency_hz : array_like, shape (n_freq,)
        Frequencies of the estimate [Hz], > 0.
    frf : array_like, shape (p, p, n_freq)
        Complex estimate [µm/µm]; NaN entries are left out (with none left,
        or ``n_freq = 0``, the identified model is drawn alone, from 1 Hz).
    names : sequence of str, optional
        Axis names (p); default those of ``identified``.
    title : str
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        2 p rows (magnitude, phase per output) by p columns (inputs).

    Examples
    --------
    >>> import numpy as np, control
    >>> G = control.ss([[-100.0]], [[100.0]], [[1.0]], [[0.0]])
    >>> f = np.logspace(0, 3, 50)
    >>> H = np.asarray(control.frequency_response(G, 2 * np.pi * f).complex).reshape(1, 1, -1)
    >>> fig = measured_bode_figure(G, f, H)
    >>> len(fig.axes)
    2
    """
    import control  # lazy: python-control only for runs with identified dynamics

    f = np.asarray(frequency_hz, dtype=float)
    H = np.asarray(frf, dtype=complex)
    keep = (f > 0) & np.all(np.isfinite(H), axis=(0, 1))
    f, H = f[keep], H[:, :, keep]
    p, m = identified.noutputs, identified.ninputs
    names = list(identified.output_labels) if names is None else [str(n) for n in names]
    sys_named = control.ss(identified.A, identified.B, identified.C, identified.D, identified.dt,
                           inputs=[f"{n}_h" for n in names[:m]], outputs=names[:p])
    nyquist = 0.49 / identified.dt if identified.isdtime(strict=True) else np.inf
    if f.size:
        f_lo, f_hi = max(f.min(), 1e-2), min(f.max(), nyquist)
    else:       # no finite measured line: the identified model alone, over its own band
        f_lo, f_hi = 1.0, min(1e4, nyquist)
        title = f"{title} (no measured line to draw)"
    w = 2 * np.pi * np.logspace(np.log10(f_lo), np.log10(f_hi), 400)
    model = control.frequency_response(sys_named, w)
    model.sysname = "identified"
    responses = [model]
    if f.size:
        measured = control.FrequencyResponseData(H, 2 * np.pi * f, inputs=sys_named.input_labels,
                                                 outputs=sys_named.output_labels)
        meas = control.frequency_response(measured)
        meas.sysname = "measured (H1)"
        responses = [meas, model]
    title_h = _title_height(title, 4.0 * m + 1.5)
    with plt.rc_context(control.config.defaults["ctrlplot.rcParams"]):
        fig, ax = plt.subplots(2 * p, m, figsize=(4.0 * m + 1.5, 3.0 * p + 1.0 + title_h),
                               squeeze=False)
        fixed_layout(fig, 2 * p, m, left=1.35, right=0.25, bottom=0.6, top=title_h + 0.35,
                     wspace=0.45, hspace=0.35)
        with np.errstate(divide="ignore"):
            cplt = control.bode_plot(responses, Hz=True, dB=True, deg=True, ax=ax,
                                     wrap_phase=True, share_magnitude="row",
                                     share_phase="row", share_frequency="col")
    suptitle(fig, title)
    _major_grid(cplt.axes)
    _physical_labels(cplt.figure, sys_named.input_labels, sys_named.output_labels)
    for a in np.ravel(cplt.axes):
        for line in a.get_lines():
            if line.get_label() == "measured (H1)":
                line.set_linestyle("none")
                line.set_marker(".")
                line.set_markersize(2.0)
                line.set_color("0.6")
                line.set_zorder(1)
        legend = a.get_legend()
        if legend is not None:
            handles = {ln.get_label(): ln for ln in a.get_lines()}
            a.legend([handles[t.get_text()] for t in legend.get_texts()],
                     [t.get_text() for t in legend.get_texts()], loc=legend._loc,
                     fontsize=legend.get_texts()[0].get_fontsize())
    return cplt.figure
