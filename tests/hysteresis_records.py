"""Hysteresis records for the identify tests: one decreasing sine per input, played through a model."""

import numpy as np

from hammerstein.models.preisach import MultivariableHysteresis, Polynomial, PreisachModel
from hammerstein.signals.excitation import decreasing_sine


def write(path, t, u, y):
    """A record with columns t, ux, uy, x, y (``u``, ``y``: (2, n_samples))."""
    np.savetxt(path, np.column_stack([t, u.T, y.T]), delimiter=",", header="t,ux,uy,x,y",
               comments="", fmt="%.10g")


def decreasing_sine_records(d, act, noise, prefix, T, scale=(1.0, 1.0), t_scale=1.0, seed=3):
    """One record per input of ``act`` (a 10 V decreasing sine on it, the other at 0 V) with
    ``noise`` µm of sensor noise, the outputs times ``scale`` and the time times ``t_scale``,
    written as ``d/<prefix>-<k>.csv``; their paths."""
    rng, out = np.random.default_rng(seed), []
    for k in range(2):
        t, one, _ = decreasing_sine(T, 10.0)
        u = np.zeros((2, t.size))
        u[k] = one
        y = act.simulate(u)[0] + noise * rng.standard_normal((2, t.size))
        write(d / f"{prefix}-{k}.csv", t * t_scale, u, y * np.asarray(scale, float)[:, None])
        out.append(str(d / f"{prefix}-{k}.csv"))
    return out


def preisach_actuator():
    """A 2x2 Preisach actuator with tilted, biased loops and an even cross-coupling (y <- ux)."""
    e = np.linspace(-10.5, 10.5, 31)
    x = PreisachModel.from_density(e, total=24.0, bias_width=5.0, tilt=0.6, coercivity_width=3.0,
                                   reversible=[3.0, 0.035])
    y = PreisachModel.from_density(e, total=22.0, bias=0.3, bias_width=5.0, tilt=-0.5,
                                   coercivity_width=2.6, reversible=[2.8, -0.04])
    return MultivariableHysteresis([[x, None], [Polynomial([0.05, 0.03]), y]], ["ux", "uy"],
                                   ["x", "y"], [10.0, 10.0])
