"""A compensator table in words, for figure titles and report lines (behind :mod:`hammerstein.report.scenario`).

Used by the scenario report and by the sweep sections (:mod:`hammerstein.report.sweeps`),
which the scenario report imports: the words live here, below both.
"""

from __future__ import annotations

from hammerstein.signals.references import words_number as _num

__all__: list[str] = []


def _records_summary(ident):
    """An ``identify = { records = "excitation", ... }`` table in words: what it asked for
    (the class ``auto`` keeps is chosen when the scenario runs)."""
    bits = [f"model {ident.get('model', 'auto')}"]
    if ident.get("creep"):
        bits.append("with creep")
    if ident.get("range") is not None:
        bits.append(f"range [{ident['range'][0]:g}, {ident['range'][1]:g}] V")
    elif ident.get("amplitude") is not None:
        amp = ident["amplitude"]
        bits.append(f"{', '.join(f'{a:g}' for a in amp) if isinstance(amp, list) else f'{amp:g}'} V")
    if ident.get("slew_rate") is not None:
        bits.append(f"slew rate {ident['slew_rate']:g} V/s")
    return "model identified from the excitation records (" + ", ".join(bits) + ")"


def _identify_summary(ident):
    if not ident:
        return "model identified on the plant"
    if ident.get("records") == "excitation":
        return _records_summary(ident)
    if ident.get("records") == "files":
        n = sum(len(ident.get(k) or []) for k in ("hysteresis_records", "dynamics_records",
                                                   "creep_records"))
        kinds = ["hysteresis"] + [w for w, k in (("dynamics", "dynamics_records"),
                                                 ("creep", "creep_records")) if ident.get(k)]
        return (f"model identified from {n} measured record file(s) ({', '.join(kinds)}; "
                f"{ident.get('model', 'auto')} class)")
    at = _num(ident["frequency"], "Hz")
    if "amplitude" in ident:
        at += f", {_num(ident['amplitude'], 'V')}"
    if ident.get("model", "classical") != "classical":   # not the classical PI's hysterons
        cls = "the class auto chose" if ident["model"] == "auto" else f"{ident['model']} class"
        return f"model identified at {at} ({cls})"
    bits = [f"{ident['n_hysterons']} hysterons"] if "n_hysterons" in ident else []
    bits += [ident["method"]] if "method" in ident else []
    return f"model identified at {at}" + (f" ({', '.join(bits)})" if bits else "")


def _model_summary(c):
    model = c.get("model", "plant")
    if model == "identified":
        i = c.get("identify", {})
        if i.get("records") in ("excitation", "files"):
            return _identify_summary(i)
        extra = ", ".join(str(i[k]) for k in ("method", "bounds") if k in i)
        return f"model identified at {i.get('frequency', 0):g} Hz" + (f" ({extra})" if extra else "")
    if model == "plant":
        return "the plant's own model"
    return f"model {model}"


def _compensator_title(spec):
    """A compensator in words, e.g. 'multivariable compensator, model identified
    at 100 Hz (least-squares, monotone), midpoint gain'."""
    c = spec.compensator_spec
    words = f"{c.get('kind', 'multivariable')} compensator, {_model_summary(c)}"
    gain = c.get("gain")
    if gain is not None:
        words += f", {gain if isinstance(gain, str) else 'matrix'} gain"
    if c.get("iterations", 1) != 1:
        words += f", {c['iterations']} iterations"
    return words
