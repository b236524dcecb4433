"""Hysteresis loops that run the wrong way round: an output that leads its input.

A piezo actuator's output lags its input: in the (input, output) plane its
loops run counter-clockwise, the ascending branch below the descending one,
and every model class draws them so. Records whose loops run clockwise say
that the output leads: a time column shifted against the inputs, a delay
given or estimated with the wrong sign, inputs and outputs paired wrongly.
An outside user's records of that kind (a simulator whose descending branch
lay 12.8 % of the stroke below the ascending one) were identified with
warnings on symmetry, minor loops and the dynamics fit, never on this, and
every drive then missed by 10-55 %. :func:`clockwise_loop_warnings` names them.

The orientation is the sign of the area the path ``(u, y)`` encloses, by the
shoelace formula ``A = 1/2 sum_i (u_i y_{i+1} - u_{i+1} y_i)`` (the path closed
by the chord from its end to its start; positive counter-clockwise). For the
ellipse ``u = a sin t``, ``y = b sin(t - phi)``, ``A = pi a b sin(phi)``: a lag
``phi > 0`` gives ``A > 0``, and ``A / (ptp(u) ptp(y)) = (pi / 4) sin(phi)``,
``sin(phi)`` being the loop's opening at ``u = 0`` over the output's span.
"""

from __future__ import annotations

import numpy as np

__all__ = ["CLOCKWISE_SHARE", "loop_area_share", "clockwise_loop_warnings"]

#: A direct path whose loops' signed area is below minus this share
#: (:func:`loop_area_share`) runs clockwise: a loop opening of about 1.3 % of the output's
#: span the wrong way (the sensor's noise adds a few 1e-5 on a record of thousands of samples).
CLOCKWISE_SHARE = 0.01


def loop_area_share(records, k, l):
    """The signed area of output ``l`` over input ``k``, over half the input's travel times
    the output's span.

    Parameters
    ----------
    records : sequence of MultiRecord
        Each with ``u`` (m, n_samples) [V] and ``y`` (p, n_samples) [µm].
    k, l : int
        Input and output index.

    Returns
    -------
    float or None
        The sum of the records' shoelace areas over the sum of their
        ``sum |diff(u_k)| ptp(y_l) / 2`` (``ptp(u) ptp(y)`` for one cycle: module
        notes; > 0 counter-clockwise, a lagging output); None when no record moves
        both.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> t = np.linspace(0, 2 * np.pi, 2001)
    >>> lag = SimpleNamespace(u=np.sin(t)[None], y=np.sin(t - 0.2)[None])
    >>> round(loop_area_share([lag], 0, 0), 4), round(float(np.pi / 4 * np.sin(0.2)), 4)
    (0.156, 0.156)
    """
    area = scale = 0.0
    for r in records:
        u = np.asarray(r.u[k], dtype=float)
        y = np.asarray(r.y[l], dtype=float)
        ok = np.isfinite(u) & np.isfinite(y)
        u, y = u[ok], y[ok]
        if u.size < 3 or np.ptp(u) <= 0 or np.ptp(y) <= 0:
            continue
        u, y = u - u.mean(), y - y.mean()       # the area does not move; the rounding does
        area += 0.5 * float(np.dot(u[:-1], y[1:]) - np.dot(u[1:], y[:-1])
                            + u[-1] * y[0] - u[0] * y[-1])
        # over the input's whole travel: every cycle of a decreasing sine adds its area
        scale += 0.5 * float(np.sum(np.abs(np.diff(u)))) * float(np.ptp(y))
    return area / scale if scale > 0 else None


def _direct_slope(records, k):
    """The least-squares slope of output ``k`` on input ``k`` over the records (0 if none)."""
    u = np.concatenate([np.asarray(r.u[k], dtype=float) for r in records])
    y = np.concatenate([np.asarray(r.y[k], dtype=float) for r in records])
    ok = np.isfinite(u) & np.isfinite(y)
    du, dy = u[ok] - u[ok].mean(), y[ok] - y[ok].mean()
    var = float(np.dot(du, du))
    return float(np.dot(du, dy)) / var if var > 0 else 0.0


def clockwise_loop_warnings(records, inputs, outputs):
    """One warning line per direct path whose loops run clockwise in the records.

    Parameters
    ----------
    records : sequence of MultiRecord
        The hysteresis records (``u`` (m, n) [V], ``y`` (p, n) [µm]).
    inputs, outputs : sequence of str
        Names; output k is input k's direct path.

    Returns
    -------
    list of str
        Per such path: the share (:func:`loop_area_share`) below
        ``-CLOCKWISE_SHARE`` (above ``CLOCKWISE_SHARE`` on a path whose output falls as
        its input rises: a lagging output's loops run clockwise there), the loop
        opening it stands for, what to check.

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> t = np.linspace(0, 6 * np.pi, 3001)
    >>> lead = SimpleNamespace(u=np.sin(t)[None], y=np.sin(t + 0.1)[None])
    >>> clockwise_loop_warnings([lead], ["ux"], ["x"])[0][:47]
    "x's loops over ux run clockwise (the output lea"
    """
    lines = []
    for k in range(min(len(inputs), len(outputs))):
        share = loop_area_share(records, k, k)
        if share is None:
            continue
        # a lagging output's loops run clockwise on a falling path (a sensor of inverted
        # sign, which identify names apart): judged against the path's slope, they lead
        # only where they open the other way
        falling = _direct_slope(records, k) < 0
        if (-share if falling else share) >= -CLOCKWISE_SHARE:
            continue
        turn = "counter-clockwise on its falling path" if falling else "clockwise"
        lines.append(f"{outputs[k]}'s loops over {inputs[k]} run {turn} (the output leads "
                     f"its input: loops opening by about {100 * 4 * abs(share) / np.pi:.3g} % of "
                     f"{outputs[k]}'s span the wrong way, on average over the records); "
                     f"a piezo's output lags its input, and every model class draws its loops "
                     f"so: a time column shifted against the inputs, a delay of the wrong sign, "
                     f"or inputs and outputs paired wrongly?")
    return lines
