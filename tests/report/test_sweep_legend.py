"""Sweep figures name compensators in words, not by their scenario labels ("mv-50Hz")."""

from types import SimpleNamespace

from hammerstein.report.sweeps import compensator_legend


def _result(name, table):
    return SimpleNamespace(name=name, spec=SimpleNamespace(compensator_spec=table))


def test_labels_become_words_and_twins_keep_their_label():
    spec = SimpleNamespace(cases=[{"case": "rms-mv-50Hz-x-10Hz", "compensator": "mv-50Hz"},
                                  {"case": "rms-mv2-x-10Hz", "compensator": "mv2"},
                                  {"case": "rms-pa-x-10Hz", "compensator": "pa"},
                                  {"case": "rms-st-x-10Hz", "compensator": "st"}])
    ident = {"frequency": 50.0, "method": "least-squares"}
    results = [_result("rms-mv-50Hz-x-10Hz", {"kind": "multivariable", "model": "identified",
                                              "identify": ident, "gain": "midpoint"}),
               _result("rms-mv2-x-10Hz", {"kind": "multivariable", "model": "identified",
                                          "identify": ident, "gain": "secant"}),
               _result("rms-pa-x-10Hz", {"kind": "per-axis", "model": "plant"}),
               _result("rms-st-x-10Hz", {"kind": "static-gain", "model": "presets/a.toml"})]
    words = compensator_legend(spec, results)
    assert words == {"mv-50Hz": "multivariable, identified at 50 Hz (mv-50Hz)",
                     "mv2": "multivariable, identified at 50 Hz (mv2)",
                     "pa": "per-axis, plant's model",
                     "st": "static-gain, model a.toml"}
