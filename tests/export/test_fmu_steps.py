"""The FMU's communication steps: 0 is a no-op (FMI 2.0 allows it), n T runs n samples and
says once, through the logger, that the inputs are then held over the step."""

from __future__ import annotations

import numpy as np
import pytest

from hammerstein.export import export_c
from hammerstein.export.fmu import build_fmu, platform_folder

from conftest import needs_cc
from test_c_equivalence import T, build, circle

fmpy = pytest.importorskip("fmpy", reason="fmpy (extra [export]) is needed to run the FMU")
fmi2 = pytest.importorskip("fmpy.fmi2")

pytestmark = [needs_cc, pytest.mark.skipif(platform_folder() is None,
                                           reason="unknown platform for an FMU binary")]


@pytest.fixture(scope="module")
def fmu(tmp_path_factory):
    code = export_c(build("hammerstein"), "steps", T)
    path = tmp_path_factory.mktemp("fmu") / "steps.fmu"
    path.write_bytes(build_fmu(code, "test")[0])
    md = fmpy.read_model_description(str(path))
    return str(path), md, fmpy.extract(str(path)), code


class _Run:
    """One instance with a logger that records (status, category, message)."""

    def __init__(self, fmu):
        path, md, unzipped, code = fmu
        self.log = []

        def logger(env, name, status, category, message):
            self.log.append((status, category.decode(), message.decode()))
        self._logger = fmi2.fmi2CallbackLoggerTYPE(logger)     # kept alive with the instance
        cb = fmi2.fmi2CallbackFunctions()
        cb.logger = self._logger
        cb.allocateMemory = fmi2.fmi2CallbackAllocateMemoryTYPE(fmi2.calloc)
        cb.freeMemory = fmi2.fmi2CallbackFreeMemoryTYPE(fmi2.free)
        self._cb = cb
        vr = {v.name: v.valueReference for v in md.modelVariables}
        self.refs = [vr[f"reference_{n}"] for n in code.output_names]
        self.outs = [vr[f"voltage_{n}"] for n in code.input_names]
        self.slave = fmi2.FMU2Slave(guid=md.guid, unzipDirectory=unzipped,
                                    modelIdentifier=md.coSimulation.modelIdentifier,
                                    instanceName="steps")
        self.slave.instantiate(callbacks=cb)
        self.slave.setupExperiment(startTime=0.0)
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()
        self.t = 0.0

    def step(self, reference, n):
        self.slave.setReal(self.refs, list(reference))
        self.slave.doStep(currentCommunicationPoint=self.t, communicationStepSize=n * T)
        self.t += n * T
        return np.array(self.slave.getReal(self.outs))

    def close(self):
        self.slave.terminate()
        self.slave.freeInstance()


def test_a_zero_step_changes_nothing(fmu):
    yr = circle(120)
    plain, zeros = _Run(fmu), _Run(fmu)
    try:
        u = np.array([plain.step(yr[:, k], 1) for k in range(120)])
        v = []
        for k in range(120):
            before = zeros.step(yr[:, k], 0)          # refused before: "must be a multiple"
            assert k == 0 or np.array_equal(before, v[-1])      # the outputs stay
            v.append(zeros.step(yr[:, k], 1))
        assert np.abs(u).max() > 1.0            # a real drive, not zeros on both sides
        assert np.array_equal(np.array(v), u)
        assert not any(s >= 3 for s, _, _ in zeros.log)          # no error logged
    finally:
        plain.close()
        zeros.close()


def test_a_step_of_several_periods_is_said_once(fmu):
    yr = circle(80)
    one, four = _Run(fmu), _Run(fmu)
    try:
        for k in range(80):
            one.step(yr[:, k], 1)
        for k in range(0, 80, 4):
            four.step(yr[:, k], 4)
        assert one.log == []
        notes = [m for s, c, m in four.log if "several sampling periods" in m]
        assert len(notes) == 1 and all(s == 1 for s, _, _ in four.log)     # fmi2Warning, once
    finally:
        one.close()
        four.close()
