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
### For the class

**The set-up.** A piezo patch drives a cantilever; a sensor records its displacement. The
model (Euler–Bernoulli beam, a few modes, the effects ticked on the left) is calibrated on the
shaded window with an i.i.d. (or AR(1)) noise likelihood and judged on the rest of the record.

**Try this** (default dataset `lab_run_1`).

1. *Read the bands.* The model mean follows the chirp in the window; outside it, watch where
   the measurement leaves the prediction band.
2. *Calibrate on the first second, then on the last* (move the window; *Pin* the first
   result): the stiffness estimates EI disagree, each with a tiny error bar — **the model is
   missing something**. More data made it more confident, not more right.
3. *More modes* (1 → 8): the calibration RMSE falls a little; the held-out error does not.
4. *AR(1) likelihood*: the band widens — the noise model absorbs the misfit — but the
   parameters stay biased.
5. Open the **Diagnosis** tab: it points at the missing effect. *Add* it and watch the
   held-out RMSE fall.

**Notice.** A narrow band is not a good band: read the held-out RMSE (µm) and the coverage
(%) together, and the convergence flag before trusting a posterior.

<small>RMSE in µm of displacement; EI in N m², k_p in N m/V. Kennedy & O'Hagan (2001);
Brynjarsdóttir & O'Hagan (2014).</small>
"""

DIAGNOSIS_GUIDE = """
### For the class

The diagnosis looks at the beam view's current model (dataset, window, modes, effects) over the
**whole** record:

* **Residual** — where the data leave the 95 % prediction band (red intervals).
* **Spectra** — residual power piled up near a model mode means that mode is wrong
  (a frequency shift: mass or stiffness missing).
* **Autocorrelation** — a white residual stays inside ±1.96/√n; Ljung–Box p < 0.05 says the
  misfit is structure, not noise.
* **Modes table** — frequencies and damping identified from the free decay against the model's.
* **Backbone** — a frequency that changes with amplitude is a nonlinearity (a hardening spring).

Each candidate effect is calibrated on the same window and scored by the **Laplace log
evidence** (nats; ≥ 5 is very strong) and the **held-out RMSE** (µm). Press **Add** on the best
one: the beam view re-calibrates with full MCMC and the **error ladder** gets a new rung.
Then *Diagnose the current model* again: is anything else missing?

<small>On `lab_run_2` the hidden effect is a tip mass; `lab_run_5` is a control with nothing missing.</small>
"""
