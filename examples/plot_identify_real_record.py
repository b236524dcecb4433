"""
Identify a model from a real measured record
============================================

``hammerstein/data/piezo-stack-150V-1Hz.csv`` is a real piezoelectric stack
driven by a 150 V, 1 Hz sine and measured at 5 kHz (columns: 0 time [s],
1 displacement [µm], 2 voltage [V]; its source and licence are in
``hammerstein/data/README.md``). A classical Prandtl-Ishlinskii model with 15
play operators is fitted by least squares on the first loops; the last two
periods are held out and predicted. The command line does the same with
``hammerstein identify hammerstein/data/piezo-stack-150V-1Hz.csv --input 2
--output 1 --time 0 --out model.toml --plot fit.png``.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import hammerstein as hs

record = hs.read_record(Path(hs.__file__).parent / "data" / "piezo-stack-150V-1Hz.csv",
                        input=2, output=1, time=0)
fit = hs.identify_record(record, method="least-squares", n_hysterons=15)
split = fit.splits[0]
print(split.description)
for part, errors in (("training", fit.train[0]), ("held out", fit.validation[0])):
    print(f"{part}: RMS error {errors['rms']:.3f} µm, {errors['rms_percent']:.2f} % of the range")

# %%
# Measured and predicted loops, and the error against time. The samples before
# the first complete branch (the start-up curve) only warm up the play states.
y_model = fit.predictions[0][0]
held = split.held_out
fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
left.plot(record.u[split.train], record.y[split.train], ".", ms=1, label="measured, training")
left.plot(record.u[held], record.y[held], ".", ms=1, label="measured, held out")
left.plot(record.u[split.burn_in:], y_model[split.burn_in:], "k", lw=0.6, label="model")
left.set(xlabel="voltage [V]", ylabel="displacement [µm]", title="(a) input-output loops")
left.legend(markerscale=8)
warm = slice(split.burn_in, None)
right.plot(record.timepts[warm], (record.y - y_model)[warm], lw=0.5)
right.axvspan(record.timepts[held][0], record.timepts[-1], color="0.9", label="held out")
right.set(xlabel="time [s]", ylabel="measured − model [µm]", title="(b) error",
          ylim=(-0.5, 0.5))
right.legend()
plt.show()
