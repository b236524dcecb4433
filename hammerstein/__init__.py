"""hammerstein: multivariable Prandtl-Ishlinskii hysteresis of piezoelectric actuators.

Model rate-independent hysteresis and cross-couplings with a multivariable
classical Prandtl-Ishlinskii (PI) model, identify it, cancel it with the
inverse multiplicative feedforward compensator, and simulate the result on a
Hammerstein actuator (multivariable PI + python-control linear dynamics).

``import hammerstein`` is light: it loads the exception classes only. Every
other name below is imported from its module on first access (PEP 562), so
numba, python-control, pandas and matplotlib load only when a name that
needs them is used.

Layers (each imports only the ones before it): :mod:`hammerstein.exceptions`,
:mod:`hammerstein.simulation` (stepping on arrays), :mod:`hammerstein.core`
(numbers, safe file writes, table schemas), :mod:`hammerstein.models`
(hysteresis, creep, dynamics, plant), :mod:`hammerstein.io` (presets, data
files), :mod:`hammerstein.signals` (references, excitation, metrics),
:mod:`hammerstein.identification`, :mod:`hammerstein.compensation`
(compensators, drives, learning, feedback), :mod:`hammerstein.scenario`,
:mod:`hammerstein.report`, :mod:`hammerstein.runner`, :mod:`hammerstein.cli`;
:mod:`hammerstein.export` reads models and compensators.
"""

from __future__ import annotations

import importlib

from hammerstein.exceptions import (BaselineError, CompensatorDivergence, CompensatorError,
                                    ConvergenceWarning, DataFileError, DynamicsError, ExportError,
                                    FileLimitError, OutputError,
                                    HammersteinError, HammersteinWarning, HysteresisError,
                                    IdentificationError, Invalid, NestedInvalid, PresetError,
                                    RangeWarning, ScenarioError, SignalError)
from hammerstein.exceptions import AmplifierError, AmplifierWarning, DynamicsWarning, FeedbackError

from hammerstein.core._version import VERSION as __version__  # noqa: E402

#: public name -> module that defines it (imported on first access)
_LAZY = {
    # core: models, compensators, stability, dynamics
    "ConvergenceReport": "hammerstein.compensation.compensators",
    "InverseMultiplicativeCompensator": "hammerstein.compensation.compensators",
    "PerAxisInverseCompensator": "hammerstein.compensation.compensators",
    "StaticGainCompensator": "hammerstein.compensation.compensators",
    "check_reference_range": "hammerstein.compensation.reference_range",
    "convergence_report": "hammerstein.compensation.compensators",
    "diagonal_compensator": "hammerstein.compensation.compensators",
    "midpoint_gains": "hammerstein.compensation.compensators",
    "InversePI": "hammerstein.compensation.inverse",
    "InversePlay": "hammerstein.compensation.inverse",
    "kuhnen_inverse": "hammerstein.compensation.inverse",
    "kuhnen_inverse_parameters": "hammerstein.compensation.inverse",
    "literal_gain_equivalent_scale": "hammerstein.compensation.stability",
    "stability_map": "hammerstein.compensation.stability",
    "bandwidths_hz": "hammerstein.models.dynamics",
    "bending_modes": "hammerstein.models.dynamics",
    "discretize": "hammerstein.models.dynamics",
    "MultivariablePI": "hammerstein.models.hysteresis",
    "OutputMap": "hammerstein.models.output_map",
    "PrandtlIshlinskii": "hammerstein.models.hysteresis",
    "play": "hammerstein.models.hysteresis",
    "HammersteinPlant": "hammerstein.models.plant",
    "bundled_presets": "hammerstein.io.presets",
    "load_model": "hammerstein.io.presets",
    "load_plant": "hammerstein.io.presets",
    "model_from_table": "hammerstein.io.model_table",
    "model_to_table": "hammerstein.io.model_table",
    "save_model": "hammerstein.io.presets",
    "ClosedFormPI": "hammerstein.identification.identification",
    "LeastSquaresPI": "hammerstein.identification.identification",
    "MultivariableIdentifier": "hammerstein.identification.identification",
    "fit_report": "hammerstein.identification.identification",
    "Sensor": "hammerstein.identification.sensors",
    "characterize": "hammerstein.identification.sensors",
    "identify_plant": "hammerstein.identification.sensors",
    "Record": "hammerstein.io.datafiles",
    "read_record": "hammerstein.io.datafiles",
    # dynamics compensation: the Hammerstein compensator (ZPETC / stable inversion)
    "HammersteinCompensator": "hammerstein.compensation.hammerstein_compensator",
    "INVERSIONS": "hammerstein.compensation.hammerstein_compensator",
    "fade_in": "hammerstein.compensation.hammerstein_compensator",
    "ZPETCInverse": "hammerstein.compensation.inversion",
    "inverse_system": "hammerstein.compensation.inversion",
    "LookaheadInverse": "hammerstein.compensation.lookahead",
    # identification of the linear dynamics and from measured records
    "DynamicsIdentifier": "hammerstein.models.lti",
    "identify_dynamics": "hammerstein.models.lti",
    "identify_record": "hammerstein.identification.record_identification",
    "identify_records": "hammerstein.identification.record_identification",
    # reference and drive generators, (n_signals, n_samples) arrays
    "time_vector": "hammerstein.signals.references",
    "sine": "hammerstein.signals.references",
    "sine_drive": "hammerstein.signals.references",
    "triangle": "hammerstein.signals.references",
    "triangle_drive": "hammerstein.signals.references",
    "circle": "hammerstein.signals.references",
    "spiral": "hammerstein.signals.references",
    "lissajous": "hammerstein.signals.references",
    "lissajous_period": "hammerstein.signals.references",
    "raster": "hammerstein.signals.references",
    # metrics
    "tracking_metrics": "hammerstein.signals.metrics",
    "open_loop_metrics": "hammerstein.signals.metrics",
    "euclidean_error": "hammerstein.signals.metrics",
    "peak_to_peak": "hammerstein.signals.metrics",
    "hysteresis_width": "hammerstein.signals.metrics",
    # simulation
    "ChainResult": "hammerstein.simulation",
    "simulate_chain": "hammerstein.simulation",
    "simulate_chain_batch": "hammerstein.simulation",
    "simulate_compensator": "hammerstein.simulation",
    "simulate_hysteresis": "hammerstein.simulation",
    "simulate_plant": "hammerstein.simulation",
    # scenarios, runner, reports
    "progress": "hammerstein.scenario.progress",
    "comparison_model": "hammerstein.scenario.identification",
    "identified_model": "hammerstein.scenario.identification",
    "identify_table": "hammerstein.scenario.identify_tables",
    "save_identified_models": "hammerstein.report.model_files",
    "load_scenario": "hammerstein.scenario.resolve",
    "resolve_scenario": "hammerstein.scenario.resolve",
    "validate_scenario": "hammerstein.scenario.validate",
    "COMPENSATORS": "hammerstein.scenario.registry",
    "ScenarioOutcome": "hammerstein.runner",
    "build_compensator": "hammerstein.scenario.registry",
    "run_scenario": "hammerstein.runner",
    "run_scenarios": "hammerstein.runner",
    "compare_metrics": "hammerstein.scenario.regression",
    "read_baseline": "hammerstein.scenario.regression",
    "resolve_tolerances": "hammerstein.scenario.regression",
    "write_baseline": "hammerstein.scenario.regression",
    "SweepSpec": "hammerstein.scenario.sweeps",
    "expand_sweeps": "hammerstein.scenario.sweeps",
    "run_cases": "hammerstein.scenario.sweeps",
    "sweep_table": "hammerstein.report.sweeps",
    "paper_comparison": "hammerstein.report.replication",
    "replicate": "hammerstein.runner",
    "drive_signal": "hammerstein.compensation.drive",
    "compensate_reference": "hammerstein.scenario.hardware_route",
    "IterativeLearning": "hammerstein.compensation.ilc",
    "write_readme": "hammerstein.report.replication",
    # export: the compensators as C99 code / FMUs
    "export_c": "hammerstein.export",
}

_EXCEPTIONS = ["HammersteinError", "HammersteinWarning", "HysteresisError", "SignalError",
               "CompensatorError", "CompensatorDivergence", "ConvergenceWarning",
               "RangeWarning", "DynamicsError", "DynamicsWarning", "PresetError", "IdentificationError",
               "DataFileError", "ScenarioError", "BaselineError", "Invalid", "NestedInvalid",
               "FileLimitError", "OutputError", "ExportError", "AmplifierError", "AmplifierWarning",
               "FeedbackError"]

__all__ = sorted(_EXCEPTIONS + list(_LAZY)) + ["__version__"]


def __getattr__(name):
    """Import a public name from its module on first access (PEP 562)."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'hammerstein' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value            # later accesses skip __getattr__
    return value


def __dir__():
    """Public names, loaded or not, for ``dir(hammerstein)`` and completion."""
    return sorted(set(globals()) | set(__all__))
