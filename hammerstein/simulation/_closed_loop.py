"""Compiled (numba) closed loop: sensor, discrete controller, amplifier and the Hammerstein plant.

Arrays only; :func:`simulate_closed_loop` validates and packs, the kernel
:func:`closed_loop_kernel` steps one record with no Python per sample and
updates every state in place (a chunked run equals one long run).

At sample t, with the plant strictly proper or the measurement delayed
(``delay >= 1``):

1. ``z_t = y_{t-d} + n_{t-d}`` the sensed position plus the sensor noise,
   delayed (``y_t = C x_t`` when ``d = 0``);
2. ``m_t = Cs xs_t + Ds z_t``, ``xs <- As xs + Bs z_t`` (sensor bandwidth);
3. ``v_t = Ck xc_t + Dk [r_t; m_t; f_t]`` the controller (it may read the
   feedforward ``f_t``), ``u_t = f_t + v_t``, ``a_t`` = ``u_t`` slew-limited then clipped to the
   amplifier range;
4. ``xc <- Ak xc + Bk [r_t; m_t; f_t]`` plus the anti-windup: back-calculation
   ``+ Kaw (a_t - u_t)``, or clamping: conditional integration per channel,
   an integrator state of the controller that drives channel k keeps its value
   while k is limited and its update would push k further past the limit
   (``Ck[k, i] dxc_i`` of the sign of ``u_k - a_k``), and moves otherwise, so
   that it unwinds as soon as the error turns;
5. ``h_t = Gamma(a_t)`` (the hysteresis, its states committed),
   ``y_t = C x_t + D h_t (+ offset)``, ``x <- A x + B h_t``.

The hysteresis is either a packed multivariable classical PI
(:class:`~hammerstein.simulation.PIArrays`, ``kind = 0``) or the component
arrays of a :class:`~hammerstein.models.preisach.MultivariableHysteresis`
(ramp Preisach hysterons, generalised plays, polynomials; ``kind = 1``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit, uint64

from hammerstein.exceptions import HysteresisError
from hammerstein.simulation._kernels import FASTMATH, _commit, _output
from hammerstein.simulation._packing import PIArrays
from hammerstein.simulation._preisach import _ramp

__all__ = ["ComponentArrays", "LoopArrays", "LoopState", "closed_loop_kernel",
           "simulate_closed_loop", "empty_pi", "empty_components",
           "AW_NONE", "AW_BACK", "AW_CLAMP"]

#: anti-windup codes of the kernel
AW_NONE = 0
AW_BACK = 1
AW_CLAMP = 2


class ComponentArrays(NamedTuple):
    """Component arrays of a multivariable Preisach / generalised-PI / polynomial model.

    Component ``c = l m + k`` maps input k to output l.

    Parameters
    ----------
    E : numpy.ndarray
        Cell edges of every component's switching grid [V].
    e_off : numpy.ndarray, shape (p m + 1,)
        Component c's edges are ``E[e_off[c]:e_off[c+1]]``.
    row, col : numpy.ndarray of int64
        Alpha (rising) and beta (falling) cell of each ramp hysteron.
    mu : numpy.ndarray
        Weight of each ramp hysteron [µm].
    q_off : numpy.ndarray, shape (p m + 1,)
        Component c's hysterons are ``q_off[c]:q_off[c+1]``.
    pr, pw : numpy.ndarray
        Thresholds [V] and weights [µm/V] of the generalised plays.
    p_off : numpy.ndarray, shape (p m + 1,)
        Component c's plays are ``p_off[c]:p_off[c+1]``.
    env : numpy.ndarray, shape (p m, 8)
        Envelopes ``gamma_l | gamma_r`` of the generalised plays.
    s_off : numpy.ndarray, shape (p m,)
        Start of each component's states in the flat state.
    rev : numpy.ndarray, shape (p m, n_c)
        Polynomial coefficients (u, u^2, ...) [µm/V^i].
    off : numpy.ndarray, shape (p m,)
        Offsets [µm].
    present : numpy.ndarray of bool, shape (p m,)
        Whether each component exists.
    """

    E: np.ndarray
    e_off: np.ndarray
    row: np.ndarray
    col: np.ndarray
    mu: np.ndarray
    q_off: np.ndarray
    pr: np.ndarray
    pw: np.ndarray
    p_off: np.ndarray
    env: np.ndarray
    s_off: np.ndarray
    rev: np.ndarray
    off: np.ndarray
    present: np.ndarray


class LoopArrays(NamedTuple):
    """The loop's fixed arrays (sensor, controller, amplifier), a kernel argument.

    Parameters
    ----------
    As, Bs, Cs, Ds : numpy.ndarray
        The discrete sensor low-pass (p -> p).
    Ak, Bk, Ck, Dk : numpy.ndarray
        The discrete controller, inputs ``[r; m; f]`` (2 p + m) -> voltages (m).
    Kaw : numpy.ndarray, shape (n_c, m)
        Back-calculation gain.
    clamp : numpy.ndarray of int64, shape (n_c,)
        The channel each integrator state drives most (``argmax_k |Ck[k, i]|``),
        whose limit clamps it; -1 for a state never clamped.
    low, high : numpy.ndarray, shape (m,)
        Amplifier range [V].
    slew : numpy.ndarray, shape (m,)
        Largest voltage step per sample [V].
    y_off : numpy.ndarray, shape (p,)
        Output offset [µm].
    delay : int
        Sensor delay [samples].
    aw : int
        Anti-windup code (``AW_NONE``, ``AW_BACK``, ``AW_CLAMP``).
    """

    As: np.ndarray
    Bs: np.ndarray
    Cs: np.ndarray
    Ds: np.ndarray
    Ak: np.ndarray
    Bk: np.ndarray
    Ck: np.ndarray
    Dk: np.ndarray
    Kaw: np.ndarray
    clamp: np.ndarray
    low: np.ndarray
    high: np.ndarray
    slew: np.ndarray
    y_off: np.ndarray
    delay: int
    aw: int


class LoopState(NamedTuple):
    """States of a closed-loop run, updated in place by the kernel.

    Parameters
    ----------
    s : numpy.ndarray
        Hysteresis states (play outputs [V] or hysteron states).
    x : numpy.ndarray
        Plant linear states (creep then modes) [µm].
    xs : numpy.ndarray
        Sensor low-pass states [µm].
    buf : numpy.ndarray, shape (p, max(delay, 1))
        The delayed noisy positions [µm], the oldest at index ``pos[0]``.
    pos : numpy.ndarray of int64, shape (1,)
        Ring-buffer position.
    xc : numpy.ndarray
        Controller states.
    a : numpy.ndarray, shape (m,)
        The last applied voltages [V] (slew limit).
    """

    s: np.ndarray
    x: np.ndarray
    xs: np.ndarray
    buf: np.ndarray
    pos: np.ndarray
    xc: np.ndarray
    a: np.ndarray


@njit(cache=True, inline="always")
def _components(u, ca, s, h, rho):
    """``h = Gamma(u)`` of the component model, every state committed."""
    p = h.size
    m = u.size
    for l in range(p):
        h[l] = 0.0
    for l in range(p):
        for k in range(m):
            c = l * m + k
            if not ca.present[c]:
                continue
            uk = u[k]
            acc = 0.0
            e0 = ca.e_off[c]
            q0 = ca.q_off[c]
            q1 = ca.q_off[c + 1]
            if q1 > q0:
                nl = uint64(ca.e_off[c + 1] - e0 - 1)
                E = ca.E
                for i in range(nl):
                    i = uint64(i)
                    rho[i] = _ramp(uk, E[uint64(e0) + i], E[uint64(e0) + i + uint64(1)])
                row, col, mu = ca.row, ca.col, ca.mu
                sb = uint64(ca.s_off[c])
                uq0 = uint64(q0)
                for q in range(uq0, uint64(q1)):
                    q = uint64(q)
                    up = rho[uint64(row[q])]
                    down = rho[uint64(col[q])]
                    j = sb + (q - uq0)
                    v = s[j]
                    v = down if v > down else v
                    v = up if v < up else v
                    s[j] = v
                    acc += mu[q] * v
            p0 = ca.p_off[c]
            p1 = ca.p_off[c + 1]
            if p1 > p0:
                base = ca.s_off[c] + q1 - q0 - p0
                lo = ca.env[c, 0] * np.tanh(ca.env[c, 1] * uk + ca.env[c, 2]) + ca.env[c, 3]
                hi = ca.env[c, 4] * np.tanh(ca.env[c, 5] * uk + ca.env[c, 6]) + ca.env[c, 7]
                for j in range(p0, p1):
                    v = s[base + j]
                    if v > hi + ca.pr[j]:
                        v = hi + ca.pr[j]
                    if v < lo - ca.pr[j]:
                        v = lo - ca.pr[j]
                    s[base + j] = v
                    acc += ca.pw[j] * v
            poly = 0.0
            for n in range(ca.rev.shape[1] - 1, -1, -1):
                poly = (poly + ca.rev[c, n]) * uk
            h[l] += acc + poly + ca.off[c]


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def closed_loop_kernel(r, f, noise, kind, pi, ca, plant, loop, st, y, a_out, m_out):
    """One closed-loop record (see the module docstring); states in ``st`` in/out.

    ``r`` (p, N) reference [µm], ``f`` (m, N) feedforward [V], ``noise``
    (p, N) [µm]; ``kind`` 0 (PI arrays ``pi``) or 1 (component arrays
    ``ca``); ``plant`` the LinearArrays of the plant's linear part;
    outputs ``y`` (p, N) positions [µm], ``a_out`` (m, N) applied voltages
    [V], ``m_out`` (p, N) measurements [µm].
    """
    p, N = r.shape
    m = f.shape[0]
    A, B, C, D = plant.A, plant.B, plant.C, plant.D
    nx = A.shape[0]
    ns = loop.As.shape[0]
    nc = loop.Ak.shape[0]
    d = loop.delay
    nrho = 1
    for c in range(ca.e_off.size - 1):
        if ca.e_off[c + 1] - ca.e_off[c] > nrho:
            nrho = ca.e_off[c + 1] - ca.e_off[c]
    rho = np.empty(nrho)
    z = np.empty(p)
    meas = np.empty(p)
    ne = 2 * p + m
    e = np.empty(ne)
    u = np.empty(m)
    a = np.empty(m)
    h = np.empty(p)
    yt = np.empty(p)
    xn = np.empty(nx)
    xsn = np.empty(ns)
    xcn = np.empty(nc)
    sat = np.zeros(m)
    pos = st.pos[0]
    for t in range(N):
        # 1. the sensed position
        if d == 0:
            for l in range(p):
                acc = 0.0
                for i in range(nx):
                    acc += C[l, i] * st.x[i]
                z[l] = acc + loop.y_off[l] + noise[l, t]
        else:
            for l in range(p):
                z[l] = st.buf[l, pos]
        # 2. the sensor
        for l in range(p):
            acc = 0.0
            for i in range(ns):
                acc += loop.Cs[l, i] * st.xs[i]
            for j in range(p):
                acc += loop.Ds[l, j] * z[j]
            meas[l] = acc
        for i in range(ns):
            acc = 0.0
            for j in range(ns):
                acc += loop.As[i, j] * st.xs[j]
            for j in range(p):
                acc += loop.Bs[i, j] * z[j]
            xsn[i] = acc
        for i in range(ns):
            st.xs[i] = xsn[i]
        # 3. the controller and the amplifier
        for l in range(p):
            e[l] = r[l, t]
            e[p + l] = meas[l]
        for k in range(m):
            e[2 * p + k] = f[k, t]
        saturated = False
        for k in range(m):
            sat[k] = 0.0
            acc = f[k, t]
            for i in range(nc):
                acc += loop.Ck[k, i] * st.xc[i]
            for j in range(ne):
                acc += loop.Dk[k, j] * e[j]
            u[k] = acc
            v = acc
            lo_s = st.a[k] - loop.slew[k]
            hi_s = st.a[k] + loop.slew[k]
            if v > hi_s:
                v = hi_s
            if v < lo_s:
                v = lo_s
            if v > loop.high[k]:
                v = loop.high[k]
            if v < loop.low[k]:
                v = loop.low[k]
            if v != acc:
                saturated = True
                sat[k] = 1.0 if acc > v else -1.0
            a[k] = v
            st.a[k] = v
        # 4. the controller's state, with the anti-windup
        for i in range(nc):
            acc = 0.0
            for j in range(nc):
                acc += loop.Ak[i, j] * st.xc[j]
            for j in range(ne):
                acc += loop.Bk[i, j] * e[j]
            if loop.aw == AW_BACK:
                for k in range(m):
                    acc += loop.Kaw[i, k] * (a[k] - u[k])
            elif loop.aw == AW_CLAMP and saturated and loop.clamp[i] >= 0:
                c = loop.clamp[i]      # its channel limited, and the update pushes it further
                if sat[c] != 0.0 and loop.Ck[c, i] * (acc - st.xc[i]) * sat[c] > 0.0:
                    acc = st.xc[i]
            xcn[i] = acc
        for i in range(nc):
            st.xc[i] = xcn[i]
        # 5. the plant
        if kind == 0:
            _commit(a, pi.start, pi.r, st.s)
            _output(a, pi.W, pi.G, st.s, h)
        else:
            _components(a, ca, st.s, h, rho)
        for l in range(p):
            acc = loop.y_off[l]
            for i in range(nx):
                acc += C[l, i] * st.x[i]
            for j in range(p):
                acc += D[l, j] * h[j]
            yt[l] = acc
        for i in range(nx):
            acc = 0.0
            for j in range(nx):
                acc += A[i, j] * st.x[j]
            for j in range(p):
                acc += B[i, j] * h[j]
            xn[i] = acc
        for i in range(nx):
            st.x[i] = xn[i]
        if d > 0:
            for l in range(p):
                st.buf[l, pos] = yt[l] + noise[l, t]
            pos += 1
            if pos == d:
                pos = 0
        for l in range(p):
            y[l, t] = yt[l]
            m_out[l, t] = meas[l]
        for k in range(m):
            a_out[k, t] = a[k]
    st.pos[0] = pos



def empty_pi(m, p):
    """PI arrays of no play operator and no gain (the argument unused by ``kind = 1`` runs).

    Parameters
    ----------
    m, p : int
        Numbers of inputs and outputs.

    Returns
    -------
    PIArrays
    """
    return PIArrays(np.zeros(m + 1, np.int64), np.zeros(0), np.zeros((p, 0)), np.zeros((p, m)))


def empty_components(m, p):
    """Component arrays of no component (the argument unused by ``kind = 0`` runs).

    Parameters
    ----------
    m, p : int
        Numbers of inputs and outputs.

    Returns
    -------
    ComponentArrays
    """
    n = p * m
    z = np.zeros(n + 1, np.int64)
    return ComponentArrays(np.zeros(0), z, np.zeros(0, np.int64), np.zeros(0, np.int64),
                           np.zeros(0), z.copy(), np.zeros(0), np.zeros(0), z.copy(),
                           np.zeros((n, 8)), np.zeros(n, np.int64), np.zeros((n, 1)),
                           np.zeros(n), np.zeros(n, np.bool_))


def _record(a, rows, n, name):
    arr = np.ascontiguousarray(a, dtype=float)
    if arr.shape != (rows, n):
        raise HysteresisError(f"{name}: expected shape ({rows}, {n}), found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise HysteresisError(f"{name}: expected finite values")
    return arr


def simulate_closed_loop(kind, pi, components, plant, loop, reference, feedforward, noise, state):
    """Run the compiled closed loop on one record (arrays validated here).

    Parameters
    ----------
    kind : {0, 1}
        0: the hysteresis is the packed classical PI ``pi``; 1: the
        component arrays ``components``.
    pi : PIArrays
        Packed multivariable PI (:func:`hammerstein.simulation.pack_model`),
        or :func:`empty_pi`.
    components : ComponentArrays
        Component arrays, or :func:`empty_components`.
    plant : LinearArrays
        Discrete linear part of the plant (creep then modes), p -> p [µm].
    loop : LoopArrays
        Sensor, controller and amplifier.
    reference : numpy.ndarray, shape (p, n_samples)
        Reference [µm].
    feedforward : numpy.ndarray, shape (m, n_samples)
        Feedforward voltages [V].
    noise : numpy.ndarray, shape (p, n_samples)
        Sensor noise [µm].
    state : LoopState
        Initial states, updated in place to the final ones.

    Returns
    -------
    outputs : numpy.ndarray, shape (p, n_samples)
        Positions [µm].
    inputs : numpy.ndarray, shape (m, n_samples)
        Applied voltages [V].
    measurements : numpy.ndarray, shape (p, n_samples)
        Sensor outputs [µm].

    Raises
    ------
    HysteresisError
        On wrongly shaped or non-finite records, or an algebraic loop (a
        plant with direct feedthrough and no sensor delay).
    """
    p = plant.C.shape[0]
    m = loop.Ck.shape[0]
    yr = _record(reference, p, np.shape(reference)[-1], "reference")
    n = yr.shape[1]
    ff = _record(feedforward, m, n, "feedforward")
    nz = _record(noise, p, n, "noise")
    if loop.delay == 0 and np.any(plant.D != 0):
        raise HysteresisError("sensor delay: the plant has a direct feedthrough (D != 0): the "
                              "loop is algebraic without a delay of at least one sample")
    if loop.Dk.shape != (m, 2 * p + m) or loop.Bk.shape[1] != 2 * p + m:
        raise HysteresisError(f"controller: expected 2 p + m = {2 * p + m} inputs [r; m; f], "
                              f"found {loop.Dk.shape[1]}")
    y = np.empty((p, n))
    a = np.empty((m, n))
    meas = np.empty((p, n))
    closed_loop_kernel(yr, ff, nz, int(kind), pi, components, plant, loop, state, y, a, meas)
    return y, a, meas
