"""The report's Dynamics section lists the order search that chose G, creep refit or not.

``identify``'s pipeline fits G, then the creep, then the hysteresis again without the
creep and G once more at the order the first search chose (the search is not repeated).
The report listed that last fit's one order; it lists the search (every candidate order
and its held-out fit), as ``identify`` prints it.
"""

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from hammerstein.io.presets import load_plant
from hammerstein.report.identified import order_words
from hammerstein.scenario.identify_tables import identify_table
from hammerstein.scenario.identification import excitation_records
from route_files import run_files_scenario, write_record

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def test_the_words_list_the_summary_search_over_the_one_order_refitted():
    refit = SimpleNamespace(order_=4, candidate_order_=4, orders_=np.array([4]),
                            validation_fit_=np.array([97.0]), candidates_=[{"order": 4}])
    summary = {"candidate_order": 4, "chosen_on": "held-out records m-validation",
               "candidates": [{"order": 2, "held_out_fit_percent": 61.25},
                              {"order": 3, "rejected": "unstable"},
                              {"order": 4, "held_out_fit_percent": 97.5}]}
    assert order_words(refit) == ("order 4; held-out (validation) fit by the one order tried: "
                                  "4: 97.00 %")
    assert order_words(refit, summary) == (
        "order 4; held-out (validation) fit by candidate order: 2: 61.25 %, "
        "3: rejected (unstable), 4: 97.50 % (chosen on held-out records m-validation)")



@pytest.mark.slow
def test_a_files_table_with_creep_reports_the_whole_order_search(tmp_path):
    plant = load_plant(SCENARIOS / "presets" / "realistic-gpi.toml")
    recs = excitation_records(plant, identify_table({
        "records": "excitation", "model": "generalized", "creep": True, "frequency": 5.0,
        "hold": 0.25, "multisine_periods": 2}))
    names = {kind: [Path(write_record(tmp_path / f"{kind}-{i}.csv", r)).name for i, r in enumerate(rs)]
             for kind, rs in recs.items()}
    report = run_files_scenario(
        tmp_path, (SCENARIOS / "presets" / "realistic-gpi.toml").read_text(),
        'kind = "hammerstein"\nmodel = "identified"\ndynamics = "identified"',
        f'''records = "files"
model = "generalized"
hysteresis_records = {names["hysteresis"]}
dynamics_records = {names["dynamics"]}
creep_records = {names["creep"]}''', "{ kind = \"circle\", radius = 12, frequency = 40, periods = 4 }")
    line = next(x for x in (report / "report.md").read_text().splitlines()
                if "held-out (validation) fit by" in x)
    tried = line.split("fit by candidate order: ")[1]
    assert len(tried.split(", ")) >= 3, line
    assert "order searched on the model outputs before the creep was identified" in line
