"""
The paper's 2-DOF actuator, open loop
=====================================

The bundled preset ``rakotondrabe-2dof`` is the piezoelectric cantilever of
the paper: a multivariable classical Prandtl-Ishlinskii (PI) hysteresis from
the two voltages ``ux``, ``uy`` [V] to the two deflections ``x``, ``y`` [µm],
followed by its bending modes. Driving one input with a sine shows the
hysteresis of its direct transfer and the cross-coupling to the other axis
(the paper's Fig. 5).
"""

import matplotlib.pyplot as plt
import numpy as np

import hammerstein as hs

plant = hs.load_plant("rakotondrabe-2dof")          # PI hysteresis + bending modes
T = plant.sampling_period
print(f"inputs {plant.hysteresis.input_names}, outputs {plant.hysteresis.output_names}, T = {T * 1e6:.0f} µs")

# %%
# A 10 V, 1 Hz sine on each input in turn (slow: the modes play no part).
fig, axes = plt.subplots(2, 2, figsize=(8, 6.5), layout="constrained")
for col, name in enumerate(plant.hysteresis.input_names):
    t, u = hs.sine_drive(T, plant.hysteresis.input_names, name, amplitude=10.0, frequency=1.0, periods=2)
    y, _ = hs.simulate_plant(plant, u)
    for row, out in enumerate(plant.hysteresis.output_names):
        ax = axes[row, col]
        ax.plot(u[col], y[row], lw=1)
        kind = "direct transfer" if row == col else "cross-coupling"
        letter = "abcd"[2 * row + col]
        ax.set(title=f"({letter}) {name} → {out}: {kind}",
               xlabel=f"{name} [V]", ylabel=f"{out} [µm]")
        ax.grid(alpha=0.3)
fig.suptitle("Open-loop input-output maps of the rakotondrabe-2dof preset")
plt.show()

# %%
# The hysteresis ratio of each direct transfer: the largest vertical gap between
# the branches of the loop over its output range.
for k, name in enumerate(plant.hysteresis.input_names):
    t, u = hs.sine_drive(T, plant.hysteresis.input_names, name, amplitude=10.0, frequency=1.0, periods=2)
    y, _ = hs.simulate_plant(plant, u)
    period = int(round(1.0 / T))                        # samples of one 1 Hz period
    h = hs.hysteresis_width(u[k], y[k], period)          # over the last full period
    ratio = 100 * h / np.ptp(y[k, -period:])
    print(f"{name} -> {plant.hysteresis.output_names[k]}: hysteresis {h:.2f} µm, {ratio:.1f} % of the range")
