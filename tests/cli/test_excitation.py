"""``hammerstein excitation``: the files users play on hardware (issue 17, item 2).

Expectations come from the issue's specification (amplitude levels 100..10 %,
two 1 Hz periods each; multisine 10 Hz to half Nyquist at 80 %; 2 s steps),
checked on the written CSV files by independent means (FFT, run lengths).
"""

import re

import numpy as np
import pytest

from hammerstein.cli.main import main
from hammerstein.signals.excitation import LEVELS

#: seconds of the 1 Hz decreasing sine: two periods per level
SINE_S = 2 * len(LEVELS)

T = 5e-4          # 2 kHz keeps the files small; the design scales with T


def _run(out, *extra):
    return main(["excitation", "--inputs", "ux,uy", "--amplitude", "10", "--sampling-period",
                 str(T), "--out", str(out), *extra])


def _read(path):
    with open(path) as fh:
        header = fh.readline().strip().split(",")
    return header, np.loadtxt(path, delimiter=",", skiprows=1)


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("exc") / "records"
    assert _run(out) == 0
    return out


def test_files_columns_and_the_undriven_input(written):
    names = sorted(p.name for p in written.iterdir())
    expected = [".hammerstein-excitation", "README.md"]
    expected += [f"{k}-{i}.csv" for i in ("ux", "uy")
                 for k in ("hysteresis", "multisine", "creep")]
    expected += [f"multisine-{i}-validation.csv" for i in ("ux", "uy")] + ["demagnetise.csv"]
    assert names == sorted(expected)
    for name in ("hysteresis-uy.csv", "multisine-uy.csv", "creep-uy.csv"):
        header, d = _read(written / name)
        assert header == ["t", "ux", "uy"]
        np.testing.assert_allclose(np.diff(d[:, 0]), T, rtol=1e-6)
        assert np.all(d[:, 1] == 0) and np.abs(d[:, 2]).max() > 0
    readme = (written / "README.md").read_text()
    assert "hammerstein identify hysteresis-ux.csv hysteresis-uy.csv" in readme


def test_demagnetising_cycle_wipes_every_input_from_the_amplitude_to_rest(written):
    """Every input at once: turning points that shrink by 5 % of the amplitude per period
    (so that each reversal lies inside the previous one: the hysteresis memory is wiped
    from the amplitude down), from 0 V and back to 0 V, then 1 s at rest; its slew is
    that of a 2 Hz sine of the amplitude (2 pi 2 Hz 10 V), the README says to play it."""
    header, d = _read(written / "demagnetise.csv")
    assert header == ["t", "ux", "uy"]
    u = d[:, 1:].T
    n_rest = int(round(1.0 / T))
    assert np.all(u[:, -n_rest:] == 0) and np.all(u[:, 0] == 0)
    decay = u[0, :-n_rest]
    assert decay.size == int(round(20 / 2.0 / T))       # 20 periods at 2 Hz
    peaks = np.array([decay[k:k + int(round(0.5 / T))].max()
                      for k in range(0, decay.size, int(round(0.5 / T)))])
    assert peaks[0] == pytest.approx(10.0 * (1 - 0.25 / 20), rel=2e-3)
    assert np.all(np.diff(peaks) < 0) and np.allclose(np.diff(peaks), -0.5, rtol=0.02)
    np.testing.assert_array_equal(u[0], u[1])             # both inputs (amplitude 10 V each)
    assert np.abs(np.diff(decay)).max() <= 2 * np.pi * 2.0 * 10.0 * T * (1 + 1e-9)
    assert "play `demagnetise.csv`" in (written / "README.md").read_text()


def test_demagnetising_cycle_at_the_fastest_sine_keeps_eight_samples_a_period(tmp_path):
    """At the fastest sine the command accepts (8 samples a period), twice its frequency would
    leave 4: the demagnetising cycle stays at 8 samples a period instead of refusing the
    command with a --sine-frequency it was given within its limit."""
    fastest = 1 / (8 * T)
    assert _run(tmp_path / "fast", "--sine-frequency", str(fastest)) == 0
    _, d = _read(tmp_path / "fast" / "demagnetise.csv")
    assert d.shape[0] == 20 * 8 + int(round(1.0 / T))


def test_decreasing_sine_levels(written):
    _, d = _read(written / "hysteresis-ux.csv")
    u = d[:, 1]
    n = int(round(1 / T))                      # samples per 1 Hz period
    peaks = [np.abs(u[k * 2 * n:(k + 1) * 2 * n]).max() for k in range(len(LEVELS))]
    np.testing.assert_allclose(peaks, [10 * a for a in LEVELS], rtol=1e-4)
    assert LEVELS[-1] == 0.1 and u.size == SINE_S * n      # the 10 % level is the last


def _turning_points(u):
    """Values of u at its strict local extrema (independent of the package's own splitter)."""
    du = np.diff(u)
    k = np.flatnonzero(du[:-1] * du[1:] < 0) + 1
    return u[k]


@pytest.fixture(scope="module")
def with_curves(tmp_path_factory):
    out = tmp_path_factory.mktemp("exc") / "curves"
    assert _run(out, "--reversals", "standard") == 0
    return out


def test_reversal_curves_follow_the_decreasing_sine(with_curves):
    """After the sine (two periods per level), the first-order reversal curves: up to the amplitude; then
    for each reversal point (80 % to -80 % in steps of 20 %) down to it and back up, down to
    minus the amplitude, up to minus the point and back down, up to the amplitude again (to
    0 V after the last point). Read as turning points of the file's input; every move no
    faster than three times the 1 Hz sine's largest slew (3 x 2 pi 1 Hz 10 V: 6 s of curves
    in all), the record continuous where the two parts meet, the curves' mean 0 V."""
    _, d = _read(with_curves / "hysteresis-ux.csv")
    u = d[:, 1]
    n = int(round(1 / T))
    curves = u[SINE_S * n - 1:]               # the sine's last sample, then the curves
    b = np.arange(8, -9, -2) / 10 * 10.0
    expected = [10.0]
    for v in b:
        expected += [v, 10.0, -10.0, -v, -10.0] + ([10.0] if v != b[-1] else [])
    np.testing.assert_allclose(_turning_points(curves), expected, atol=1e-9)
    slew = 2 * np.pi * 1.0 * 10.0 * T
    assert np.abs(np.diff(u[:SINE_S * n])).max() <= slew * (1 + 1e-6)
    assert 0.99 * 3 * slew <= np.abs(np.diff(curves)).max() <= 3 * slew * (1 + 1e-6)
    assert curves.size - 1 == pytest.approx(6.0 / T, rel=0.01)
    assert abs(curves.mean()) < 1e-3 * 10.0
    assert abs(u[-1]) < 3 * slew and u[0] == 0
    readme = (with_curves / "README.md").read_text()
    assert "first-order reversal curves" in readme


def test_by_default_and_with_none_the_decreasing_sine_alone(written, tmp_path):
    assert _run(tmp_path / "plain", "--reversals", "none") == 0
    for d in (written, tmp_path / "plain"):
        _, data = _read(d / "hysteresis-ux.csv")
        assert data.shape[0] == SINE_S * int(round(1 / T))
        assert "reversal curves" not in (d / "README.md").read_text()


def test_explicit_reversal_points(tmp_path):
    """Two points: two curves from +10 V turning at 5 and -2.5 V, their mirrors from -10 V."""
    assert _run(tmp_path / "two", "--reversals", "0.5,-0.25") == 0
    _, d = _read(tmp_path / "two" / "hysteresis-ux.csv")
    curves = d[SINE_S * int(round(1 / T)) - 1:, 1]
    np.testing.assert_allclose(_turning_points(curves),
                               [10, 5, 10, -10, -5, -10, 10, -2.5, 10, -10, 2.5, -10], atol=1e-9)


@pytest.mark.parametrize("text", ["1.0", "0.5,0.5", "x", "nan", "-1"])
def test_bad_reversals_are_a_usage_error(tmp_path, capsys, text):
    assert _run(tmp_path / "bad", "--reversals", text) == 2
    err = capsys.readouterr().err
    assert err.startswith("hammerstein excitation: error: --reversals:") and err.count("\n") == 1
    assert not (tmp_path / "bad").exists()


def test_multisine_band_and_peak(written):
    _, d = _read(written / "multisine-ux.csv")
    u = d[:, 1]
    assert np.abs(u).max() == pytest.approx(8.0, rel=1e-6)
    n = int(round(0.1 / T))                    # one period (10 Hz grid)
    spec = np.abs(np.fft.rfft(u[:n]))
    f = np.fft.rfftfreq(n, T)
    lines = f[spec > 1e-6 * spec.max()]
    assert lines.min() == pytest.approx(10.0) and lines.max() == pytest.approx(0.25 / T)
    np.testing.assert_allclose(u[:n], u[n:2 * n], atol=1e-6)      # periodic
    _, v = _read(written / "multisine-ux-validation.csv")
    assert np.corrcoef(u, v[:, 1])[0, 1] < 0.2                      # other phases


@pytest.mark.parametrize("period, top", [(5e-4, 500.0), (5e-5, 5000.0), (1e-4, 2500.0),
                                         (2e-5, 2500.0), (1e-5, 0.25 / 9e-5)])
def test_the_default_band_ends_at_a_quarter_of_the_rate_the_modes_are_fitted_at(period, top):
    """At 20 kHz and below the band ends at half the Nyquist frequency; faster records are
    decimated near 10 kHz for the dynamics (by 5 at 50 kHz, 9 at 100 kHz), and their band
    ends at a quarter of that rate: at 50 kHz it reached 12.5 kHz, where the decimation's
    filter removes it, and a tester's held-out fit fell to 78.7 % (96.1 % at 10 kHz)."""
    from hammerstein.signals.excitation import excitation_set
    rec = [r for r in excitation_set(["ux"], 5.0, period, multisine_periods=1, hold=0.1)
           if r.kind == "multisine"][0]
    n = rec.u.shape[1]
    spec = np.abs(np.fft.rfft(rec.u[0]))
    lines = np.fft.rfftfreq(n, period)[spec > 1e-6 * spec.max()]
    assert rec.f_max == pytest.approx(top, abs=10.0) and lines.max() == pytest.approx(rec.f_max)


def test_staircase_steps_held_two_seconds(written):
    _, d = _read(written / "creep-ux.csv")
    u = d[:, 1]
    change = np.flatnonzero(np.diff(u) != 0) + 1
    runs = np.diff(np.concatenate([[0], change, [u.size]]))
    assert np.all(runs % int(round(2 / T)) == 0) and runs.min() == int(round(2 / T))
    assert u.max() == 10 and u.min() == -10 and u[0] == 0


def test_never_replaces_a_file_it_did_not_write(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "creep-ux.csv").write_text("my data\n")
    assert _run(out) == 2
    assert "--force" in capsys.readouterr().err
    assert (out / "creep-ux.csv").read_text() == "my data\n"
    assert sorted(p.name for p in out.iterdir()) == ["creep-ux.csv"]
    assert _run(out) == 2 and _run(out, "--force") == 0
    assert _run(out) == 0                              # its own files: replaced


@pytest.mark.parametrize("opts,fragment", [
    (["--amplitude", "-1"], "--amplitude"),
    (["--amplitude", "1,2,3"], "one per input"),
    (["--sampling-period", "0"], "--sampling-period"),
    (["--f-min", "3000"], "f_min"),
])
def test_usage_errors(tmp_path, capsys, opts, fragment):
    args = {"--amplitude": "10", "--sampling-period": str(T)}
    for k, v in zip(opts[::2], opts[1::2]):
        args[k] = v
    flat = [x for kv in args.items() for x in kv if kv[0] in ("--amplitude", "--sampling-period")]
    extra = [x for k, v in args.items() if k not in ("--amplitude", "--sampling-period")
             for x in (k, v)]
    status = main(["excitation", "--inputs", "ux,uy", *flat, "--out", str(tmp_path / "o"), *extra])
    err = capsys.readouterr().err
    assert status == 2 and fragment in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_a_slew_rate_keeps_every_record_within_it(tmp_path, capsys):
    """``--slew-rate``: no record steps faster, from rest (the first sample counted from 0 V):
    the multisines are one period shifted cyclically (the same amplitude spectrum, scaled) and
    scaled down, the staircase's steps are ramps at the rate; the README names the scale and
    its identify command the three outputs."""
    S = 2000.0                              # V/s: 1 V a sample at 2 kHz, 10 V steps ramped
    out = tmp_path / "slow"
    band = ["--f-max", "400"]               # given: kept, the amplitude scaled
    assert main(["excitation", "--inputs", "ux,uy,uz", "--amplitude", "10", "--sampling-period",
                 str(T), "--out", str(out), "--slew-rate", str(S), "--hold", "0.5", *band]) == 0
    assert "scaled to" in capsys.readouterr().err
    reference = tmp_path / "fast"
    assert main(["excitation", "--inputs", "ux,uy,uz", "--amplitude", "10", "--sampling-period",
                 str(T), "--out", str(reference), "--hold", "0.5", *band]) == 0
    for f in sorted(out.glob("*.csv")):
        _, data = _read(f)
        u = data[:, 1:]
        steps = np.abs(np.diff(np.vstack([np.zeros((1, u.shape[1])), u]), axis=0))
        assert steps.max() <= S * T, (f.name, steps.max())     # as printed, not 1e-9 more
        if f.name.startswith("multisine"):
            k = int(np.argmax(np.ptp(u, axis=0)))
            one, fast = u[:, k], _read(reference / f.name)[1][:, 1 + k]
            n = one.size // 4                           # four periods
            a, b = np.abs(np.fft.rfft(one[:n])), np.abs(np.fft.rfft(fast[:n]))
            scale = a.max() / b.max()
            assert 0 < scale < 1 and np.allclose(a, scale * b, atol=1e-6 * a.max())
            assert abs(one[0]) <= S * T
    readme = (out / "README.md").read_text()
    assert "scaled down to stay within the slew rate" in readme and "--outputs x,y,z" in readme
    # the table gives the amplitude the multisines were played at (80 % of the amplitude times
    # each one's scale), not the 80 % they had before the slew rate scaled them down
    scales = {float(m) for m in re.findall(r"multisine-\w+(?:-validation)? to ([\d.]+) %", readme)}
    row = next(ln for ln in readme.splitlines() if ln.startswith("| multisine-ux.csv"))
    shares = [float(v) for v in re.findall(r"at ([\d.]+)(?:-([\d.]+))? %", row)[0] if v]
    assert scales and np.isclose(min(shares), 0.8 * min(scales), atol=0.06)
    assert np.isclose(max(shares), 0.8 * max(scales), atol=0.06) and "at 80 %" not in row
    fast_row = next(ln for ln in (reference / "README.md").read_text().splitlines()
                    if ln.startswith("| multisine-ux.csv"))
    assert "at 80 % of the amplitude" in fast_row


def test_a_slew_rate_narrows_the_default_band_before_the_amplitude():
    """Without f_max, a slew rate narrows the multisines' band (down to 4 f_min) until a
    quarter of their amplitude is kept: scaled to 3 %, a multisine of 4 V left a scenario's
    identified G with two poles the actuator does not have."""
    from hammerstein.signals.excitation import MIN_MULTISINE_SCALE, excitation_set, peak_slew
    for S in (2000.0, 500.0):
        for rec in excitation_set(["ux"], 5.0, 5e-5, hold=0.1, slew_rate=S):
            if rec.kind == "multisine":
                assert rec.scale >= MIN_MULTISINE_SCALE or rec.f_max <= 4 * 10.0 + 1e-9
                assert rec.f_max < 5000.0 and peak_slew(rec.u[0], 5e-5) <= S * (1 + 1e-9)


def test_a_slew_rate_the_slow_sine_exceeds_is_a_usage_error(tmp_path, capsys):
    assert main(["excitation", "--inputs", "ux", "--amplitude", "10", "--sampling-period",
                 str(T), "--out", str(tmp_path / "r"), "--slew-rate", "10"]) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("hammerstein excitation: error: --sine-frequency")
    assert not (tmp_path / "r").exists()


def test_a_unipolar_range_keeps_every_record_within_it(tmp_path, capsys):
    """``--range 0,150`` (a unipolar stack: below -20 V it depolarises): every file stays in
    [0, 150] V, starts from the amplifier's rest (0 V) and ends there; the decreasing sine's
    levels are centred on 75 V (its peaks at 75 +- 75 a_k), the creep staircase climbs from
    rest by quarters of the range, and the demagnetising cycle ends at rest."""
    out = tmp_path / "uni"
    assert main(["excitation", "--inputs", "ux,uy", "--range", "0,150", "--sampling-period",
                 str(T), "--out", str(out), "--hold", "0.5"]) == 0
    for f in sorted(out.glob("*.csv")):
        _, data = _read(f)
        u = data[:, 1:]
        assert u.min() >= 0.0 and u.max() <= 150.0 + 1e-9, f.name
        assert np.abs(u[0]).max() < 0.1 and np.abs(u[-1]).max() == 0.0, f.name   # from/to rest
    _, h = _read(out / "hysteresis-ux.csv")
    ux = h[:, 1]
    assert ux.max() == pytest.approx(150.0) and np.all(h[:, 2] == 0.0)
    mid = ux[np.abs(ux - 75.0) < 75.0 * 0.2 + 1e-9]          # the 20 % level's loop and crossings
    assert mid.size and ux[(ux > 30) & (ux < 120)].mean() == pytest.approx(75.0, abs=2.0)
    _, c = _read(out / "creep-uy.csv")
    levels = np.unique(np.round(c[:, 2], 6))
    np.testing.assert_allclose(levels, [0.0, 37.5, 75.0, 112.5, 150.0])
    _, d = _read(out / "demagnetise.csv")
    assert np.all(d[-int(0.5 / T):, 1:] == 0.0) and d[:, 1:].max() <= 150.0
    assert "range [0, 150], [0, 150] V" in (out / "README.md").read_text()


@pytest.mark.parametrize("opts, fragment", [(["--range", "150,0"], "--range: expected finite LOW < HIGH"),
                                            (["--range", "0,150", "--amplitude", "10"], "exactly one"),
                                            ([], "exactly one")])
def test_range_and_amplitude_usage(tmp_path, capsys, opts, fragment):
    argv = ["excitation", "--inputs", "ux", "--sampling-period", str(T), "--out",
            str(tmp_path / "r"), *opts]
    assert main(argv) == 2
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and fragment in err[0] and not (tmp_path / "r").exists()


def test_printed_multisines_stay_within_the_slew_rate(tmp_path):
    """A new user's AFM records (+-10 V, 2e4 V/s at 20 kHz): the multisines, scaled onto the
    slew rate, stepped 1.0000000037 V per sample once printed to 9 digits; they are scaled
    onto the rate less two roundings of the largest voltage's decade."""
    out = tmp_path / "afm"
    assert main(["excitation", "--inputs", "vx,vy", "--amplitude", "10", "--sampling-period",
                 "5e-5", "--slew-rate", "2e4", "--out", str(out)]) == 0
    for f in sorted(out.glob("multisine*.csv")):
        u = _read(f)[1][:, 1:]
        steps = np.abs(np.diff(np.vstack([np.zeros((1, u.shape[1])), u]), axis=0))
        assert steps.max() <= 2e4 * 5e-5, (f.name, steps.max())


def test_a_slew_rate_says_how_far_the_band_reaches_and_what_f_max_does(tmp_path, capsys):
    """A 5 kHz stage with a 2000 V/s amplifier: the default band is narrowed far below half
    the Nyquist frequency; the note and the README say where it ends (the highest line of the
    multisine file's spectrum) and what --f-max keeps, at what amplitude; with --f-max close
    to Nyquist the README says the multisines' amplitude and that modes above Nyquist fold."""
    Ts = 2e-4
    out = tmp_path / "narrow"
    assert main(["excitation", "--inputs", "ux,uy", "--amplitude", "10", "--sampling-period",
                 str(Ts), "--slew-rate", "2000", "--out", str(out)]) == 0
    note = [line for line in capsys.readouterr().err.splitlines() if line.startswith("note:")]
    _, data = _read(out / "multisine-ux.csv")
    u = data[:, 1]
    n = u.size // 4
    spectrum = np.abs(np.fft.rfft(u[:n]))
    top = np.flatnonzero(spectrum > 1e-3 * spectrum.max())[-1] / (n * Ts)
    assert top < 0.25 / Ts / 4                                 # far below the default 1250 Hz
    assert len(note) == 1 and f"band reaches {top:.4g} Hz only" in note[0]
    assert "--f-max HZ keeps a wider band at a lower amplitude (1250 Hz:" in note[0]
    readme = (out / "README.md").read_text()
    assert f"the multisines reach {top:.4g} Hz only" in readme and "`--f-max HZ`" in readme
    wide = tmp_path / "wide"
    assert main(["excitation", "--inputs", "ux,uy", "--amplitude", "10", "--sampling-period",
                 str(Ts), "--slew-rate", "2000", "--f-max", "2400", "--out", str(wide)]) == 0
    capsys.readouterr()
    peak = max(np.abs(_read(wide / f)[1][:, 1:]).max()
               for f in ("multisine-ux.csv", "multisine-uy.csv"))
    readme = (wide / "README.md").read_text()
    assert f"up to 2400 Hz at" in readme and f"{peak:.2g} V)" in readme
    assert "Modes above the Nyquist frequency (2500 Hz) fold into the band" in readme


@pytest.mark.slow  # two processes at once
def test_two_excitations_into_one_directory_at_once_keep_both_in_the_manifest(tmp_path):
    # both read the manifest before either wrote it: one set of files was left out of it, and
    # a later run of that set was refused ("was not written by hammerstein excitation")
    import os
    import subprocess
    import sys
    from pathlib import Path
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    base = [sys.executable, "-m", "hammerstein", "excitation", "--amplitude", "10",
            "--sampling-period", "5e-5", "--out", str(tmp_path / "cx")]
    for attempt in range(3):             # the race needs both to start together: try a few
        procs = [subprocess.Popen(base + ["--inputs", name], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True, env=env)
                 for name in ("ux", "vx")]
        assert [p.wait(timeout=300) for p in procs] == [0, 0]
        manifest = (tmp_path / "cx" / ".hammerstein-excitation").read_text().splitlines()
        names = {ln.split("\t")[0] for ln in manifest}
        assert {"hysteresis-ux.csv", "hysteresis-vx.csv"} <= names, manifest
    for name in ("ux", "vx"):            # and each set may be written again
        assert subprocess.run(base + ["--inputs", name], capture_output=True, env=env,
                              timeout=300).returncode == 0


def test_each_input_may_have_its_own_range(tmp_path, capsys):
    # a bipolar x (+-10 V) and a unipolar y (0..100 V): one --range for both could not say it,
    # and two directories gave two demagnetising cycles, each wrong for the other amplifier
    out = tmp_path / "lab"
    assert main(["excitation", "--inputs", "ux,uy", "--range", "-10,10", "0,100",
                 "--sampling-period", str(T), "--out", str(out)]) == 0, capsys.readouterr().err
    limits = {"ux": (-10.0, 10.0), "uy": (0.0, 100.0)}
    for path in sorted(out.glob("*.csv")):
        header, data = _read(path)
        for name, (low, high) in limits.items():
            u = data[:, header.index(name)]
            assert low - 1e-9 <= u.min() and u.max() <= high + 1e-9, (path.name, name)
        if path.name == "demagnetise.csv":          # both amplifiers swept, each within its own
            for name, (low, high) in limits.items():
                u = data[:, header.index(name)]
                assert np.ptp(u) > 0.9 * (high - low)
                assert abs(u[0]) < 1e-4 * (high - low) and u[-1] == 0.0      # from rest, back
    readme = (out / "README.md").read_text()
    assert "range [-10, 10], [0, 100] V" in readme
    # the unipolar input's files ramp from rest and back and are longer: the README's table
    # gives each kind's shortest to longest file (it gave the last file's alone)
    for kind in ("hysteresis", "multisine"):
        sizes = [_read(out / f"{kind}-{n}.csv")[1].shape[0] * T for n in ("ux", "uy")]
        row = next(ln for ln in readme.splitlines() if ln.startswith(f"| {kind}-ux.csv"))
        assert row.endswith(f"| {min(sizes):g}-{max(sizes):g} s |"), row


@pytest.mark.parametrize("argv, words", [
    (["--range", "-10,10", "0,100", "0,50"], "--range: expected one LOW,HIGH for every input or "
                                             "one per input (2: ux, uy), found 3"),
    (["--range", "-10,10", "--range", "0,100"], "--range: given twice ('-10,10', then '0,100', "
                                                "which would replace it); give it once"),
])
def test_a_range_per_input_that_does_not_fit_is_refused(tmp_path, capsys, argv, words):
    # a repeated --range was 'last one wins': every input driven over 0..100 V, exit 0
    status = main(["excitation", "--inputs", "ux,uy", *argv, "--sampling-period", str(T),
                   "--out", str(tmp_path / "lab")])
    err = capsys.readouterr().err
    assert status == 2 and words in err and not (tmp_path / "lab").exists()


def test_a_ranges_multisines_are_measured_about_its_middle(tmp_path, capsys):
    """-10..150 V (amplitude 80 V about 70 V) behind 5e4 V/s: the note gave the multisines'
    share from max |u|, the middle included (1.1e+02-1.3e+02 % of the amplitude, 92-100 V);
    it is their excursion about the middle, measured here on the files."""
    out = tmp_path / "stack"
    assert main(["excitation", "--inputs", "ux,uy", "--range", "-10,150", "--sampling-period",
                 "5e-4", "--slew-rate", "5e4", "--out", str(out)]) == 0
    note = [line for line in capsys.readouterr().err.splitlines() if "multisines up to" in line]
    swings = []
    for f in sorted(out.glob("multisine*.csv")):
        u = _read(f)[1][:, 1:]
        k = int(np.argmax(np.ptp(u, axis=0)))
        row = u[:, k]
        middle = row[row.size // 4: 3 * row.size // 4]       # the periods, not the ramps to them
        swings.append(np.max(np.abs(middle - 70.0)))
    low, high = 100 * min(swings) / 80.0, 100 * max(swings) / 80.0
    assert len(note) == 1 and f"scaled to {low:.2g}-{high:.2g} % of the amplitude" in note[0]


@pytest.mark.parametrize("hold, code, said", [
    ("0.001", 2, "--hold: 0.001 s is 2 sampling periods; expected at least 10"),   # 2 samples a level
    ("0.05", 0, "warning: --hold 0.05 s: the creep staircases hold each level for less than 0.1 s"),
    ("2", 0, None),
])
def test_a_hold_too_short_to_show_creep_is_refused_or_warned(tmp_path, capsys, hold, code, said):
    out = tmp_path / "x"
    assert main(["excitation", "--inputs", "ux", "--amplitude", "10", "--sampling-period",
                 "5e-4", "--hold", hold, "--out", str(out)]) == code
    err = capsys.readouterr().err
    if said is None:
        assert "--hold" not in err
    else:
        assert said in err and len(err.strip().splitlines()) == 1
    assert out.exists() == (code == 0)


@pytest.mark.parametrize("ranges", [["--amplitude", "10"], ["--range", "-10,10", "0,150"]],
                         ids=["amplitude", "bipolar-unipolar"])
@pytest.mark.parametrize("slew", [[], ["--slew-rate", "2e4"]], ids=["no-slew", "slew"])
def test_every_file_starts_at_rest(tmp_path, ranges, slew):
    """Every file written starts at the amplifier's rest (0 V, or the range's value nearest
    0 V): its first sample within 1 % of the input's span of it, and no larger a step than the
    file's own largest one (a multisine started at its first sample, 3 V of a -10..10 V input:
    a step out of rest a tester's actuator rang on)."""
    out = tmp_path / "o"
    assert main(["excitation", "--inputs", "ux,uy", *ranges, "--sampling-period", str(T),
                 "--periods", "1", "--hold", "0.2", "--out", str(out), *slew]) == 0
    spans = {"ux": (-10.0, 10.0), "uy": (-10.0, 10.0) if ranges[0] == "--amplitude" else (0.0, 150.0)}
    files = sorted(out.glob("*.csv"))
    assert len(files) == 9
    for f in files:
        header, data = _read(f)
        for j, name in enumerate(header[1:], start=1):
            low, high = spans[name]
            rest = min(max(0.0, low), high)
            u = data[:, j]
            own = float(np.max(np.abs(np.diff(u)))) if u.size > 1 else 0.0
            first = abs(u[0] - rest)
            assert first <= 0.01 * (high - low), (f.name, name, u[0])
            assert first <= own + 1e-12, (f.name, name, u[0], own)


def test_a_record_the_user_filled_is_never_replaced(tmp_path, capsys):
    """The README says to add the measured columns to the records and give them back: a second
    ``excitation --out`` into that directory replaced them silently (the measurement lost).
    A file is replaced only while it holds what excitation wrote there (its SHA-256 in the
    manifest); with --force it is."""
    import hashlib
    argv = ["excitation", "--inputs", "ux,uy", "--amplitude", "8", "--sampling-period", "1e-4",
            "--out", str(tmp_path / "lab")]
    assert main(argv) == 0
    assert main(argv) == 0                          # unchanged files: written again
    rec = tmp_path / "lab" / "hysteresis-ux.csv"
    lines = rec.read_text().splitlines()
    rec.write_text("\n".join([lines[0] + ",x,y"] + [ln + ",0.5,0.25" for ln in lines[1:]]) + "\n")
    mine = hashlib.sha256(rec.read_bytes()).hexdigest()
    before = {p.name: p.stat().st_mtime_ns for p in (tmp_path / "lab").iterdir()}
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "hysteresis-ux.csv changed since hammerstein excitation wrote it" \
        in err[0] and "--force" in err[0]
    assert hashlib.sha256(rec.read_bytes()).hexdigest() == mine      # nothing written at all
    assert {p.name: p.stat().st_mtime_ns for p in (tmp_path / "lab").iterdir()} == before
    # a manifest of the earlier format (names alone): compared with what this run writes
    man = tmp_path / "lab" / ".hammerstein-excitation"
    man.write_text("\n".join(ln.split("\t")[0] for ln in man.read_text().splitlines()) + "\n")
    capsys.readouterr()
    assert main(argv) == 2
    assert "an older version's" in capsys.readouterr().err
    assert hashlib.sha256(rec.read_bytes()).hexdigest() == mine
    assert main(argv + ["--force"]) == 0 and hashlib.sha256(rec.read_bytes()).hexdigest() != mine


def test_more_inputs_than_it_writes_records_for_are_a_usage_error(tmp_path, capsys):
    """40 inputs wrote 1.1 GB (every file holds every input); 500 were not refused at all."""
    from hammerstein.cli.excitation import MAX_INPUTS
    names = ",".join(f"u{i}" for i in range(MAX_INPUTS + 1))
    assert main(["excitation", "--inputs", names, "--amplitude", "5", "--sampling-period",
                 str(T), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{MAX_INPUTS + 1} names; expected at most {MAX_INPUTS}" in err[0]
    assert not (tmp_path / "o").exists()


@pytest.mark.slow  # a subprocess waiting on the lock
def test_a_second_excitation_checks_the_files_once_the_first_has_written_them(tmp_path):
    # the race of the test above, made certain: the first run holds the directory's lock
    # and its manifest already names the shared README.md by what it is about to write, the
    # file itself not written yet. The second run used to check its files before the lock,
    # find README.md not what the manifest said, and stop with exit 2; it waits now
    import hashlib
    import os
    import subprocess
    import sys
    import time
    from pathlib import Path
    from hammerstein.core._provenance import locked
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    base = [sys.executable, "-m", "hammerstein", "excitation", "--amplitude", "10",
            "--sampling-period", "5e-5", "--out", str(tmp_path / "cx")]
    assert subprocess.run(base + ["--inputs", "ux"], capture_output=True, env=env,
                          timeout=300).returncode == 0
    out = tmp_path / "cx"
    manifest = out / ".hammerstein-excitation"
    readme = (out / "README.md").read_bytes()
    with locked(out.absolute()):
        (out / "README.md").write_bytes(b"the first run's README, half written")
        second = subprocess.Popen(base + ["--inputs", "ux"], stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True, env=env)
        time.sleep(8.0)                   # the second run reaches the lock and waits
        assert second.poll() is None, second.stderr.read()
        (out / "README.md").write_bytes(readme)      # the first run's write ends
        assert hashlib.sha256(readme).hexdigest() in manifest.read_text()
    assert second.wait(timeout=300) == 0, second.stderr.read()
