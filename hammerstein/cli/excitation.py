"""``hammerstein excitation``: write the excitation files to play on an actuator.

Per input (the others held at 0): ``hysteresis-<input>.csv`` (a slow sine of
decreasing amplitude, 100/80/60/40/20 %, two periods each; with ``--reversals``,
then first-order reversal curves from both ends of the range, e.g. turning back
at -80 to 80 % in steps of 20 % with ``--reversals standard``),
``multisine-<input>.csv``
and ``multisine-<input>-validation.csv`` (random-phase multisines, 10 Hz to half
the Nyquist frequency, about 2.5 kHz above 20 kHz, at 80 % of the amplitude, independent phases; the
second is held out to choose the order of the dynamics) and ``creep-<input>.csv``
(a voltage staircase, 2 s per step); ``demagnetise.csv`` (every input at
once, a sine decaying from the amplitude to 0 V at twice the sine frequency,
then 1 s at rest), played before each file and before every drive; each file
holds the time column ``t`` [s] and every input column [V]
(:mod:`hammerstein.signals.excitation`). A ``README.md`` says what to measure
and how to give the records back to ``hammerstein identify``.

Files: the directory is created if missing; an existing file is replaced
only when this command wrote it (listed in the directory's
``.hammerstein-excitation``), otherwise nothing is written and the command
names ``--force`` (exit 2). Each file goes through a temporary file and a
rename. Exit status: 0 on success, 1 when a file cannot be written, 2 on a
usage error.
"""

from __future__ import annotations

import contextlib
import hashlib
import sys
from pathlib import Path

import numpy as np

from hammerstein.cli._common import integer_type, number_type, out_dir_problem, print_err
from hammerstein.signals.excitation import (LEVELS, REVERSALS, STAIRCASE_LEVELS,
                                            UNIPOLAR_STAIRCASE, ExcitationRecord,
                                            _slew_limited_multisine, default_f_max,
                                            demagnetising_record, excitation_set, multisine,
                                            peak_slew)
from hammerstein.core.files import (FileLimitError, all_or_nothing, bounded_read_text, escape,
                                    file_digest, locked, name_problem, removed_if_failed,
                                    safe_write)
from hammerstein.core.numbers import MAX_MAGNITUDE, number_problem, plausibility_problem
from hammerstein.identification.defaults import CREEP_T_MIN

__all__ = ["add_parser", "MANIFEST", "readme_text"]

#: The file listing what this command wrote in a directory (one name per line).
MANIFEST = ".hammerstein-excitation"
#: The most inputs one excitation writes records for (the files grow with the square of it:
#: one set of records per input, each holding every input's column).
MAX_INPUTS = 16
_MANIFEST_HEAD = "# written by hammerstein excitation; files it may replace"


def add_parser(subparsers):
    """Register the ``excitation`` subcommand (sets ``handler``).

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        The ``add_subparsers()`` object of the ``hammerstein`` parser.
    """
    p = subparsers.add_parser(
        "excitation", help="write excitation files to play on an actuator before identifying it",
        description="Write, per input, the excitation records that 'hammerstein identify' "
                    "needs: a decreasing-amplitude sine (hysteresis and minor loops; "
                    "--reversals adds first-order reversal curves), two "
                    "random-phase multisines (dynamics; the second held out) and a voltage "
                    "staircase (creep), each a CSV file with the time and every input column, "
                    "plus a README of what to measure.")
    p.add_argument("--inputs", required=True, metavar="NAMES",
                   help="input names, comma-separated (the column names), e.g. ux,uy")
    p.add_argument("--amplitude", metavar="V|V1,V2,...",
                   help="full amplitude [V], one for all inputs or one per input: the records "
                        "span [-V, V] (or give --range)")
    p.add_argument("--range", metavar="LOW,HIGH", nargs="+",
                   help="the amplifier's range [V] instead of --amplitude, e.g. 0,150 for a "
                        "unipolar stack or -20,120, one for every input or one per input in "
                        "the order of --inputs (-10,10 0,100 for a bipolar x and a unipolar "
                        "y): the records are played around its middle, from and back to its "
                        "value nearest 0 V (the amplifier's rest), and never leave it")
    p.add_argument("--sampling-period", required=True, type=_SECONDS, metavar="S",
                   help="sampling period of the hardware [s], e.g. 5e-5")
    p.add_argument("--out", required=True, metavar="DIR", help="directory to write")
    p.add_argument("--sine-frequency", type=_HERTZ, default=1.0, metavar="HZ",
                   help="frequency of the decreasing-amplitude sine (default 1 Hz)")
    p.add_argument("--f-min", type=_HERTZ, default=10.0, metavar="HZ",
                   help="lowest multisine frequency (default 10 Hz; also its resolution)")
    p.add_argument("--f-max", type=_HERTZ, metavar="HZ",
                   help="highest multisine frequency (default half the Nyquist frequency at 20 kHz "
                        "and below, about 2.5 kHz above: identify fits the bending modes near "
                        "10 kHz)")
    p.add_argument("--periods", type=integer_type(1), default=4, metavar="N",
                   help="periods per multisine record (default 4)")
    p.add_argument("--hold", type=_SECONDS, default=2.0, metavar="S",
                   help="duration of each creep step (default 2 s)")
    p.add_argument("--seed", type=integer_type(0), default=0, help="seed of the multisine phases (default 0)")
    p.add_argument("--reversals", default="none", metavar="F1,F2,...|standard|none",
                   help="first-order reversal curves played after the decreasing sine, turning "
                        "back at these fractions of the amplitude in (-1, 1); standard: "
                        + ",".join(f"{b:g}" for b in REVERSALS) + " (off-centre loops of a "
                        "Preisach-like actuator, e.g. rasters; docs/identification.md); "
                        "default none: the decreasing sine alone")
    p.add_argument("--slew-rate", type=_SLEW, metavar="V/S",
                   help="the amplifier's slew rate [V/s]: every record then steps no faster "
                        "(the multisines start at their sample nearest 0 V and are scaled down "
                        "as far as needed, the staircase's steps become ramps); default none: "
                        "the README gives each record's largest slew to check against yours")
    p.add_argument("--force", action="store_true",
                   help="replace files in DIR that this command did not write")
    p.set_defaults(handler=_handler)


_SECONDS = number_type(0, low_open=True, unit="s")
_HERTZ = number_type(0, low_open=True, unit="Hz")
_SLEW = number_type(0, low_open=True, unit="V/s")


class _Usage(ValueError):
    """A usage error (exit 2)."""


def _amplitudes(text, m):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise _Usage(f"--amplitude: expected a number [V] or one per input, found {text!r}") from None
    if len(values) not in (1, m):
        raise _Usage(f"--amplitude: expected 1 or {m} values (one per input), found {len(values)}")
    bad = [v for v in values if number_problem(v) or not 0 < v <= MAX_MAGNITUDE]
    if bad:
        raise _Usage(f"--amplitude: expected positive amplitudes [V] up to {MAX_MAGNITUDE:.0e}, "
                     f"found {escape(repr(text), 60)}")
    for v in values:        # valid, but said: a unit slip (mV for V) would break the actuator
        problem = plausibility_problem(v, "V", "--amplitude")
        if problem:
            print_err(f"warning: hammerstein excitation: {problem}")
            break
    return np.broadcast_to(np.array(values), (m,)).copy()


#: The parameters of :func:`~hammerstein.signals.excitation.excitation_set` and their options.
_OPTIONS = {"f_min, periods": "--f-min, --periods", "frequency": "--sine-frequency",
            "sampling_period": "--sampling-period", "f_min, f_max": "--f-min, --f-max",
            "f_min": "--f-min", "f_max": "--f-max", "hold": "--hold", "periods": "--periods",
            "amplitude": "--amplitude", "reversals": "--reversals", "slew_rate": "--slew-rate"}


def _amplitude_and_centre(args, m):
    """(amplitude (m,), centre (m,)) [V] from ``--amplitude`` or ``--range``."""
    if (args.amplitude is None) == (args.range is None):
        raise _Usage("--amplitude, --range: expected exactly one of them (the records' "
                     "amplitude around 0 V, or the amplifier's range LOW,HIGH)")
    if args.amplitude is not None:
        return _amplitudes(args.amplitude, m), np.zeros(m)
    given = args.range if isinstance(args.range, list) else [args.range]
    items = [t for g in given for t in g.split(";") if t.strip()]
    if len(items) not in (1, m):
        raise _Usage(f"--range: expected one LOW,HIGH for every input or one per input ({m}: "
                     f"{', '.join(args.inputs.split(','))}), found {len(items)}: "
                     f"{escape(' '.join(given), 60)}")
    lows, highs = [], []
    for item in items:
        try:
            low, high = (float(v) for v in item.split(","))
        except ValueError:
            raise _Usage(f"--range: expected two numbers LOW,HIGH [V], found "
                         f"{escape(repr(item), 60)}") from None
        if number_problem(low) or number_problem(high) or not low < high \
                or max(abs(low), abs(high)) > MAX_MAGNITUDE:
            raise _Usage(f"--range: expected finite LOW < HIGH [V] up to {MAX_MAGNITUDE:.0e}, "
                         f"found {escape(repr(item), 60)}")
        lows.append(low)
        highs.append(high)
    lows, highs = np.resize(np.array(lows), m), np.resize(np.array(highs), m)
    amplitude = _amplitudes(",".join(repr(float(v)) for v in 0.5 * (highs - lows)), m)
    return amplitude, 0.5 * (lows + highs)


def _reversals(text):
    if text.strip().lower() == "none":
        return ()
    if text.strip().lower() == "standard":
        return REVERSALS
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise _Usage(f"--reversals: expected fractions in (-1, 1), comma-separated, standard "
                     f"or none; "
                     f"found {escape(repr(text), 60)}") from None
    if any(number_problem(v) or not -1 < v < 1 for v in values) or len(set(values)) != len(values):
        raise _Usage(f"--reversals: expected distinct fractions in (-1, 1), found "
                     f"{escape(repr(text), 60)}")
    return values


def _option_names(message):
    """An excitation_set message with its leading parameter named as the command's option."""
    for name, option in _OPTIONS.items():
        if message.startswith(name + ":"):
            return option + message[len(name):]
    return message


def _owned(directory):
    """Names this command wrote in ``directory`` and the SHA-256 of what it wrote (from its
    manifest): ``{name: hex digest}``, the digest None in a manifest that did not record it."""
    path = directory / MANIFEST
    if not path.is_file():
        return {}
    try:
        text = bounded_read_text(path, "toml", "excitation manifest")
    except (OSError, FileLimitError, UnicodeDecodeError):
        return {}
    lines = text.splitlines()
    if not lines or lines[0] != _MANIFEST_HEAD:
        return {}
    owned = {}
    for ln in lines[1:]:
        name, _, digest = ln.strip().partition("\t")
        if name:
            owned[name] = digest.strip() or None
    return owned


def readme_text(records, names, amplitude, sampling_period, reversals=(), centre=None,
                band=None):
    """The README written with the excitation files: what to measure, how to identify.

    Parameters
    ----------
    records : list of hammerstein.signals.excitation.ExcitationRecord
        The records written.
    names : sequence of str
        Input names.
    amplitude : numpy.ndarray, shape (m,)
        Full amplitude per input [V].
    sampling_period : float
        T [s].
    reversals : sequence of float
        Reversal points of the first-order reversal curves in the hysteresis
        records (fractions of the amplitude; empty: none).
    centre : numpy.ndarray, shape (m,), optional
        The middle of each input's range [V] (``--range``); None or zeros: ``[-A, A]``.
    band : dict, optional
        What a slew rate did to the multisines' band (``band_summary``): the README then
        says how far the band reaches and what ``--f-max`` does.

    Returns
    -------
    str
        Markdown text.
    """
    T = sampling_period
    by_kind = {}
    for r in records:
        by_kind.setdefault(r.kind, []).append(f"{r.name}.csv")
    spans = {}                   # per kind, the files' durations: an input whose range is
    for r in records:            # off 0 V ramps from rest and back, and its files are longer
        spans.setdefault(r.kind, []).append(r.time.size * T)
    dur = {k: (f"{min(v):g} s" if np.isclose(min(v), max(v), rtol=1e-9, atol=0.0)
               else f"{min(v):g}-{max(v):g} s") for k, v in spans.items()}
    tops = sorted({r.f_max for r in records if r.kind == "multisine" and r.f_max is not None})
    reach = (f" up to {tops[-1]:.4g} Hz" if len(tops) == 1
             else f" up to {tops[0]:.4g}-{tops[-1]:.4g} Hz" if tops else "")
    centred = centre is not None and np.any(centre)
    if centred:
        rest = np.clip(0.0, centre - amplitude, centre + amplitude)
        where = (f"range {', '.join(f'[{c - a:g}, {c + a:g}]' for c, a in zip(centre, amplitude))} V: "
                 f"every record is played around the middle of the range "
                 f"({', '.join(f'{c:g}' for c in centre)} V), from the amplifier's rest "
                 f"({', '.join(f'{r:g}' for r in rest)} V, the range's value nearest 0 V) and "
                 f"back, by half-cosine ramps")
        idle = "at rest"
    else:
        where = f"amplitude {', '.join(f'{a:g}' for a in amplitude)} V"
        idle = "at 0 V"
    lines = [
        "# Excitation records (written by `hammerstein excitation`)", "",
        f"Inputs {', '.join(names)}, {where}, "
        f"sampling period {T:g} s ({1 / T:g} Hz). Each file holds the time `t` [s] and every "
        f"input column [V]; one input is driven, the others stay {idle} (`demagnetise.csv`: "
        f"every input).", "",
        "| files | what for | signal | duration |", "|---|---|---|---|",
        f"| {', '.join(by_kind['hysteresis'])} | hysteresis, its minor loops"
        f"{' and off-centre reversals' if len(reversals) else ''} | sine, "
        f"{', '.join(f'{100 * a:.0f}' for a in LEVELS)} % of the amplitude, two periods each"
        + (f"; then first-order reversal curves: for each of "
           f"{', '.join(f'{100 * b:.0f}' for b in reversals)} %, from the amplitude down to it "
           f"and back, then from minus the amplitude up to minus it and back (half-cosine "
           f"moves at three times the sine's largest slew)" if len(reversals) else "")
        + f" | {dur['hysteresis']} |",
        f"| {', '.join(by_kind['multisine'])} | linear dynamics (estimation) | random-phase "
        f"multisine{reach} at {_multisine_share(records)} of the amplitude | "
        f"{dur['multisine']} |",
        f"| {', '.join(by_kind['multisine-validation'])} | linear dynamics (held out: chooses "
        f"the order) | the same band, other phases | {dur['multisine-validation']} |",
        f"| {', '.join(by_kind['creep'])} | creep | staircase "
        + (f"from the amplifier's rest to the range's far end and back, "
           f"{', '.join(f'{100 * a:.0f}' for a in (0.0, *UNIPOLAR_STAIRCASE))} % of the way"
           if centred else
           f"{', '.join(f'{100 * a:.0f}' for a in (0.0, *STAIRCASE_LEVELS))} % of the amplitude")
        + f" | {dur['creep']} |",
        *([f"| {', '.join(by_kind['demagnetise'])} | the demagnetised state, before every file "
           f"and every drive | every input at once: a sine decaying from the amplitude to "
           f"{'the middle of the range, then back to rest and 1 s there' if centred else '0 V, then 1 s at 0 V'}"
           f" | {dur['demagnetise']} |"] if "demagnetise" in by_kind else []),
        "", *_slew_lines(records, names, T, band), "## What to measure", "",
        *(["0. Before each file below, and later before every drive you play (`hammerstein "
           "compensate`, `learn`), play `demagnetise.csv` (nothing to record). A model starts "
           "from the demagnetised state; an input left idle in a record, or a drive, would "
           "otherwise start from whatever hysteresis memory the previous motion left, an "
           "offset the model cannot know (measured on a simulated actuator that rested in "
           "another state: about 1 µm on every later drive that moves both inputs)."]
          if "demagnetise" in by_kind else []),
        "1. Play each file from rest (all inputs at 0 V for at least a second before) at "
        "exactly this sampling period, and record every displacement (e.g. `x`, `y` in µm) "
        "synchronously, one sample per row.",
        "2. Add the displacements as new columns to a copy of the file (keep `t` and the input "
        "columns); a sensor offset is fine (it is identified). Note the sensor's noise and "
        "bandwidth.",
        "3. Identify (the multisine files are the dynamics records, the validation ones "
        "held out to choose the order; the staircase files record the creep, the slow drift "
        "after each step):", "",
        "```",
        f"hammerstein identify {' '.join(by_kind['hysteresis'])} --inputs {','.join(names)} "
        f"--outputs {','.join(_output_names(len(names)))} --time t --dynamics --dynamics-records "
        f"{' '.join(by_kind['multisine'] + by_kind['multisine-validation'])} "
        f"--creep-records {' '.join(by_kind['creep'])} "
        f"--out preset.toml --metrics fit.csv --plot fit.png",
        "```", "",
        f"`--outputs` names your displacement columns, in the order of the inputs that drive "
        f"them ({', '.join(_output_names(len(names)))} are the example's names).", "",
        "Without the creep records the model has no creep: a drive then leaves the slow drift "
        "of every step (a few % of the displacement within seconds) uncompensated.", ""]
    return "\n".join(lines)


def _output_names(m):
    """The example output columns of the README's identify command (x, y, z, then y1...)."""
    return ["x", "y", "z"][:m] if m <= 3 else [f"y{i + 1}" for i in range(m)]


def _multisine_scale(T, amplitude, slew_rate, f_max, f_min, periods, seed):
    """The scale ``excitation_set`` gives a multisine up to ``f_max`` within ``slew_rate``
    (its estimation record's phases): a wider band, a lower amplitude."""
    _, one, _ = multisine(T, amplitude, f_min, f_max, periods=periods, seed=seed)
    return _slew_limited_multisine(one, one.size // int(periods), T, float(slew_rate))[1]


def band_summary(records, amplitude, sampling_period, slew_rate, f_max=None, f_min=10.0,
                 periods=4, seed=0):
    """How far a slew rate let the multisines' band reach, and what ``--f-max`` would keep.

    Parameters
    ----------
    records : list of hammerstein.signals.excitation.ExcitationRecord
        The records written (their multisines' ``scale`` and ``f_max``).
    amplitude : numpy.ndarray, shape (m,)
        Full amplitude per input [V].
    sampling_period : float
        T [s].
    slew_rate : float or None
        ``--slew-rate`` [V/s].
    f_max : float, optional
        ``--f-max`` [Hz] (None: the default band, narrowed by the slew rate).
    f_min : float
        ``--f-min`` [Hz].
    periods : int
        ``--periods``.
    seed : int
        ``--seed``.

    Returns
    -------
    dict or None
        None when no multisine was scaled down. Else ``top`` (the band's end [Hz]),
        ``default`` (the default band's end, ``1 / (4 T)``), ``nyquist`` [Hz],
        ``narrowed`` (the default band was narrowed: no ``--f-max``), ``share`` (smallest
        and largest multisine peak, fraction of the full amplitude), ``volts`` (the same
        [V]), ``slew_rate`` and ``options``: ``(f_max, share)`` of wider bands
        (``1 / (4 T)`` and ``0.45 / T``) when narrowed.
    """
    scaled = [r for r in records if r.kind.startswith("multisine") and r.scale < 1.0]
    if slew_rate is None or not scaled:
        return None
    T = float(sampling_period)
    amp = float(np.max(amplitude))
    # each multisine's peak about the middle of its input's range: 0.8 of the input's amplitude
    # (excitation_set's multisine_fraction) times its scale; max |u| counted a --range's
    # middle (70 V of -10..150 V) as the multisine's
    peaks = [0.8 * float(r.scale) * float(np.asarray(amplitude, dtype=float)[r.excited])
             for r in scaled]
    out = {"top": max(r.f_max for r in scaled), "default": default_f_max(T), "nyquist": 0.5 / T,
           "narrowed": f_max is None, "share": (min(peaks) / amp, max(peaks) / amp),
           "volts": (min(peaks), max(peaks)), "slew_rate": float(slew_rate), "options": []}
    if out["narrowed"] and out["top"] < out["default"]:
        for f in sorted({default_f_max(T), 0.25 / T, 0.45 / T}):
            try:
                share = 0.8 * _multisine_scale(T, 0.8 * amp, slew_rate, f, f_min, periods, seed)
            except ValueError:
                continue
            out["options"].append((f, share))
    return out


def _share_text(lo, hi, scale=100, unit=" %"):
    return (f"{scale * lo:.2g}{unit}" if np.isclose(lo, hi, rtol=0.05)
            else f"{scale * lo:.2g}-{scale * hi:.2g}{unit}")


def _band_sentences(band):
    """What the slew rate did to the multisines' band, and what --f-max does (README)."""
    S, top, nyq = band["slew_rate"], band["top"], band["nyquist"]
    kept = (f"{_share_text(*band['share'])} of the amplitude "
            f"({_share_text(*band['volts'], 1, ' V')})")
    if band["narrowed"] and top < band["default"]:
        options = ", ".join(f"up to {f:.4g} Hz at {100 * s:.2g} %" for f, s in band["options"])
        return [f"Within the slew rate {S:g} V/s the multisines reach {top:.4g} Hz only (the "
                f"default band ends at {band['default']:.4g} Hz; the Nyquist frequency is "
                f"{nyq:.4g} Hz): the band was narrowed to keep {kept}. Bending modes above "
                f"{top:.4g} Hz are then not in the records, and `identify --dynamics` cannot "
                f"identify them. `--f-max HZ` keeps the band up to HZ and lowers the "
                f"multisines' amplitude instead"
                + (f" ({options} of the amplitude)" if options else "")
                + ": their response must then stay well above your sensor's noise "
                "(`identify` measures the noise between the records' periods; `--periods N` "
                "averages more of them)."]
    lines = [f"Within the slew rate {S:g} V/s the multisines keep their band up to {top:.4g} "
             f"Hz at {kept} (80 % without a slew rate): check that their response stays well "
             f"above your sensor's noise (`identify` measures the noise between the records' "
             f"periods and says which held-out fit it allows; `--periods N` averages more of "
             f"them, a lower `--f-max` keeps more amplitude)."]
    if top > band["default"]:
        lines.append(f"Modes above the Nyquist frequency ({nyq:.4g} Hz) fold into the band "
                     f"unless your sensor low-pass filters them (an anti-alias filter), and "
                     f"bending modes close to it are sampled at few samples per period.")
    return lines


def _multisine_share(records):
    """The multisines' amplitude as the README's table gives it: "80 %", or, scaled down to
    a slew rate, the shares they were scaled to ("31.8 %", "27.2-31.8 %: scaled down")."""
    shares = sorted({round(80.0 * r.scale, 1) for r in records
                     if r.kind.startswith("multisine")})
    if not shares or shares == [80.0]:
        return "80 %"
    text = f"{shares[0]:g}" if len(shares) == 1 else f"{shares[0]:g}-{shares[-1]:g}"
    return f"{text} % (scaled down to the slew rate, below)"


def _slew_lines(records, names, T, band=None):
    """README lines: each kind's largest slew from rest [V/s], and the multisines a slew rate
    scaled down (with ``band``, :func:`band_summary`: how far their band reaches)."""
    by_kind = {}
    for r in records:
        fast = max(peak_slew(row, T) for row in r.u)
        by_kind[r.kind] = max(by_kind.get(r.kind, 0.0), fast)
    lines = ["Largest slew of each kind of record, from rest: "
             + ", ".join(f"{kind} {v:.3g} V/s" for kind, v in by_kind.items())
             + ". Your amplifier must follow them; the inputs the records hold must be what "
             "the actuator received (`--slew-rate` keeps every record within yours).", ""]
    scaled = [r for r in records if r.scale < 1.0]
    if scaled:
        lines += ["The multisines were scaled down to stay within the slew rate: "
                  + ", ".join(f"{r.name} to {100 * r.scale:.3g} % (band to {r.f_max:g} Hz)"
                              for r in scaled)
                  + " of their amplitude (80 % of the full one). A multisine's slew grows with its band: without "
                  "`--f-max` the band is narrowed first, until a quarter of the amplitude is "
                  "kept.", ""]
        if band is not None:
            for text in _band_sentences(band):
                lines += [text, ""]
    return lines


def _csv_bytes(record, names):
    data = np.column_stack([record.time, record.u.T])
    row = ",".join(["%.9g"] * data.shape[1])      # one %-format per row: the same text as
    lines = [",".join(["t", *names])]               # formatting each value, 2x less CPU
    lines += [row % tuple(values) for values in data.tolist()]
    return ("\n".join(lines) + "\n").encode()


#: The record files of one input ``{n}`` (``excitation_set``), besides ``demagnetise.csv``.
_STEMS = ("hysteresis-{n}", "multisine-{n}", "multisine-{n}-validation", "creep-{n}")


def _collision(names):
    """Why two inputs of ``names`` would write one file (one line), or None.

    ``ux`` and ``ux-validation`` both write ``multisine-ux-validation.csv``
    (the held-out multisine of ``ux``, the estimation one of the other).
    """
    owner = {}
    for n in names:
        for stem in _STEMS:
            other = owner.setdefault(stem.format(n=n), n)
            if other != n:
                return (f"--inputs: '{other}' and '{n}' would both write {stem.format(n=n)}.csv; "
                        f"rename one of them")
    return None


def _handler(args):
    try:
        names = [n.strip() for n in args.inputs.split(",")]
        if len(names) > MAX_INPUTS:
            raise _Usage(f"--inputs: {len(names)} names; expected at most {MAX_INPUTS} (every "
                         f"file holds every input: {MAX_INPUTS} inputs write about 0.2 GB, 40 "
                         f"wrote 1.1 GB)")
        if not all(names) or len(set(names)) != len(names) or "t" in names:
            raise _Usage(f"--inputs: expected distinct non-empty names other than t, found "
                         f"{args.inputs!r}")
        for n in names:              # each becomes part of file names and a CSV column
            problem = name_problem(n, "--inputs: name", 64) or \
                (f"--inputs: name '{n}': a quote or a comma; expected a plain name"
                 if any(c in n for c in "\",'") else None)
            if problem:
                raise _Usage(problem)
        problem = _collision(names)
        if problem:
            raise _Usage(problem)
        amplitude, centre = _amplitude_and_centre(args, len(names))
        reversals = _reversals(args.reversals)
        T = args.sampling_period
        if not (np.isfinite(T) and T > 0):
            raise _Usage(f"--sampling-period: expected a positive time [s], found {T}")
        if args.hold < 10 * T:       # 2 samples a level: a staircase that shows no creep
            raise _Usage(f"--hold: {args.hold:g} s is {args.hold / T:.3g} sampling periods; "
                         f"expected at least 10 ({10 * T:.4g} s), and seconds to measure creep")
        problem = out_dir_problem(args.out)
        if problem:
            raise _Usage(problem)
        try:
            records = excitation_set(names, amplitude, T, sine_frequency=args.sine_frequency,
                                     f_min=args.f_min, f_max=args.f_max,
                                     multisine_periods=args.periods, hold=args.hold,
                                     seed=args.seed, reversals=reversals,
                                     slew_rate=args.slew_rate, centre=centre)
            t, u = demagnetising_record(T, amplitude, args.sine_frequency, centre,
                                        args.slew_rate)
            records.append(ExcitationRecord("demagnetise", "demagnetise", -1, t, u))
            band = band_summary(records, amplitude, T, args.slew_rate, args.f_max, args.f_min,
                                args.periods, args.seed)
        except ValueError as exc:
            raise _Usage(_option_names(str(exc))) from None
        out = Path(args.out)
        targets = [f"{r.name}.csv" for r in records] + ["README.md"]
        contents = _contents(targets, records, names, amplitude, T, reversals, centre, band)
        # the files' ownership is checked under the lock below only: checked here too, a
        # second excitation into the directory read the manifest while the first was writing
        # its files, found the shared README.md not yet what the manifest said, and stopped
        # with exit 2 (under load, in CI)
    except _Usage as exc:
        print(f"hammerstein excitation: error: {exc}", file=sys.stderr)
        return 2
    try:
        # two excitations into one directory at once both read the manifest before either
        # wrote it: one's entries were lost, and its files later refused as not its own. The
        # check and the write now run one after the other (a lock on the directory's parent)
        lock = locked(out.absolute()) if out.absolute().parent.is_dir() else contextlib.nullcontext()
        with lock:
            try:
                owned = _owned_targets(out, targets, args.force, contents)   # as the lock found it
            except _Usage as exc:
                print(f"hammerstein excitation: error: {exc}", file=sys.stderr)
                return 2
            _write_records(out, owned, contents)
    except (FileLimitError, OSError) as exc:
        if isinstance(exc, FileLimitError):
            print(f"hammerstein excitation: error: {' '.join(str(exc).split())}", file=sys.stderr)
        else:
            print(f"hammerstein excitation: error: {exc.filename or args.out}: cannot write "
                  f"({exc.strerror or exc})", file=sys.stderr)
        return 1
    status = _written(out, records, targets, T, band, args)
    if args.hold < 10 * CREEP_T_MIN:      # said once the records are written
        print_err(f"warning: --hold {args.hold:g} s: the creep staircases hold each level for "
                  f"less than {10 * CREEP_T_MIN:g} s, and creep acts over seconds (identify "
                  f"fits lags from {CREEP_T_MIN:g} s): they show almost none of it (default 2 s)")
    return status


def _owned_targets(out, targets, force, contents):
    """The files the directory's manifest owns, once every target may be written (else _Usage).

    A file the manifest lists is replaced only while it holds what this command wrote there
    (its SHA-256 in the manifest; a manifest without digests: what this run writes): the
    records a user filled with the measured columns, as the README says, are theirs
    (replaced silently, a user's measurements were lost).
    """
    owned = _owned(out)
    for name in targets + [MANIFEST]:
        path = out / name
        if name == MANIFEST:
            if path.exists() and not owned and not force and not path.is_file():
                raise _Usage(f"--out: {path} exists and is not a file")
            continue
        if not _exists(path) or force:
            continue
        if name not in owned:
            raise _Usage(f"--out: {path} exists and was not written by hammerstein "
                         f"excitation; choose another directory or add --force")
        now = file_digest(path) if path.is_file() and not path.is_symlink() else None
        was = owned[name] or hashlib.sha256(contents[name]).hexdigest()
        if now != was:
            why = ("changed since hammerstein excitation wrote it (the measured columns "
                   "added?)" if owned[name] else
                   "differs from what this run writes, and the directory's manifest (an older "
                   "version's) does not say whether you changed it")
            raise _Usage(f"--out: {path} {why}; nothing was written: choose another "
                         f"directory, move it away, or add --force to replace it")
    return owned


def _contents(targets, records, names, amplitude, T, reversals, centre, band):
    """``{file name: bytes}`` of the records and README.md this run writes."""
    out = {name: _csv_bytes(r, names) for r, name in zip(records, targets)}
    out["README.md"] = readme_text(records, names, amplitude, T, reversals, centre,
                                   band).encode("utf-8")
    return out


def _write_records(out, owned, contents):
    """The manifest, the records and README.md: all of them or none."""
    digests = dict(owned)
    digests.update({name: hashlib.sha256(data).hexdigest() for name, data in contents.items()})
    manifest = "\n".join([_MANIFEST_HEAD, *(f"{name}\t{d}" if d else name
                                             for name, d in sorted(digests.items()))]) + "\n"
    # a failed write (full disk) or an interruption leaves no file, not even the manifest,
    # and no directory this run made
    with removed_if_failed(out), all_or_nothing():
        safe_write(out / MANIFEST, manifest, "excitation manifest", root=out)
        for name, data in contents.items():
            safe_write(out / name, data, "README" if name == "README.md" else "excitation file",
                       root=out)


def _written(out, records, targets, T, band, args):
    """Print what was written and the notes on the multisines' band; exit status 0."""
    for r, name in zip(records, targets):
        print(f"wrote {out / name}: {r.kind}, {r.time.size} samples ({r.time.size * T:g} s)")
    print(f"wrote {out / 'README.md'}")
    if band is not None and band["narrowed"] and band["top"] < band["default"]:
        options = ", ".join(f"{f:.4g} Hz: {100 * s:.2g} %" for f, s in band["options"])
        print_err(f"note: within --slew-rate {args.slew_rate:g} V/s the multisines' band reaches "
              f"{band['top']:.4g} Hz only (default {band['default']:.4g} Hz): bending modes "
              f"above it cannot be identified from these records; --f-max HZ keeps a wider "
              f"band at a lower amplitude" + (f" ({options} of the amplitude)" if options else "")
              + " (README.md)")
    elif band is not None:
        print_err(f"note: within --slew-rate {args.slew_rate:g} V/s the multisines up to "
              f"{band['top']:.4g} Hz were scaled to {_share_text(*band['share'])} of the amplitude "
              f"({_share_text(*band['volts'], 1, ' V')}): check their response against your "
              f"sensor's noise (README.md)")
    return 0


def _exists(path):
    """True when something (a file, a directory, a link) is at ``path``."""
    return path.is_symlink() or path.exists()
