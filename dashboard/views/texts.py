"""Explanatory texts of the dashboard (Markdown), kept apart from the layout code."""

TOY_GUIDE = """
### For the class

**The set-up.** The data are `A sin(2π f t + φ) + δ d(t) + noise`; the model is the sine
alone, calibrated on the shaded window with an i.i.d. (or AR(1)) noise likelihood and judged
on the rest of the record (held out). `δ d(t)` is physics the model misses.

**Try this.**

1. *No discrepancy* (δ = 0): over many seeds the 95 % prediction band holds about 95 % of
   the held-out data and the truth (green) sits inside the posterior. One record can fall
   short: try a few seeds.
2. *Tone, δ = 0.3 du, window 3 s*: the estimated noise sd grows — it absorbs the missing
   physics — and the held-out coverage drops well below 95 %.
3. *Drift, δ = 0.3 du, then widen the window*: the posterior narrows (the sd of f falls)
   while the prediction gets worse (the RMSE grows): more data make the model **more
   confident, not more right**. The *Window sweep* tab shows every window at once.
4. *Switch the likelihood to AR(1)* with the tone and compare the coverage: a correlated
   noise model reads the smooth misfit as correlation and is less over-confident. It does
   not rescue the drift.
5. *Pin* a result, change one input, and compare the bands and the table side by side.

**Notice.** A narrow band is not a good band: read the coverage and the RMSE together.

<small>du = data unit. Kennedy & O'Hagan (2001); Brynjarsdóttir & O'Hagan (2014).</small>
"""

PLACEHOLDER = """
### {title}

Coming in the next step: {what}

The view will plug into the same session state as the toy model.
"""

BEAM_GUIDE = """
**The set-up.** A piezo patch drives a cantilever; a sensor records its displacement. The
model (a beam with a few vibration modes, plus the effects ticked on the left) is calibrated
on the shaded window and judged on the rest of the record (the *held-out* data).

**Try this** (default record `lab_run_1`).

1. *Read the numbers, then the plot.* Beside each number a line says what it means for this
   model. Outside the window, watch where the measurement (dots) leaves the pink band.
2. *Calibrate on the first second, then on the last* (move the window; *Pin* the first
   result): the stiffness estimates EI disagree, each with a tiny error bar — **the model is
   missing something**. More data made it more confident, not more right.
3. *More modes*: the error in the window falls a little; the held-out error does not.
4. *AR(1) noise model*: the band widens — the noise absorbs the misfit — but the
   parameters stay biased.
5. Open the **Diagnosis** tab: it points at the missing effect. *Add* it and watch the
   held-out error fall.

**Notice.** A wide band holds the data whatever the physics: compare the noise the model
needs with the sensor's noise floor before trusting the coverage.

**Words.** *Posterior*: the parameter values that fit the data, with their uncertainty.
*95 % prediction band*: where new measurements should fall if the model were right.
*Coverage*: the share of held-out data inside it. *RMSE*: root-mean-square error.
*ESS*: how many independent draws the sampler's chain is worth. *R-hat*: whether the
sampler's chains agree (1.00 is perfect).

<small>Displacements in µm; EI in N m², k_p in N m/V. Kennedy & O'Hagan (2001);
Brynjarsdóttir & O'Hagan (2014).</small>
"""

DIAGNOSIS_GUIDE = """
The diagnosis looks at the beam view's current model (record, window, modes, effects) over
the **whole** record:

* **Residual** (data − model) — where the data leave the 95 % band (red intervals).
* **Spectra** — residual power piled up near a model mode means that mode is wrong
  (a frequency shift: mass or stiffness missing).
* **Autocorrelation** — the residual of a right model is white noise: its bars stay inside
  the dashed lines. The *Ljung–Box test* says the same in one number: p < 0.05 means
  left-over structure, not noise.
* **Modes table** — frequencies and damping measured in the free decay against the model's.
* **Backbone** — a frequency that changes with amplitude is a nonlinearity (a hardening spring).

Each candidate effect is calibrated on the same window and scored two ways: the **held-out
error** (µm) and the **evidence** — how much better the model explains the data, paying for
its extra parameters. It is given in nats: a gain of Δ nats means odds of e^Δ : 1 for the
effect (5 nats ≈ 150 : 1 counts as material). Press **Add** on the best one: the beam view
re-calibrates, the diagnosis re-runs for the new model and the **error ladder** gets a new
step. Is anything else missing?

*Reveal* (teacher) shows what the record was simulated with.
"""
