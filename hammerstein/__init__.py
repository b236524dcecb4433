"""hammerstein: multivariable Prandtl-Ishlinskii hysteresis of piezoelectric actuators.

Model rate-independent hysteresis and cross-couplings with a multivariable
classical Prandtl-Ishlinskii (PI) model, identify it, cancel it with the
inverse multiplicative feedforward compensator, and simulate the result on a
Hammerstein actuator (multivariable PI + python-control linear dynamics).
"""

from hammerstein.core.compensators import (CompensatorDivergence, CompensatorError, ConvergenceReport,
                           ConvergenceWarning, InverseMultiplicativeCompensator, midpoint_gains,
                           convergence_report)
from hammerstein.core.compensators import (PerAxisInverseCompensator, RangeWarning, StaticGainCompensator, check_reference_range, diagonal_compensator)
from hammerstein.core.inverse import InversePI, InversePlay, kuhnen_inverse, kuhnen_inverse_parameters
from hammerstein.core.stability import literal_gain_equivalent_scale, stability_map
from hammerstein.core.dynamics import DynamicsError, bandwidths_hz, bending_modes, discretize
from hammerstein.core.hysteresis import HysteresisError, MultivariablePI, PrandtlIshlinskii, play
from hammerstein.core.plant import HammersteinPlant
from hammerstein.core.presets import (PresetError, bundled_presets, load_model, load_plant, model_from_table,
                      model_to_table, save_model)
from hammerstein.simulation import ChainResult, simulate_chain, simulate_compensator, simulate_plant
from hammerstein.simulation import simulate_chain_batch, simulate_hysteresis
from hammerstein.scenario.progress import progress
from hammerstein.core.identification import ClosedFormPI, IdentificationError, LeastSquaresPI, MultivariableIdentifier, fit_report
from hammerstein.core.sensors import Sensor, characterize, identify_plant
from hammerstein.core.datafiles import DataFileError, Record, read_record
from hammerstein.scenario.identified import comparison_model, identified_model, identify_table, save_identified_models
from hammerstein.scenario.schema import ScenarioError
from hammerstein.scenario.validate import validate_scenario
from hammerstein.scenario.resolve import load_scenario, resolve_scenario
from hammerstein.scenario.registry import COMPENSATORS, build_compensator
from hammerstein.runner import ScenarioOutcome, replicate, run_scenario, run_scenarios
from hammerstein.scenario.regression import BaselineError, compare_metrics, read_baseline, resolve_tolerances, write_baseline
from hammerstein.scenario.sweeps import SweepSpec, expand_sweeps, run_cases
from hammerstein.report.sweeps import sweep_table
from hammerstein.report.replication import paper_comparison, write_readme

__version__ = "0.1.0"
