"""An identification's plant in memory is the plant of the preset ``identify`` writes.

A Python user had to write the preset and read it back: ``HammersteinPlant(result.model,
T, result.dynamics, creep=result.creep)`` raised ``TypeError: 'CreepIdentifier' object is
not iterable``. ``IdentificationResult.plant`` builds it; the expectation is the file
route (:func:`save_model` with the result's tables and the records' ``[amplifier]``, then
:func:`load_plant`).
"""

import numpy as np
import pytest

from hammerstein.exceptions import HysteresisError
from hammerstein.identification.identification_pipeline import PipelineOptions, identify_pipeline
from hammerstein.io.presets import load_plant, save_model
from hammerstein.models.amplifier import records_amplifier_table
from hammerstein.models.plant import HammersteinPlant

from test_preisach_identification import T, preisach_actuator, records


def test_the_plant_in_memory_is_the_preset_identify_writes(tmp_path):
    recs = records(preisach_actuator(), noise=0.02)
    res = identify_pipeline(recs, PipelineOptions(model="preisach", preisach_levels=8))
    names = list(res.model.input_names)
    extra = dict(res.tables() or {})
    extra["amplifier"] = records_amplifier_table(recs, names)
    extra["preset"] = {"name": "id", "sampling_period": T}
    save_model(res.model, tmp_path / "id.toml", extra=extra)
    from_file = load_plant(tmp_path / "id.toml")
    plant = res.plant(T, records=recs)
    u = recs[0].u[:, :3000]
    np.testing.assert_allclose(plant.simulate(u, plant.rest_state())[0],
                               from_file.simulate(u, from_file.rest_state())[0], rtol=0,
                               atol=1e-9)
    for a, b in zip(plant.amplifier.channels, from_file.amplifier.channels):
        assert (a.low, a.high, a.slew_rate) == (b.low, b.high, b.slew_rate)
    lo = np.min([r.u.min(axis=1) for r in recs], axis=0)
    hi = np.max([r.u.max(axis=1) for r in recs], axis=0)
    np.testing.assert_allclose(np.asarray(plant.hysteresis.input_range), np.vstack([lo, hi]).T)


def test_an_identifications_creep_given_to_the_plant_is_named():
    # HammersteinPlant(model, T, G, creep=result.creep) raised TypeError ('CreepIdentifier'
    # object is not iterable)

    class CreepIdentifier:
        creeps_ = [None, None]

    model = load_plant("rakotondrabe-2dof", dynamics=False).hysteresis
    with pytest.raises(HysteresisError, match="found CreepIdentifier .* IdentificationResult.plant"):
        HammersteinPlant(model, 5e-5, None, creep=CreepIdentifier())
