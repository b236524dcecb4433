"""
Compensate a circle
===================

Ask the paper's 2-DOF actuator to draw a 30 µm circle at 50 Hz. Without
compensation (voltages proportional to the reference) the hysteresis and the
cross-coupling distort it; the multivariable inverse multiplicative
compensator (Theorem 4.1 of the paper, normalised by its gain K) removes
both; the Hammerstein compensator also inverts the bending modes.
"""

import matplotlib.pyplot as plt
import numpy as np

import hammerstein as hs

plant = hs.load_plant("rakotondrabe-2dof")
T = plant.sampling_period
t, reference = hs.circle(T, radius=30.0, frequency=50.0, periods=6)
model = plant.hysteresis                     # the actuator's own model (no identification error)

compensators = {
    "static gain": hs.StaticGainCompensator(model),
    "multivariable": hs.InverseMultiplicativeCompensator(model, gain="midpoint"),
    "Hammerstein": hs.HammersteinCompensator(model, plant.dynamics, sampling_period=T),
}

# %%
# Each compensator drives the simulated actuator; the error is measured after
# two periods of settling.
settled = t >= 2 / 50.0
fig, axes = plt.subplots(1, 3, figsize=(11, 4), layout="constrained", sharex=True, sharey=True)
period = int(round(1 / (50.0 * T)))          # samples of one period of the circle
for ax, (label, compensator) in zip(axes, compensators.items()):
    if isinstance(compensator, hs.HammersteinCompensator):
        # the inverse of the dynamics reads the reference a few samples ahead
        # and fades it in over one period, from rest
        result = compensator.run_reference(plant, reference, period_samples=period,
                                           fade_samples=period)
    else:
        result = hs.simulate_chain(compensator, plant, reference)
    error = np.linalg.norm(reference - result.outputs, axis=0)[settled].max()
    ax.plot(*reference[:, settled], "k--", lw=0.8, label="reference")
    ax.plot(*result.outputs[:, settled], lw=1, label="actuator")
    ax.set(title=f"{label}: max error {100 * error / 30:.1f} %", xlabel="x [µm]",
           aspect="equal")
    print(f"{label}: max Euclidean error {error:.2f} µm ({100 * error / 30:.1f} % of the radius)")
axes[0].set_ylabel("y [µm]")
axes[0].legend(loc="lower left")
plt.show()
