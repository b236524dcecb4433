"""C99 code of a feedforward compensator: one header and one source, no allocation.

:func:`export_c` turns a compensator object of :mod:`hammerstein.core` into
``NAME.h`` / ``NAME.c``: every parameter a ``static const`` table, the state a
``NAME_state`` struct the caller allocates, ``NAME_init`` and ``NAME_step``
(one sample). The C code computes what the Python compensator computes, in
the order of the compiled simulation kernels (``hammerstein.simulation``):

- reference transform ``S^-1(Yr - c)`` (model offset c, output map S of a
  modified PI; :meth:`MultivariablePI.gamma_reference`);
- for the Hammerstein compensator, the causal ZPETC inverse of the linear
  dynamics as the state space ``v = Cf xf + Df r``, ``xf <- Af xf + Bf r``
  (:meth:`ZPETCInverse.state_space`), ``NAME_PREVIEW`` samples ahead;
- the inverse multiplicative law (Theorem 4.1 of Rakotondrabe's paper,
  normalised by K): delay law with ``iterations`` fixed-point steps
  ``U <- U + K^-1 (v - Gamma(U; s(t-T)))`` on frozen play states, or the
  low-pass law of its Section 6; then the play operators (eq. (1)) move to U;
- or the per-axis analytic inverse PI of Kuhnen & Janocha (the shifted
  inverse PI then the inverse play of threshold r_1), or ``U = K^-1 Yr``;
- for a Preisach or generalised-PI model (``MultivariableHysteresis``), the
  exact per-sample inverse of
  :class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`
  step for step (``hammerstein.simulation._preisach_inverse``: the same bracket,
  Illinois iterations, tolerances, Gauss-Seidel sweeps and order of
  additions), its multiplicative law, or ``U = K^-1 (Yr - c)``; with a
  Hammerstein compensator, after the ZPETC inverse and the creep inverse as
  cascaded linear stages.

``EMITTERS`` is the one dispatch table: compensator class -> planner; one
module per emitted class (:mod:`~hammerstein.export.c_law`,
:mod:`~hammerstein.export.c_per_axis`, :mod:`~hammerstein.export.c_static`,
:mod:`~hammerstein.export.c_exact`, :mod:`~hammerstein.export.c_hammerstein`)
over the shared :mod:`~hammerstein.export.c_base`; this module assembles the
header and the source.
Every step returns a status: ``STATUS_LIMIT``, ``STATUS_DIVERGED``,
``STATUS_RANGE`` (NaN, inf or out-of-range references, on every kind).

Optional amplifier limits (range [V], slew rate [V/s]) clamp U inside
``NAME_step`` after the law, as hammerstein's amplifier model does
(``hammerstein.models.amplifier`` where present: range clip, then
``amp += clip(x - amp, -S T, S T)``); the law keeps its own voltages, as
the Python compensator does.
"""

from __future__ import annotations

import math
import hashlib
import re

import numpy as np

from hammerstein.compensation.drive import compensator_rest
from hammerstein.compensation.compensators import (InverseMultiplicativeCompensator,
                                                   PerAxisInverseCompensator,
                                                   StaticGainCompensator)
from hammerstein.compensation.hammerstein_compensator import HammersteinCompensator
from hammerstein.compensation.mixed_compensators import LinearInverseCompensator
from hammerstein.compensation.preisach_inverse import PreisachInverseCompensator
from hammerstein.exceptions import ExportError
from hammerstein.models.hysteresis import MultivariablePI
from hammerstein.models.preisach import MultivariableHysteresis
from hammerstein.export.c_base import (MARKER, STATUS_LIMIT, STATUS_DIVERGED, STATUS_RANGE,
                                       check_name, AmplifierLimits, CExport, _limits_code,
                                       _describe_limits, _status_checks)
from hammerstein.export.c_exact import _plan_preisach_inverse
from hammerstein.export.c_hammerstein import _plan_hammerstein
from hammerstein.export.c_law import _plan_law
from hammerstein.export.c_per_axis import _plan_per_axis
from hammerstein.export.c_static import _plan_linear_inverse, _plan_static

__all__ = ["AmplifierLimits", "CExport", "export_c", "check_name", "MARKER", "STATUS_LIMIT",
           "STATUS_DIVERGED", "STATUS_RANGE", "EMITTERS", "with_build_id", "struct_ints"]


def with_build_id(header, source):
    """A header and source pair with its fingerprint in place of ``@BUILD_ID@``.

    The source refuses to compile with another run's header. The fingerprint is over
    their code, not their comments: the same code written by the library and by the
    command line, whose comments name the command and the limits' source, gets one id.

    Parameters
    ----------
    header, source : str
        The texts of ``NAME.h`` and ``NAME.c``, each with ``@BUILD_ID@`` placeholders.

    Returns
    -------
    header, source : str
        With ``0x<8 hex digits of SHA-256>UL`` in place of each placeholder.
    """
    code = "\n".join(line for t in (header, source) for line in t.splitlines()
                     if not line.lstrip().startswith(("/*", "*", "//")))
    build_id = "0x" + hashlib.sha256(code.encode()).hexdigest()[:8] + "UL"
    return tuple(t.replace("@BUILD_ID@", build_id) for t in (header, source))


def struct_ints(header):
    r"""The ints of the state struct of an exported header.

    Parameters
    ----------
    header : str
        The text of an exported ``NAME.h``.

    Returns
    -------
    int
        The ``int`` members of its ``NAME_state`` struct, ``int name[n];`` counting n
        (0 without a struct).

    Examples
    --------
    >>> struct_ints("typedef struct {\n    double u[2];\n    int k;\n    int m[3];\n} a_state;")
    4
    """
    body = re.search(r"typedef struct \{\n(.*?)\n\} \w+_state;", header, re.S)
    if body is None:
        return 0
    return sum(int(n) if n else 1
               for n in re.findall(r"^\s*int \w+(?:\[(\d+)\])?;", body.group(1), re.M))


#: The dispatch table of the C export: compensator class -> planner. A planner returns
#: ``(kind, model, preview, description, build)``, ``build(precision, N, limits, T)`` the C
#: declarations, functions, state members, defines and state size. A new compensator class
#: is one entry here (first matching class wins; subclasses before their bases).
EMITTERS = {
    HammersteinCompensator: _plan_hammerstein,
    InverseMultiplicativeCompensator: _plan_law,
    PerAxisInverseCompensator: _plan_per_axis,
    StaticGainCompensator: _plan_static,
    PreisachInverseCompensator: _plan_preisach_inverse,
    LinearInverseCompensator: _plan_linear_inverse,
}


#: The model types whose components the C emitters know (a model of another registered
#: class, e.g. a new one, is refused here by name: its compensator raised AttributeError
#: deep in an emitter).
C_MODEL_TYPES = (MultivariablePI, MultivariableHysteresis)


def _plan(compensator):
    """(kind, model, preview, description, build) of a compensator, or ExportError."""
    model = getattr(compensator, "model", None)
    if model is not None and not isinstance(model, C_MODEL_TYPES):
        raise ExportError(f"model: a {type(model).__name__} cannot be exported to C: the C emitters "
                          f"know the classical PI, Preisach, generalised-PI and mixed models "
                          f"(hammerstein/export/c_*.py); a new model class needs its emitter there")
    for cls, planner in EMITTERS.items():
        if isinstance(compensator, cls):
            return planner(compensator)
    raise ExportError(f"compensator: a {type(compensator).__name__} cannot be exported to C (the "
                      f"exportable classes: {', '.join(c.__name__ for c in EMITTERS)})")


def export_c(compensator, name, sampling_period, precision="double", limits=None, version="",
             source_note=""):
    """Generate the C99 code (``NAME.h``, ``NAME.c``) of a compensator.

    Parameters
    ----------
    compensator : object
        An instance of a class of :data:`EMITTERS`: an
        :class:`~hammerstein.compensation.compensators.InverseMultiplicativeCompensator`
        (multivariable or diagonal, delay or low-pass feedback), a
        :class:`~hammerstein.compensation.compensators.PerAxisInverseCompensator` or a
        :class:`~hammerstein.compensation.compensators.StaticGainCompensator` of a
        classical PI (linear components, offset and output map included); a
        :class:`~hammerstein.compensation.preisach_inverse.PreisachInverseCompensator`
        (exact inverse or its law) or a
        :class:`~hammerstein.compensation.mixed_compensators.LinearInverseCompensator`
        of a Preisach or generalised-PI model; or a
        :class:`~hammerstein.compensation.hammerstein_compensator.HammersteinCompensator`
        with ``inversion='zpetc'`` (with or without creep) over any of them.
    name : str
        C prefix and file stem (:func:`check_name`).
    sampling_period : float
        ``NAME_SAMPLING_PERIOD`` [s], > 0.
    precision : {'double', 'float'}
        Type ``NAME_real`` of the tables, state and arithmetic; the
        interface too (``NAME_real`` references and voltages: a float
        export has no double anywhere).
    limits : AmplifierLimits, optional
        Amplifier range and slew rate applied inside ``NAME_step``.
    version : str
        Version written in the generated files' first line.
    source_note : str
        What the compensator was built from (one line, in the header).

    Returns
    -------
    CExport

    Raises
    ------
    ExportError
        A compensator kind, model class, inversion or option that cannot be
        exported (the message names it), a bad name, precision or sampling
        period, or non-finite parameters.

    Examples
    --------
    >>> from hammerstein import export_c
    >>> from hammerstein import MultivariablePI, PrandtlIshlinskii, InverseMultiplicativeCompensator
    >>> model = MultivariablePI([[PrandtlIshlinskii([0.0, 1.0], [1.0, 0.5])]], input_amplitude=[5.0])
    >>> code = export_c(InverseMultiplicativeCompensator(model), "piezo", 5e-5)
    >>> sorted(code.files())
    ['piezo.c', 'piezo.h']
    >>> for line in code.header.splitlines():
    ...     if line.startswith(("#define piezo_N_IN", "#define piezo_PRE", "int piezo_step")):
    ...         print(line)
    #define piezo_N_INPUTS 1
    #define piezo_PREVIEW 0
    int piezo_step(piezo_state *s, const piezo_real reference[piezo_N_OUTPUTS], piezo_real voltage[piezo_N_INPUTS]);
    """
    N = check_name(name)
    if precision not in ("double", "float"):
        raise ExportError(f"precision: expected 'double' or 'float', found {precision!r}")
    T = sampling_period
    if isinstance(T, bool) or not isinstance(T, (int, float, np.floating)) or not (math.isfinite(T) and T > 0):
        raise ExportError(f"sampling_period: expected a positive time [s], found {T!r}")
    T = float(T)
    kind, model, P, description, build = _plan(compensator)
    decls, body, members, defines, reals = build(precision, N, limits, T)
    sdecls, body = _status_checks(body, model, precision, N, limits)
    decls = decls + sdecls
    if limits is not None:          # the amplifier's state, its rest and the held voltage
        _, _, amp_init = _limits_code(limits, model.n_inputs, T, precision, N)
        body = [b.replace("    s->diverged = 0;\n", "\n".join(amp_init) + "\n    s->diverged = 0;\n")
                for b in body]
        members.insert(len(members) - 1,
                       f"    {N}_real amp[{N}_N_INPUTS];    /* last voltages delivered by the amplifier [V] */")
        reals += model.n_inputs
    m, p = model.n_inputs, model.n_outputs
    first = f"{MARKER} {version}: {description}. Do not edit: regenerate. */".replace("  ", " ")
    limits_text = _describe_limits(limits, m)
    n_ints = sum(int(re.match(r"int \w+(?:\[(\d+)\])?", mb.lstrip()).group(1) or 1)
                 for mb in members if mb.lstrip().startswith("int "))
    ins = ", ".join(f"{i}: {nm} [V]" for i, nm in enumerate(model.input_names))
    outs = ", ".join(f"{i}: {nm} [um]" for i, nm in enumerate(model.output_names))
    guard = f"{N.upper()}_H_INCLUDED"
    header = f"""{first}
#ifndef {guard}
#define {guard}

/*
 * {N}: {description}.
 * {source_note}
 *
 * Usage (C99, no allocation, only the C standard library):
 *
 *     {N}_state s;                 (static or automatic: {reals} reals and {n_ints} int(s))
 *     {N}_init(&s);                 (start at rest: 0 V, demagnetised plays)
 *     every sampling period {N}_SAMPLING_PERIOD:
 *         status = {N}_step(&s, reference, voltage);
 *
 * reference[{N}_N_OUTPUTS]: the desired displacements [um] of sample k + {N}_PREVIEW
 *   ({outs});
 * voltage[{N}_N_INPUTS]: the amplifier inputs [V] of sample k ({ins}).
 * The first {N}_PREVIEW calls return the rest voltages (0 V) while the preview fills.
 * Return value: 0, or the bits
 *   {N}_STATUS_LIMIT    ({STATUS_LIMIT}): an amplifier limit clamped a voltage this sample (by more
 *       than rounding, {N}_u_tol* in the .c);
 *   {N}_STATUS_DIVERGED ({STATUS_DIVERGED}): the law diverged (a non-finite voltage or one beyond
 *       the divergence bound): the voltages are held at their last valid values, and every
 *       later call returns this bit, until {N}_init.
 *   {N}_STATUS_RANGE    ({STATUS_RANGE}): the reference is not finite (NaN, inf: the sample is
 *       skipped, the voltages held and the state kept) or out of the model's range (it asks
 *       for voltages beyond its input range, {N}_u_low..{N}_u_high where present; the exact
 *       inverses stop at their bound).
 * Amplifier limits: {limits_text}.
 * One state per actuator; {N}_step is reentrant on distinct states. Copying the struct
 * (memcpy) saves and restores the compensator exactly.
 */

#ifdef __cplusplus
extern "C" {{
#endif

#define {N}_N_INPUTS {m}
#define {N}_N_OUTPUTS {p}
#define {N}_PREVIEW {P}
#define {N}_SAMPLING_PERIOD {T!r}{'f' if precision == 'float' else ''}
#define {N}_STATUS_LIMIT {STATUS_LIMIT}
#define {N}_STATUS_DIVERGED {STATUS_DIVERGED}
#define {N}_STATUS_RANGE {STATUS_RANGE}
#define {N}_STATE_BYTES sizeof({N}_state)
#define {N}_STATE_REALS {reals}
#define {N}_BUILD_ID @BUILD_ID@
{chr(10).join(defines)}

typedef {precision} {N}_real;

typedef struct {{
{chr(10).join(members)}
}} {N}_state;

void {N}_init({N}_state *s);
int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS]);

#ifdef __cplusplus
}}
#endif

#endif /* {guard} */
"""
    source = f"""{first}
#include <math.h>
#include "{N}.h"

#if !defined({N}_BUILD_ID) || {N}_BUILD_ID != @BUILD_ID@
#error "{N}.h is not the header exported with this {N}.c (export writes the two together: use both of one run)"
#endif

{chr(10).join(decls)}

{chr(10).join(body)}"""
    header, source = with_build_id(header, source)
    try:       # where NAME_init leaves the compensator: the model's output at 0 V
        rest = [float(v) for v in compensator_rest(model, compensator)]
    except Exception:        # noqa: BLE001 - a model without simulate: the zeros of before
        rest = [0.0] * p
    return CExport(name=N, header=header, source=source, n_inputs=m, n_outputs=p, preview=P,
                   sampling_period=T, kind=kind, precision=precision,
                   input_names=list(model.input_names), output_names=list(model.output_names),
                   state_reals=int(reals), description=description, rest_reference=rest)
