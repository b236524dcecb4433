"""python-control interoperability: the hysteresis and the compensator as I/O systems.

The multivariable PI model and the inverse multiplicative compensator become
discrete-time :class:`control.NonlinearIOSystem` objects (``dt = T``) whose
state vector holds the play states, so :func:`control.interconnect` can wire
them with any other python-control system and
:func:`control.input_output_response` can simulate the result. These systems
step in Python, one sample per call: use them to build and check block
diagrams, and the compiled kernels (:mod:`hammerstein.simulation`) for long
runs and sweeps.

Example
-------
>>> import control, numpy as np
>>> from hammerstein import load_plant
>>> from hammerstein.io.interop import hammerstein_system
>>> plant = load_plant("rakotondrabe-2dof")
>>> sys = hammerstein_system(plant)            # inputs ux, uy; outputs x, y
>>> t = np.arange(200) * plant.sampling_period
>>> u = np.vstack([10 * np.sin(2 * np.pi * 50 * t), np.zeros_like(t)])
>>> resp = control.input_output_response(sys, t, u)
>>> resp.outputs.shape
(2, 200)
"""

from __future__ import annotations

import numpy as np

from hammerstein.exceptions import CompensatorError, HysteresisError
from hammerstein.core.lazy import lazy_module
from hammerstein.simulation import compensator_law_of, compensator_step

control = lazy_module("control")  # lazy: python-control + scipy.signal (~1 s) on first use

__all__ = ["pi_system", "linear_system", "hammerstein_system", "compensator_system",
           "chain_system", "reference_names"]


def _check_period(sampling_period):
    if not (np.isfinite(sampling_period) and sampling_period > 0):
        raise HysteresisError(
            f"sampling_period: expected a positive time [s], found {sampling_period!r}")
    return float(sampling_period)


def _play_state_names(model, prefix):
    f = model.hysterons()
    count = {}
    names = []
    for l, k in zip(f["output_index"], f["input_index"]):
        i = count.get((l, k), 0)
        count[(l, k)] = i + 1
        names.append(f"{prefix}{model.output_names[l]}_{model.input_names[k]}[{i}]")
    return names


def pi_system(model, sampling_period, outputs=None, name="hysteresis"):
    """Multivariable PI model as a discrete-time python-control system, eq. (4).

    State: the flat play states ``s`` (ordered output, input, threshold,
    :meth:`MultivariablePI.hysterons`). Update ``s(t) = max(U - r, min(U + r,
    s(t-T)))``; output ``Y(t) = sum w s(t) + G U(t)`` (direct feedthrough).

    A model of another class (:class:`~hammerstein.models.preisach.MultivariableHysteresis`,
    Preisach or generalised-PI components, as ``identify`` writes them) steps by its own
    ``simulate`` one sample at a time, its flat state vector the system's (``s[i]``).

    Parameters
    ----------
    model : MultivariablePI or MultivariableHysteresis
        m inputs [V] -> p outputs [µm].
    sampling_period : float
        T [s], the system's ``dt``.
    outputs : sequence of str, optional
        Output signal names; default ``model.output_names``.
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``model.input_names``, states ``s_<out>_<in>[i]``.

    Raises
    ------
    HysteresisError
        On a non-positive sampling period or a wrong number of output names.
    """
    T = _check_period(sampling_period)
    outputs = list(model.output_names if outputs is None else outputs)
    if len(outputs) != model.n_outputs:
        raise HysteresisError(f"outputs: expected {model.n_outputs} names, found {outputs}")
    if not hasattr(model, "evaluate"):
        # a Preisach or generalised-PI model (identify's): one sample of its own simulation
        # from the state, whose flat vector is the system's (hysteron states, then plays)
        n = int(model.initial_state().size)

        def one(x, u):
            y, s = model.simulate(np.asarray(u, dtype=float)[:, None],
                                  np.asarray(x, dtype=float))
            return y[:, 0], s

        return control.nlsys(lambda t, x, u, params: one(x, u)[1],
                             lambda t, x, u, params: one(x, u)[0],
                             inputs=list(model.input_names), outputs=outputs,
                             states=[f"s[{i}]" for i in range(n)], dt=T, name=name)

    def update(t, x, u, params):
        return model.evaluate(np.asarray(u, dtype=float), np.asarray(x, dtype=float))[1]

    def output(t, x, u, params):
        return model.evaluate(np.asarray(u, dtype=float), np.asarray(x, dtype=float))[0]

    return control.nlsys(update, output, inputs=list(model.input_names), outputs=outputs,
                         states=_play_state_names(model, "s_"), dt=T, name=name)


def linear_system(plant, name="dynamics"):
    """Linear part of a Hammerstein plant as a named discrete StateSpace.

    Parameters
    ----------
    plant : HammersteinPlant
        With dynamics (``plant.is_static`` False).
    name : str
        System name.

    Returns
    -------
    control.StateSpace
        Inputs ``<out>_h`` [µm] (the hysteresis outputs), outputs ``<out>`` [µm],
        ``dt = plant.sampling_period``.

    Raises
    ------
    HysteresisError
        If the plant is static.
    """
    if plant.is_static:
        raise HysteresisError("plant: expected a plant with dynamics, found a static plant")
    A, B, C, D = plant.matrices
    outs = list(plant.hysteresis.output_names)
    return control.ss(A, B, C, D, dt=plant.sampling_period, inputs=[f"{n}_h" for n in outs],
                      outputs=outs, states=[f"x[{i}]" for i in range(A.shape[0])], name=name)


def hammerstein_system(plant, name="plant"):
    """Hammerstein plant (hysteresis then linear dynamics) by ``control.interconnect``.

    The hysteresis may be of any class :func:`pi_system` takes (a classical
    PI, or Preisach and generalised-PI components as ``identify`` writes
    them); start it at ``plant.rest_state()`` (``X0``), the state every drive
    starts from (a Preisach model's demagnetised hysterons are not zeros).

    Parameters
    ----------
    plant : HammersteinPlant
        The actuator model.
    name : str
        System name.

    Returns
    -------
    control.InterconnectedSystem or control.NonlinearIOSystem
        Inputs ``input_names`` [V], outputs ``output_names`` [µm]; states the
        play states then the linear states (the flat plant state order). A
        static plant gives the PI system itself.
    """
    model = plant.hysteresis
    if plant.is_static:
        return pi_system(model, plant.sampling_period, name=name)
    pi = pi_system(model, plant.sampling_period,
                   outputs=[f"{n}_h" for n in model.output_names])
    return control.interconnect([pi, linear_system(plant)], inplist=list(model.input_names),
                                outlist=list(model.output_names), inputs=list(model.input_names),
                                outputs=list(model.output_names), name=name)


def reference_names(model):
    """Names of the reference inputs of the compensator system: ``<out>_r``.

    Parameters
    ----------
    model : MultivariablePI
        The compensator's model.

    Returns
    -------
    list of str
        One name per model output.
    """
    return [f"{n}_r" for n in model.output_names]


def compensator_system(compensator, sampling_period=None, name="compensator"):
    """A fusable compensator as a discrete-time python-control system.

    Output ``U(t)`` from the reference ``Yr(t)`` and the state by the
    compensator's law (:class:`hammerstein.simulation.CompensatorLaw`, as
    :func:`hammerstein.simulation.simulate_compensator` runs it: delay with
    ``iterations`` fixed-point steps, or the low-pass of Section 6, after the
    optional reference pre-filter); update: the state committed with
    ``U(t)``. No divergence detection.

    Parameters
    ----------
    compensator : InverseMultiplicativeCompensator
        Or any compensator whose ``packed_law()`` returns a law (read once,
        when the system is built).
    sampling_period : float, optional
        T [s]; default ``compensator.sampling_period``.
    name : str
        System name.

    Returns
    -------
    control.NonlinearIOSystem
        Inputs ``<out>_r`` [µm], outputs ``model.input_names`` [V]; states
        ``U_prev`` [V], (``v_f`` [V]), ``c_<out>_<in>[i]`` play states [V],
        (``xf[i]`` pre-filter states [µm]).

    Raises
    ------
    HysteresisError
        Without a sampling period.
    CompensatorError
        If the compensator declares no law (``packed_law()``).
    """
    if sampling_period is None:
        sampling_period = getattr(compensator, "sampling_period", None)
    if sampling_period is None:
        raise HysteresisError("sampling_period: expected a positive time [s], found None")
    T = _check_period(sampling_period)
    law = compensator_law_of(compensator)
    if law is None:
        raise CompensatorError(
            f"compensator: {type(compensator).__name__} declares no packed_law(), so it has "
            f"no per-sample law to wrap")
    model = law.model
    states = [f"U_prev_{n}" for n in model.input_names]
    if law.lowpass:
        states += [f"v_f_{n}" for n in model.input_names]
    states += _play_state_names(model, "c_")
    states += [f"xf[{i}]" for i in range(law.n_filter_states)]

    def update(t, x, yr, params):
        return compensator_step(law, np.asarray(x, dtype=float), np.asarray(yr, dtype=float))[1]

    def output(t, x, yr, params):
        return compensator_step(law, np.asarray(x, dtype=float), np.asarray(yr, dtype=float))[0]

    return control.nlsys(update, output, inputs=reference_names(model),
                         outputs=list(model.input_names), states=states, dt=T, name=name)


def chain_system(compensator, plant, name="chain"):
    """Reference -> compensator -> Hammerstein plant, by ``control.interconnect``.

    Parameters
    ----------
    compensator : InverseMultiplicativeCompensator
        Its model's input names must be the plant's input names.
    plant : HammersteinPlant
        The actuator model.
    name : str
        System name.

    Returns
    -------
    control.InterconnectedSystem
        Inputs ``<out>_r`` [µm], outputs the plant outputs [µm]; states the
        compensator state then the plant state.

    Raises
    ------
    HysteresisError
        If the compensator's outputs do not match the plant's inputs.
    """
    if list(compensator.model.input_names) != list(plant.hysteresis.input_names):
        raise HysteresisError(
            f"compensator: expected the plant's inputs {plant.hysteresis.input_names}, found "
            f"{compensator.model.input_names}")
    comp = compensator_system(compensator, plant.sampling_period)
    systems = [comp, pi_system(plant.hysteresis, plant.sampling_period,
                               outputs=None if plant.is_static else
                               [f"{n}_h" for n in plant.hysteresis.output_names])]
    if not plant.is_static:
        systems.append(linear_system(plant))
    refs, outs = reference_names(compensator.model), list(plant.hysteresis.output_names)
    return control.interconnect(systems, inplist=refs, outlist=outs, inputs=refs, outputs=outs,
                                name=name)
