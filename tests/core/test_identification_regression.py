"""The identifications on the bundled record hold the values of the code before the speed-ups.

The reference numbers below were identified on the bundled real record
(``piezo-stack-150V-1Hz.csv``, input column 2, output column 1) by the code
of commit 7dbcca6, before the creep regressors, the Preisach smoothing
trials' predictions and the module split; they are that code's output, kept
here so that a later change of the numerics shows.

Tolerances:

* the classical PI and the Preisach model are convex least-squares fits: the
  two versions solve the same problem with the operations in another order,
  so their minimisers differ by rounding amplified by the problem's
  conditioning. ``tests/core/test_lsq.py`` bounds the difference of two
  *different solvers* on this record by 1e-6 of the output range (measured
  2.6e-9 on the realistic records, 500 below the record's noise of 0.05 % of
  its range); the same 1e-6 holds here for the RMS errors (relative) and the
  weights (relative to the largest). The thresholds are computed from the
  input alone: 1e-12 relative.
* the generalised PI's envelopes come from a nonlinear search whose
  finite-difference Jacobian turns rounding into another search path that
  ends where the search's tolerance stops it: as in ``test_lsq.py``, the RMS
  errors no more than 1 % worse (and no more than 3 % better: another
  processor's BLAS kernels end 1.1-1.4 % lower) and the structure; the thresholds depend on the envelope
  ends and are not held.
"""

import numpy as np
import pytest

from hammerstein.identification.gpi_identification import GeneralizedPIIdentifier, identify_gpi_records
from hammerstein.identification.preisach_identification import PreisachIdentifier
from hammerstein.identification.record_identification import identify_records
from hammerstein.io.datafiles import bundled_data, read_record

# the classical PI with a play of threshold 0 (a linear term: the time partition of 14 after
# it; without it the model held its output over the first 2 x 1.44 V of every reversal):
# refitted by this code (the fit of 7dbcca6 had train 0.060242, held-out 0.059333 µm)
CLASSICAL = {
    "train_rms": 0.06025963312115152,
    "held_out_rms": 0.059437256562656894,
    "thresholds": [0.0, 1.6389433333333345, 6.484103333333336, 14.323725000000003,
                   24.81521333333333, 37.50000666666666, 51.823725499999995, 67.16036683333334,
                   82.83963316666666, 98.1762745, 112.49999333333332, 125.18478666666667,
                   135.676275, 143.51589666666666, 148.36105666666668],
    "weights": [0.02552074639693446, 0.06781199566090655, 0.005030895296077757,
                0.0017444261063879925, 0.012147215697588053, 0.00559625699719557,
                0.0018186617711513364, 0.011580403689685343, 0.004184835077607451,
                0.003825895819480748, 0.007081080607182456, 0.015418140884606989,
                -0.0015439798016072253, 0.016725337130580394, 0.07514968161205321],
    "offset": -0.07177963487937526,
}
PREISACH = {
    "train_rms": 0.10542473814448818,
    "held_out_rms": 0.10077247625131194,
    "weights_trace": 12.288058687500117,
    "weights_sum": 23.125441507745705,
    "reversible": [0.017217287334889503],
    "offset": -0.028667124883240015,
}
GENERALIZED = {"train_rms": 0.08872749167975039, "held_out_rms": 0.08545307284131176}
RANGE = 39.451599          # the record's output range [µm]
SOLVER = 1e-6              # relative, see the module notes
SEARCH = 1e-2


@pytest.fixture(scope="module")
def record():
    return read_record(bundled_data(), input=2, output=1, time=0)


def test_record_is_the_reference_one(record):
    assert float(np.ptp(record.y)) == pytest.approx(RANGE, rel=1e-12)


def test_classical_pi_holds_the_previous_fit(record):
    fit = identify_records(record)
    comp = fit.model.components[0][0]
    assert fit.structure == [["pi"]] and fit.output_map == "none"
    assert fit.train[0]["rms"] == pytest.approx(CLASSICAL["train_rms"], rel=SOLVER)
    assert fit.validation[0]["rms"] == pytest.approx(CLASSICAL["held_out_rms"], rel=SOLVER)
    assert np.allclose(comp.thresholds, CLASSICAL["thresholds"], rtol=1e-12, atol=0)
    w_ref = np.array(CLASSICAL["weights"])
    assert np.max(np.abs(comp.weights - w_ref)) <= SOLVER * np.max(np.abs(w_ref))
    assert abs(float(fit.model.output_offset[0]) - CLASSICAL["offset"]) <= SOLVER * RANGE


def test_preisach_holds_the_previous_fit(record):
    # the previous code's search chose lambda 0.001 on this record (the smallest of its grid);
    # the search now goes on below the grid (0.0003 here, held-out 0.2560 against 0.2563 %),
    # so the numerics are held at the lambda it chose, on the equal cells it had
    # the record was not taken after the demagnetising cycle: from the ideal demagnetised state
    fit = PreisachIdentifier(12, smoothing=0.001, grid="uniform",
                             record_start="rest").fit(record).fit_   # its grid
    comp = fit.model.components[0][0]
    assert fit.structure == [["preisach"]]
    assert fit.train[0]["rms"] == pytest.approx(PREISACH["train_rms"], rel=SOLVER)
    assert fit.validation[0]["rms"] == pytest.approx(PREISACH["held_out_rms"], rel=SOLVER)
    scale = PREISACH["weights_trace"]
    assert abs(float(np.trace(comp.weights)) - PREISACH["weights_trace"]) <= SOLVER * scale
    assert abs(float(comp.weights.sum()) - PREISACH["weights_sum"]) <= SOLVER * scale
    # the reversible (linear) term is held by what it adds to the output over the record's
    # input range, like the offset: its coefficient [µm/V] is the least determined of the
    # rank-deficient problem (measured 1.4e-6 relative between two BLAS builds, 3e-6 µm)
    u_span = float(np.max(np.abs(record.u)))
    assert np.all(np.abs(comp.reversible - PREISACH["reversible"]) * u_span <= SOLVER * RANGE)
    assert abs(comp.offset - PREISACH["offset"]) <= SOLVER * RANGE


def test_generalized_pi_holds_the_previous_errors(record):
    # the default start alone: the search the reference numbers came from
    # the record was not taken after a demagnetising cycle (its actuator rests at -1.65 µm,
    # not where a demagnetised one would): its plays start at rest, as in the reference fit
    fit = GeneralizedPIIdentifier(n_plays=8, n_starts=1, record_start="rest").fit(record).fit_
    assert fit.structure == [["generalized"]]
    # a search path that ends elsewhere may end lower: measured 1.1 % (train) and 1.4 %
    # (held out) lower with another processor's BLAS kernels; it must never end worse. Since
    # the residual is scaled to the output's RMS (a fit that does not depend on the output's
    # unit) the search ends 4.5 % (train, 0.0847 µm) and 5.2 % (held out, 0.0810 µm) lower,
    # where the four starts ended before: the lower bound allows 6 %
    for got, ref in ((fit.train[0]["rms"], GENERALIZED["train_rms"]),
                     (fit.validation[0]["rms"], GENERALIZED["held_out_rms"])):
        assert ref * (1 - 6 * SEARCH) <= got <= ref * (1 + SEARCH)


def test_generalized_pi_from_four_starts_ends_lower_on_the_real_record(record):
    """The default fit (four starts screened) on the bundled record: its training RMS below the
    single start's reference by more than the 3 % a search path moves it (measured 0.0852 µm
    against the reference's 0.0887 and 0.0866 from the default start alone today), its
    held-out RMS no worse than that search's tolerance above the reference (0.0815 µm against
    0.0833 from the default start alone)."""
    fit = identify_gpi_records(record, n_plays=8, record_start="rest")     # as above
    assert fit.structure == [["generalized"]]
    assert fit.train[0]["rms"] < GENERALIZED["train_rms"] * (1 - 3 * SEARCH)
    assert fit.validation[0]["rms"] <= GENERALIZED["held_out_rms"] * (1 + SEARCH)


@pytest.mark.parametrize("partition", ["time", "input"])
def test_a_classical_pi_from_records_has_no_dead_band_at_a_reversal(record, partition):
    """Every partition's first threshold is 0: the model answers 1 % of its span at once,
    from rest and after a reversal. The time partition started at 1.44 V on this record's
    +-75 V: the output held for 2.9 V after every reversal, and an inverse crossed that in
    one jump (a per-axis drive stepped 1.15 V at every reversal on a 60 V stage)."""
    model = identify_records(record, partition=partition).model
    comp = model.components[0][0]
    assert comp.thresholds[0] == 0.0 and comp.weights[0] > 0
    u = np.array([0.0, 1.5, 60.0, 58.5])          # from rest, and 1.5 V back from a crest
    y, _ = comp.simulate(u)
    assert y[1] - y[0] >= 1.5 * comp.weights[0] * (1 - 1e-12)
    assert y[2] - y[3] >= 1.5 * comp.weights[0] * (1 - 1e-12)


@pytest.mark.parametrize("bounds", [None, "nonnegative"])
@pytest.mark.parametrize("output_map", ["none", "deadzone"])
def test_a_direct_transfer_always_starts_its_loops_with_a_slope(tmp_path, bounds, output_map):
    """An actuator whose loops start flat (a backlash-like PI: no linear term, the output
    held while the input turns by 2 x 0.6 V) fitted with the threshold-0 play of the
    records route: least squares puts that play's weight at 0 (an outside stage's identify
    --model classical wrote exactly 0 under the output map's nonnegative bounds), a model
    no compensator inverts and export refused. The weight is bounded below by a tenth of
    the secant, the least-squares slope of the output against the input (computed here
    with numpy), as every cumulative sum is with bounds = 'monotone'."""
    from hammerstein.io.datafiles import read_records
    from hammerstein.models.hysteresis import MultivariablePI, PrandtlIshlinskii
    from hammerstein.signals.excitation import decreasing_sine

    r = np.array([0.6, 1.5, 3.0, 5.0, 7.0])
    w = np.array([1.2, 0.5, 0.4, 0.3, 0.2])
    act = MultivariablePI([[PrandtlIshlinskii(r, w), None], [None, PrandtlIshlinskii(r, w)]],
                          input_names=["ux", "uy"], output_names=["x", "y"])
    paths = []
    for k in range(2):
        t, one, _ = decreasing_sine(5e-4, 10.0)
        u = np.zeros((2, t.size))
        u[k] = one
        y = act.simulate(u)[0]
        paths.append(tmp_path / f"rec-{k}.csv")
        np.savetxt(paths[-1], np.column_stack([t, u.T, y.T]), delimiter=",",
                   header="t,ux,uy,x,y", comments="")
    records = [read_records(p, "ux,uy", "x,y", time="t") for p in paths]
    fit = identify_records(records, bounds=bounds, output_map=output_map, partition="time")
    for k in range(2):
        comp = fit.model.components[k][k]
        rec = records[k]
        secant = np.polyfit(rec.u[k], rec.y[k], 1)[0]
        assert comp.thresholds[0] == 0.0
        assert comp.weights[0] >= 0.1 * secant * 0.98, (comp.weights[0], secant)
