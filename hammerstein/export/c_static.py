"""C emitters of the static gains: ``U = K^-1 Yr`` of a classical PI
(:class:`~hammerstein.compensation.compensators.StaticGainCompensator`) and
``U = K^-1 (Yr - c)`` of a Preisach or generalised-PI model
(:class:`~hammerstein.compensation.mixed_compensators.LinearInverseCompensator`).
"""

from __future__ import annotations

import numpy as np

from hammerstein.export.c_base import (_vec, _check_model, _reference_transform, _limits_code,
                                       _reals_table, _model_text)


def _static_source(comp, model, precision, N, limits, T):
    m = model.n_inputs
    zero = "0.0" if precision == "double" else "0.0f"
    decls = [f"static const {N}_real {N}_K_inv[{N}_N_INPUTS] = {_vec(np.diag(comp.K_inv), precision)};  /* 1/K_ll [V/um] */"]
    tdecls, tcode = _reference_transform(model, precision, N)
    ldecls, lcode, _ = _limits_code(limits, m, T, precision, N)
    body = [f"""void {N}_init({N}_state *s)
{{
    int k;
    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {zero};
    s->diverged = 0;
}}
""", "\n".join([f"""int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS])
{{
    {N}_real r[{N}_N_OUTPUTS], u[{N}_N_INPUTS];
    int k, l, status = 0;
@REFERENCE_CHECK@
    for (l = 0; l < {N}_N_OUTPUTS; ++l) r[l] = reference[l];"""] + tcode + [
        f"    for (k = 0; k < {N}_N_INPUTS; ++k) u[k] = {N}_K_inv[k] * r[k];  /* U = K^-1 Yr */",
"@VOLTAGE_CHECK@"] + lcode + [f"""    return status;
}}
"""])]
    members = [f"    {N}_real u[{N}_N_INPUTS];   /* last voltages [V] */",
               "    int diverged;             /* latched divergence flag */"]
    return decls + tdecls + ldecls, body, members, [], m


def _linear_inverse_source(comp, model, precision, N, limits, T):
    """``U = K^-1 (Yr - c)`` of a LinearInverseCompensator (diagonal K)."""
    m = model.n_inputs
    decls = [_reals_table("K_inv", np.diag(comp.K_inv), precision, N, "  /* 1/K_ll [V/um] */"),
             _reals_table("centre", comp.centre, precision, N, "  /* c [um] */")]
    ldecls, lcode, _ = _limits_code(limits, m, T, precision, N)
    zero = "0.0f" if precision == "float" else "0.0"
    body = [f"""void {N}_init({N}_state *s)
{{
    int k;
    for (k = 0; k < {N}_N_INPUTS; ++k) s->u[k] = {zero};
    s->diverged = 0;
}}
""", "\n".join([f"""int {N}_step({N}_state *s, const {N}_real reference[{N}_N_OUTPUTS], {N}_real voltage[{N}_N_INPUTS])
{{
    {N}_real u[{N}_N_INPUTS];
    int k, status = 0;
@REFERENCE_CHECK@
    for (k = 0; k < {N}_N_INPUTS; ++k) u[k] = {N}_K_inv[k] * (reference[k] - {N}_centre[k]);""",
                    "@VOLTAGE_CHECK@"] + lcode + ["""    return status;
}
"""])]
    members = [f"    {N}_real u[{N}_N_INPUTS];   /* last voltages [V] */",
               "    int diverged;             /* latched divergence flag */"]
    return decls + ldecls, body, members, [], m


def _plan_static(comp):
    model = _check_model(comp.model)
    return ("static-gain", model, 0, "static gain U = K^-1 Yr (no hysteresis compensation)",
            lambda precision, N, limits, T: _static_source(comp, model, precision, N, limits, T))


def _plan_linear_inverse(comp):
    return ("static-gain", comp.model, 0,
            f"static gain U = K^-1 (Yr - c) of the {_model_text(comp.model)} (no hysteresis "
            f"compensation)",
            lambda precision, N, limits, T: _linear_inverse_source(comp, comp.model, precision, N,
                                                                   limits, T))
