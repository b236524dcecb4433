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
(models, compensators, identification), :mod:`hammerstein.scenario`,
:mod:`hammerstein.report`, :mod:`hammerstein.runner`, :mod:`hammerstein.cli`.
"""

from __future__ import annotations

import importlib

from hammerstein.exceptions import (BaselineError, CompensatorDivergence, CompensatorError,
                                    ConvergenceWarning, DataFileError, DynamicsError, ExportError,
                                    FileLimitError, OutputError,
                                    HammersteinError, HammersteinWarning, HysteresisError,
                                    IdentificationError, Invalid, NestedInvalid, PresetError,
                                    RangeWarning, ScenarioError, SignalError)
from hammerstein.exceptions import AmplifierError, AmplifierWarning, FeedbackError

__version__ = "0.1.0"

#: public name -> module that defines it (imported on first access)
_LAZY = {
    # core: models, compensators, stability, dynamics
    "ConvergenceReport": "hammerstein.core.compensators",
    "InverseMultiplicativeCompensator": "hammerstein.core.compensators",
    "PerAxisInverseCompensator": "hammerstein.core.compensators",
    "StaticGainCompensator": "hammerstein.core.compensators",
    "check_reference_range": "hammerstein.core.compensators",
    "convergence_report": "hammerstein.core.compensators",
    "diagonal_compensator": "hammerstein.core.compensators",
    "midpoint_gains": "hammerstein.core.compensators",
    "InversePI": "hammerstein.core.inverse",
    "InversePlay": "hammerstein.core.inverse",
    "kuhnen_inverse": "hammerstein.core.inverse",
    "kuhnen_inverse_parameters": "hammerstein.core.inverse",
    "literal_gain_equivalent_scale": "hammerstein.core.stability",
    "stability_map": "hammerstein.core.stability",
    "bandwidths_hz": "hammerstein.core.dynamics",
    "bending_modes": "hammerstein.core.dynamics",
    "discretize": "hammerstein.core.dynamics",
    "MultivariablePI": "hammerstein.core.hysteresis",
    "OutputMap": "hammerstein.core.hysteresis",
    "PrandtlIshlinskii": "hammerstein.core.hysteresis",
    "play": "hammerstein.core.hysteresis",
    "HammersteinPlant": "hammerstein.core.plant",
    "bundled_presets": "hammerstein.core.presets",
    "load_model": "hammerstein.core.presets",
    "load_plant": "hammerstein.core.presets",
    "model_from_table": "hammerstein.core.presets",
    "model_to_table": "hammerstein.core.presets",
    "save_model": "hammerstein.core.presets",
    "ClosedFormPI": "hammerstein.core.identification",
    "LeastSquaresPI": "hammerstein.core.identification",
    "MultivariableIdentifier": "hammerstein.core.identification",
    "fit_report": "hammerstein.core.identification",
    "Sensor": "hammerstein.core.sensors",
    "characterize": "hammerstein.core.sensors",
    "identify_plant": "hammerstein.core.sensors",
    "Record": "hammerstein.core.datafiles",
    "read_record": "hammerstein.core.datafiles",
    # dynamics compensation: the Hammerstein compensator (ZPETC / stable inversion)
    "HammersteinCompensator": "hammerstein.core.hammerstein_compensator",
    "INVERSIONS": "hammerstein.core.hammerstein_compensator",
    "fade_in": "hammerstein.core.hammerstein_compensator",
    "ZPETCInverse": "hammerstein.core.inversion",
    "inverse_system": "hammerstein.core.inversion",
    # identification of the linear dynamics and from measured records
    "DynamicsIdentifier": "hammerstein.core.lti",
    "identify_dynamics": "hammerstein.core.lti",
    "identify_record": "hammerstein.core.record_identification",
    "identify_records": "hammerstein.core.record_identification",
    # reference and drive generators, (n_signals, n_samples) arrays
    "time_vector": "hammerstein.core.references",
    "sine": "hammerstein.core.references",
    "sine_drive": "hammerstein.core.references",
    "triangle": "hammerstein.core.references",
    "triangle_drive": "hammerstein.core.references",
    "circle": "hammerstein.core.references",
    "spiral": "hammerstein.core.references",
    "lissajous": "hammerstein.core.references",
    "lissajous_period": "hammerstein.core.references",
    "raster": "hammerstein.core.references",
    # metrics
    "tracking_metrics": "hammerstein.core.metrics",
    "open_loop_metrics": "hammerstein.core.metrics",
    "euclidean_error": "hammerstein.core.metrics",
    "peak_to_peak": "hammerstein.core.metrics",
    "hysteresis_width": "hammerstein.core.metrics",
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
    "drive_signal": "hammerstein.core.drive",
    "IterativeLearning": "hammerstein.core.ilc",
    "write_readme": "hammerstein.report.replication",
    # export: the compensators as C99 code / FMUs
    "export_c": "hammerstein.export",
}

_EXCEPTIONS = ["HammersteinError", "HammersteinWarning", "HysteresisError", "SignalError",
               "CompensatorError", "CompensatorDivergence", "ConvergenceWarning",
               "RangeWarning", "DynamicsError", "PresetError", "IdentificationError",
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
