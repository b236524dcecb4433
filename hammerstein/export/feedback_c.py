"""C99 code of a feedback loop's controller, with a compensator as feedforward.

:func:`export_feedback_c` turns a :class:`hammerstein.compensation.feedback.FeedbackLoop`
(its discrete controller with the reference filter, anti-windup and
amplifier limits) and, optionally, an exportable feedforward compensator
(:func:`hammerstein.export.c_code.export_c`, generated as ``NAME_ff.h`` /
``NAME_ff.c``) into ``NAME.h`` / ``NAME.c`` with one function::

    int NAME_step(NAME_state *s, const double reference[NAME_N_OUTPUTS],
                  const double measurement[NAME_N_OUTPUTS], double voltage[NAME_N_INPUTS]);

which computes, for one sample, what the compiled closed-loop kernel
computes (``hammerstein.simulation``): the feedforward ``f`` from the
reference, ``u = f + C_k x_c + D_k [r; m; f]``, the slew limit and range clip
of the amplifier (``voltage``), then ``x_c <- A_k x_c + B_k [r; m; f]`` with
back-calculation or clamping. A feedforward with ``NAME_ff_PREVIEW = P``
samples of look-ahead takes the reference P samples ahead: ``NAME_step``
then gives the controller the reference it received P samples before (kept
in the state; ``NAME_init`` fills it with the feedforward's rest output, so
that the first P samples ask the controller for no move), so pass the
reference ``P`` samples early, as to the compensator alone. The return value
has bit 1 (``NAME_STATUS_LIMIT``) set when the amplifier limited a voltage,
bit 2 (``NAME_STATUS_DIVERGED``) when the feedforward diverged, bit 4
(``NAME_STATUS_RANGE``) on a NaN or infinite reference or measurement, or one
beyond ten times the plant model's output range
(:func:`hammerstein.export.c_base.reference_bound`: a glitch), or a reference
beyond the feedforward model's range. A glitch reference skips the sample
(voltages held, state kept). A glitch measurement skips only the feedback:
the feedforward steps on with the reference (a skipped step would shift its
preview, and a ZPETC inverse would then see a jump of the reference), the
controller's state is kept and its part of the voltage, the last applied
voltage less the last feedforward, is held. Double precision.

``hammerstein export --closed-loop`` (:mod:`hammerstein.cli.export`) builds
the loop from a ``[feedback]`` table and writes these files.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from hammerstein.export.c_base import reference_bound
from hammerstein.export.c_code import (MARKER, STATUS_DIVERGED, STATUS_LIMIT, STATUS_RANGE,
                                       check_name, export_c, struct_ints, with_build_id)
from hammerstein.compensation.drive import rest_output
from hammerstein.exceptions import ExportError

__all__ = ["FeedbackCExport", "export_feedback_c"]


@dataclass
class FeedbackCExport:
    """The generated C code of a feedback controller (and its feedforward).

    Parameters
    ----------
    name : str
        The C prefix ``NAME``.
    header, source : str
        Text of ``NAME.h`` and ``NAME.c``.
    feedforward : hammerstein.export.c_code.CExport or None
        The feedforward's code (``NAME_ff``), or None.
    n_inputs, n_outputs : int
        Voltages m [V]; references and measurements p [µm].
    preview : int
        The feedforward's look-ahead [samples].
    sampling_period : float
        ``NAME_SAMPLING_PERIOD`` [s].
    input_names, output_names : list of str
        Names of the voltages and of the references (and measurements).
    description : str
        One line saying what was exported.
    measured : bool
        True: ``NAME_step`` takes the measurements too (the FMU wrapper's
        measurement inputs, :mod:`hammerstein.export.fmu`).
    rest_reference : list of float
        Where ``NAME_init`` leaves the feedforward [µm] (the model's output at
        0 V, the creep included where it inverts it), per output: the FMU's
        reference start values (a reference left there commands no step).
    rest_measurement : list of float
        The plant's output at 0 V, creep included [µm]: the FMU's measurement
        start values (what the sensor reads at rest).
    """

    name: str
    header: str
    source: str
    feedforward: object
    n_inputs: int
    n_outputs: int
    preview: int
    sampling_period: float = 0.0
    input_names: list = field(default_factory=list)
    output_names: list = field(default_factory=list)
    description: str = ""
    measured: bool = True
    rest_reference: list = field(default_factory=list)
    rest_measurement: list = field(default_factory=list)

    def files(self):
        """File name -> text of every generated file.

        Returns
        -------
        dict of str to str
            ``NAME.h``, ``NAME.c`` and, with a feedforward, ``NAME_ff.h``, ``NAME_ff.c``.
        """
        out = {f"{self.name}.h": self.header, f"{self.name}.c": self.source}
        if self.feedforward is not None:
            out.update(self.feedforward.files())
        return out


def _lit(x):
    x = float(x)
    if math.isinf(x):
        return "HUGE_VAL" if x > 0 else "-HUGE_VAL"
    if not math.isfinite(x):
        raise ExportError(f"a controller coefficient is not finite ({x!r})")
    return repr(x)


def _mat(a):
    a = np.atleast_2d(a)
    if a.size == 0:
        return "{{0.0}}"
    return "{" + ", ".join("{" + ", ".join(_lit(v) for v in row) + "}" for row in a) + "}"


def _vec(a):
    a = np.ravel(a)
    return "{" + (", ".join(_lit(v) for v in a) if a.size else "0.0") + "}"


def _describe(L):
    """The amplifier limits in words (range [V], slew [V per sample])."""
    def one(v):
        return "none" if not np.isfinite(v) else f"{v:g}"
    return "; ".join(f"[{one(a)}, {one(b)}] V, " +
                     ("no slew limit" if not np.isfinite(s) else f"slew {s:g} V per sample")
                     for a, b, s in zip(np.ravel(L.low), np.ravel(L.high), np.ravel(L.slew)))


def export_feedback_c(loop, name, feedforward=None, version=""):
    """Generate the C99 code of a loop's controller and, optionally, its feedforward.

    Parameters
    ----------
    loop : hammerstein.compensation.feedback.FeedbackLoop
        With a controller; its amplifier limits and anti-windup are exported.
        The sensor itself is not (the measurement comes from the hardware);
        its replica on the reference is part of the controller.
    name : str
        C prefix and file stem (:func:`hammerstein.export.c_code.check_name`).
    feedforward : object, optional
        A compensator :func:`hammerstein.export.c_code.export_c` accepts
        (classical PI models); exported as ``NAME_ff``.
    version : str
        Version written in the first line of the files.

    Returns
    -------
    FeedbackCExport

    Raises
    ------
    ExportError
        Without a controller, with a bad name, a feedforward the C export
        cannot take, or non-finite coefficients.

    Examples
    --------
    >>> import control
    >>> from hammerstein.compensation.feedback import FeedbackLoop, Sensor, controller_from_lti
    >>> from hammerstein.models.plant import HammersteinPlant
    >>> from hammerstein.models.preisach import MultivariableHysteresis
    >>> T = 5e-5
    >>> plant = HammersteinPlant(MultivariableHysteresis([[2.0]]), T)
    >>> ctrl = controller_from_lti(control.tf([100.0], [1.0, 0.0]), T)
    >>> code = export_feedback_c(FeedbackLoop(plant, ctrl, Sensor(delay=1)), "loop")
    >>> sorted(code.files())
    ['loop.c', 'loop.h']
    """
    N = check_name(name)
    c = loop.controller
    if c is None:
        raise ExportError("loop: no controller to export")
    L = loop.arrays
    T = float(loop.plant.sampling_period)
    # beyond ten times the plant model's output range a reference or a measurement is a glitch (a
    # wrong unit, an overflow): skipped like NaN, so that it winds no integrator up for good
    bound = _lit(reference_bound(loop.plant.hysteresis))
    m, p = loop.m, loop.p
    nc = c.n_states
    ff = None
    if feedforward is not None:
        ff = export_c(feedforward, f"{N}_ff", T, version=version)
        if ff.n_inputs != m or ff.n_outputs != p:
            raise ExportError(f"feedforward: {ff.n_outputs} references -> {ff.n_inputs} "
                              f"voltages, the loop has {p} -> {m}")
    P = 0 if ff is None else int(ff.preview)
    at_rest = [float(v) for v in rest_output(loop.plant.hysteresis, loop.plant.creep)]
    rest = (list(ff.rest_reference) if ff is not None and getattr(ff, "rest_reference", None)
            else at_rest)
    first = f"{MARKER} {version} (feedback controller) */".replace("  ", " ")
    # the struct the caller allocates, the feedforward's inside it: a user read the
    # feedforward's 824 B where sizeof(NAME_state) is 1024 B
    reals = max(nc, 1) + 2 * m + max(P, 1) * p + (ff.state_reals if ff else 0)
    ints = 1 + (struct_ints(ff.header) if ff else 0)
    header = f"""{first}
#ifndef {N}_H
#define {N}_H
{f'#include "{N}_ff.h"' if ff else ''}
#define {N}_N_INPUTS {m}
#define {N}_N_OUTPUTS {p}
#define {N}_N_STATES {nc}
#define {N}_PREVIEW {P}
#define {N}_SAMPLING_PERIOD {_lit(T)}
#define {N}_STATUS_LIMIT {STATUS_LIMIT}
#define {N}_STATUS_DIVERGED {STATUS_DIVERGED}
#define {N}_STATUS_RANGE {STATUS_RANGE}
#define {N}_STATE_BYTES sizeof({N}_state)
#define {N}_STATE_REALS {reals}
#define {N}_STATE_INTS {ints}
#define {N}_BUILD_ID @BUILD_ID@

/*
 * {N}_init(&s) once (at rest), then every sampling period {N}_SAMPLING_PERIOD:
 *     status = {N}_step(&s, reference, measurement, voltage);
 * reference[{N}_N_OUTPUTS]: the desired displacements [um]{f" of sample k + {N}_PREVIEW (the feedforward's look-ahead; the controller is given the reference of sample k, kept in the state)" if P else ""};
 * measurement[{N}_N_OUTPUTS]: the sensor's displacements of sample k [um];
 * voltage[{N}_N_INPUTS]: the amplifier inputs of sample k [V] (feedforward + controller,
 *   slew-limited and clipped to the amplifier range: {_describe(L)}).
 * Return value: 0 or the bits {N}_STATUS_LIMIT (the amplifier limits clamped a voltage;
 *   the anti-windup acts), {N}_STATUS_DIVERGED (the feedforward diverged: it holds its
 *   voltages until {N}_init), {N}_STATUS_RANGE (a NaN, infinite or glitch reference: the
 *   sample is skipped, voltages held, state kept; a NaN, infinite or glitch measurement:
 *   the feedforward steps on, the controller's state is kept and its part of the voltage
 *   held; or a reference beyond the feedforward model's range).
 */

/* Controller: {'; '.join(c.descriptions)} */
typedef double {N}_real;

typedef struct {{
    double xc[{max(nc, 1)}];             /* controller states */
    double a[{m}];                        /* last applied voltages [V] */
    double f[{m}];                        /* last feedforward voltages [V] */
    double rbuf[{max(P, 1)}][{p}];        /* references kept for the preview [um] */
    int rpos;
{f'    {N}_ff_state ff;' if ff else ''}
}} {N}_state;

void {N}_init({N}_state *s);
int {N}_step({N}_state *s, const double reference[{N}_N_OUTPUTS],
             const double measurement[{N}_N_OUTPUTS], double voltage[{N}_N_INPUTS]);
#endif
"""
    aw = int(L.aw)
    ff_call = (f"    status |= {N}_ff_step(&s->ff, reference, f) & ({STATUS_DIVERGED} | {STATUS_RANGE});\n"
               if ff else "")
    if P:
        rnow = (f"    for (l = 0; l < {p}; ++l) {{ rnow[l] = s->rbuf[s->rpos][l]; "
                f"s->rbuf[s->rpos][l] = reference[l]; }}\n"
                f"    s->rpos = (s->rpos + 1) % {P};\n")
    else:
        rnow = f"    for (l = 0; l < {p}; ++l) rnow[l] = reference[l];\n"
    source = f"""{first}
#include <math.h>
#include <string.h>
#include "{N}.h"

#if !defined({N}_BUILD_ID) || {N}_BUILD_ID != @BUILD_ID@
#error "{N}.h is not the header exported with this {N}.c (export writes the two together: use both of one run)"
#endif

static const double AK[{max(nc, 1)}][{max(nc, 1)}] = {_mat(c.A)};
static const double BK[{max(nc, 1)}][{2 * p + m}] = {_mat(c.B) if nc else '{{0.0}}'};
static const double CK[{m}][{max(nc, 1)}] = {_mat(c.C) if nc else '{{0.0}}'};
static const double DK[{m}][{2 * p + m}] = {_mat(c.D)};
static const double KAW[{max(nc, 1)}][{m}] = {_mat(L.Kaw) if nc else '{{0.0}}'};
static const int CLAMP[{max(nc, 1)}] = {{{', '.join(str(int(v)) for v in L.clamp) or '-1'}}};  /* channel clamping each integrator, -1 none */
static const double LOW[{m}] = {_vec(L.low)};
static const double HIGH[{m}] = {_vec(L.high)};
static const double SLEW[{m}] = {_vec(L.slew)};
static const double REST[{p}] = {_vec(rest)};

void {N}_init({N}_state *s)
{{
    int i, l;
    memset(s, 0, sizeof *s);
    /* the controller's reference until the first preview has passed: where the feedforward rests */
    for (i = 0; i < {max(P, 1)}; ++i)
        for (l = 0; l < {p}; ++l) s->rbuf[i][l] = REST[l];
    (void)i; (void)l;
{f'    {N}_ff_init(&s->ff);' if ff else ''}
}}

int {N}_step({N}_state *s, const double reference[{N}_N_OUTPUTS],
             const double measurement[{N}_N_OUTPUTS], double voltage[{N}_N_INPUTS])
{{
    double f[{m}], u[{m}], a[{m}], e[{2 * p + m}], rnow[{p}], xn[{max(nc, 1)}], sat[{m}];
    int status = 0, saturated = 0, blind = 0, i, j, k, l;
    for (l = 0; l < {p}; ++l)  /* a NaN, infinite or glitch reference: the sample is skipped */
        if (!isfinite(reference[l]) || fabs(reference[l]) > {bound}) {{
            for (k = 0; k < {m}; ++k) voltage[k] = s->a[k];
            return {STATUS_RANGE};
        }}
    for (l = 0; l < {p}; ++l)  /* a NaN, infinite or glitch measurement: no feedback this sample */
        if (!isfinite(measurement[l]) || fabs(measurement[l]) > {bound}) blind = 1;
    for (k = 0; k < {m}; ++k) f[k] = 0.0;
{ff_call}{rnow}    if (blind) {{  /* the feedforward keeps time; the controller's part is held, its state kept */
        for (k = 0; k < {m}; ++k) {{
            double v = f[k] + (s->a[k] - s->f[k]);
            if (v > s->a[k] + SLEW[k]) v = s->a[k] + SLEW[k];
            if (v < s->a[k] - SLEW[k]) v = s->a[k] - SLEW[k];
            if (v > HIGH[k]) v = HIGH[k];
            if (v < LOW[k]) v = LOW[k];
            s->f[k] = f[k];
            s->a[k] = v;
            voltage[k] = v;
        }}
        return status | {STATUS_RANGE};
    }}
    for (k = 0; k < {m}; ++k) s->f[k] = f[k];
    for (l = 0; l < {p}; ++l) {{ e[l] = rnow[l]; e[{p} + l] = measurement[l]; }}
    for (k = 0; k < {m}; ++k) e[{2 * p} + k] = f[k];
    for (k = 0; k < {m}; ++k) {{
        double acc = f[k], v, lo, hi;
        for (i = 0; i < {nc}; ++i) acc += CK[k][i] * s->xc[i];
        for (j = 0; j < {2 * p + m}; ++j) acc += DK[k][j] * e[j];
        u[k] = acc;
        v = acc;
        lo = s->a[k] - SLEW[k];
        hi = s->a[k] + SLEW[k];
        if (v > hi) v = hi;
        if (v < lo) v = lo;
        if (v > HIGH[k]) v = HIGH[k];
        if (v < LOW[k]) v = LOW[k];
        sat[k] = v != acc ? (acc > v ? 1.0 : -1.0) : 0.0;
        if (v != acc) saturated = 1;
        a[k] = v;
        s->a[k] = v;
    }}
    for (i = 0; i < {nc}; ++i) {{
        double acc = 0.0;
        for (j = 0; j < {nc}; ++j) acc += AK[i][j] * s->xc[j];
        for (j = 0; j < {2 * p + m}; ++j) acc += BK[i][j] * e[j];
        if ({aw} == 1) {{ for (k = 0; k < {m}; ++k) acc += KAW[i][k] * (a[k] - u[k]); }}
        else if ({aw} == 2 && saturated && CLAMP[i] >= 0 && sat[CLAMP[i]] != 0.0
                 && CK[CLAMP[i]][i] * (acc - s->xc[i]) * sat[CLAMP[i]] > 0.0)
            acc = s->xc[i];  /* conditional integration: not pushed further past the limit */
        xn[i] = acc;
    }}
    for (i = 0; i < {nc}; ++i) s->xc[i] = xn[i];
    for (k = 0; k < {m}; ++k) voltage[k] = a[k];
    (void)AK; (void)BK; (void)KAW; (void)CLAMP; (void)xn; (void)j; (void)sat;
    return status | saturated;
}}
"""
    header, source = with_build_id(header, source)      # as the feedforward's pair
    what = "; ".join(c.descriptions)
    description = (f"feedback controller ({what}) with "
                   + (ff.description if ff else "no feedforward"))
    return FeedbackCExport(N, header, source, ff, m, p, P, T,
                           list(loop.plant.hysteresis.input_names),
                           list(loop.plant.hysteresis.output_names), description,
                           rest_reference=rest, rest_measurement=at_rest)
