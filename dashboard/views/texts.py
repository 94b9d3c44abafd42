"""Explanatory texts of the dashboard (Markdown), kept apart from the layout code."""

#: Settings every preset of the "Try this" steps starts from (the README's reference case).
_BASE = {"window_s": 5.0, "discrepancy": 0.0, "kind": "harmonic", "noise_sd": 0.1, "horizon_s": 20.0,
         "likelihood": "iid"}

#: The "Try this" steps of the toy tab: ``(title, Markdown text, presets)``, each preset a button
#: label and the :class:`~dashboard.state.session.ToyState` inputs it sets (the seed is left as it
#: is: the claims hold over seeds). Every claim in a text is run and asserted, over seeds 0–9 where
#: it is statistical, by tests/test_toy_lessons.py (the figures quoted are those measurements,
#: Laplace preview, which the MCMC matches to a few per cent here).
TOY_STEPS = (
    ("No discrepancy",
     "δ = 0: averaged over seeds the 95 % prediction band holds about 95 % of the held-out data "
     "(92 % over seeds 0–9) and the true values (green) sit inside their 95 % intervals for most seeds "
     "(f: 8 of 10). One record is one noise "
     "draw: its coverage scatters, from 78 % to 98 % over those seeds — try a few.",
     (("δ = 0", dict(_BASE)),)),
    ("Tone, window 3 s",
     "An unmodelled second mode (δ = 0.3 du): the estimated noise sd about doubles (0.22 du against "
     "the true 0.1 du) — it absorbs the missing physics — the held-out coverage drops to about 60 % "
     "and the true f falls outside its 95 % interval for 8 seeds of 10.",
     (("Tone, 3 s", dict(_BASE, discrepancy=0.3, kind="tone", window_s=3.0)),)),
    ("Drift, widen the window",
     "A baseline drift (δ = 0.3 du, d(t) = t / 5 s), window 3 s then 12 s: the sd of f falls "
     "(4.5 → 1.8 mHz) while the held-out RMSE grows (0.81 → 0.97 du) and the estimated noise sd "
     "triples (0.14 → 0.43 du): more data make the model **more confident, not more right**. The "
     "*Window sweep* tab shows every window at once.",
     (("Drift, 3 s", dict(_BASE, discrepancy=0.3, kind="drift", window_s=3.0)),
      ("Drift, 12 s", dict(_BASE, discrepancy=0.3, kind="drift", window_s=12.0)))),
    ("AR(1) likelihood",
     "With the tone, a correlated noise model reads the smooth misfit as correlation: coverage "
     "rises from about 60 % to 91 % and the true f is back inside its interval (9 seeds of 10). "
     "It does not rescue the drift: coverage stays below 50 % at both windows.",
     (("Tone, 3 s, AR(1)", dict(_BASE, discrepancy=0.3, kind="tone", window_s=3.0, likelihood="ar1")),
      ("Drift, 12 s, AR(1)", dict(_BASE, discrepancy=0.3, kind="drift", window_s=12.0, likelihood="ar1")))),
    ("Compare",
     "*Pin* a result, change one input, and compare the bands (purple: pinned) and the *Compare "
     "table* side by side.",
     ()),
)

#: One-line meaning of each statistical term of the toy tab (tooltips and the guide).
TOY_GLOSSARY = {
    "posterior": "what the data say about the parameters: a cloud of plausible values, not one value",
    "posterior predictive": "the model's prediction with its parameter uncertainty (and, for the "
                            "prediction band, the noise) carried through",
    "credible band": "where the noise-free model curve lies with 95 % probability (parameter uncertainty only)",
    "prediction band": "where a new measurement should fall with 95 % probability (parameters plus noise)",
    "coverage": "the share of held-out measurements inside the 95 % prediction band; about 95 % if the "
                "model and its noise are right",
    "RMSE": "root-mean-square distance between the prediction and the held-out measurements (du)",
    "ESS": "effective sample size: how many independent draws the correlated MCMC chain is worth",
    "R-hat": "agreement between the independent MCMC ensembles (between walkers when too few for four); above 1.01 the chain has not settled",
    "held out": "the part of the record after the calibration window, not used to calibrate",
}


def _toy_guide() -> str:
    steps = "\n".join(f"{k}. *{title}.* {text}" for k, (title, text, _) in enumerate(TOY_STEPS, start=1))
    words = "\n".join(f"* **{term}** — {meaning}" for term, meaning in TOY_GLOSSARY.items())
    return f"""
**The set-up.** The data are `A sin(2π f t + φ) + δ d(t) + noise`; the model is the sine
alone, calibrated on the shaded window with an i.i.d. (or AR(1)) noise likelihood and judged
on the rest of the record (held out). `δ d(t)` is physics the model misses.

**Try this** (the buttons under *Try this* on the left set each step's inputs).

{steps}

**Notice.** A narrow band is not a good band: read the coverage, the RMSE and the estimated
noise sd (against the true one) together.

**Words.**

{words}

<small>du = data unit. Kennedy & O'Hagan (2001); Brynjarsdóttir & O'Hagan (2014).</small>
"""


TOY_GUIDE = _toy_guide()

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

<small>Errors in the output's unit (displacement in µm, velocity in mm/s, acceleration in m/s²); EI in N m², k_p in N m/V. Kennedy & O'Hagan (2001);
Brynjarsdóttir & O'Hagan (2014).</small>
"""

RECORD_GUIDE = """
**The set-up.** A measured record: {setup}. The model (a beam with a few vibration modes,
plus the effects ticked on the left) is calibrated on the shaded window and judged on the
rest of the record (the *held-out* data). Nobody knows the true parameters: judge the model by
its residuals, the noise it needs and the evidence.

**Try this.**

1. *Read the numbers.* Compare the noise the model needs with the sensor's noise floor
   (estimated from the record alone): many times larger means **the model is missing
   something**.
2. Open the **Diagnosis** tab. {free_step}
3. *Add* the best candidate and read the error in the window again.
4. *Move the window later in the record* and watch the damping estimates: if they change with
   the window, the damping depends on the amplitude — a linear model has one damping ratio per
   mode, so that is outside the catalogue.

**Words.** *Posterior*: the parameter values that fit the data, with their uncertainty.
*95 % prediction band*: where new measurements should fall if the model were right.
*RMSE*: root-mean-square error. *ESS*: how many independent draws the sampler's chain is
worth. *R-hat*: whether the sampler's chains agree (1.00 is perfect).

<small>Errors in the output's unit ({unit}).</small>
"""

#: The output quantities of a record, as words.
_OUTPUT_WORDS = {"displacement": "displacement", "velocity": "velocity", "acceleration": "acceleration",
                 "strain": "surface strain"}
_INPUT_WORDS = {"voltage": "a piezo patch drives the beam", "force": "a point force drives the beam"}


def beam_guide(measurement, simulated: bool) -> str:
    """The beam view's "For the class" text for ``measurement``: the class script of the simulated
    lab runs, or the set-up and steps of a measured record (its input, output quantity and unit)."""
    if simulated or measurement is None:
        return BEAM_GUIDE
    output = _OUTPUT_WORDS.get(measurement.output_kind, measurement.output_kind)
    drive = (_INPUT_WORDS.get(measurement.input_kind, "the beam is driven") if not measurement.is_free
             else "the beam was released and rings down freely (no input)")
    setup = f"{drive}; a sensor records its {output} ({measurement.output_unit})"
    free_step = ("In a free decay, candidates are judged on the error in the calibration window (the rest "
                 "of a decay extrapolates each mode's damping). Several mass-like repairs can place the "
                 "modes the record shows equally well: the verdict says which mode tells them apart."
                 if measurement.is_free else
                 "It ranks the catalogue's effects by the evidence and the held-out error.")
    return RECORD_GUIDE.format(setup=setup, free_step=free_step, unit=measurement.output_unit)


DIAGNOSIS_GUIDE = """
The diagnosis looks at the beam view's current model (record, window, modes, effects) over
the **whole** record (three tabs under *Where the model fails*):

* **Residual** (data − model) — where the data leave the 95 % band (red intervals).
* **Spectra** — residual power piled up near a model mode means that mode is wrong
  (a frequency shift: mass or stiffness missing).
* **Autocorrelation** — the residual of a right model is white noise: its bars stay inside
  the dashed lines. The *Ljung–Box test* says the same in one number: p < 0.05 means
  left-over structure, not noise.
* **Modes table** — frequencies and damping measured in the free decay against the model's.
* **Backbone** — a frequency that changes with amplitude is a nonlinearity (a hardening spring).

Each candidate effect is calibrated on the same window and scored two ways: the **held-out
error** (in the output's unit; for a free decay, the error in the window) and the **evidence** — how much better the model explains the data, paying for
its extra parameters. It is given in nats: a gain of Δ nats means odds of e^Δ : 1 for the
effect (5 nats ≈ 150 : 1 counts as material). Press **Add** on the best one: the beam view
re-calibrates, the diagnosis re-runs for the new model and the **error ladder** gets a new
step. Is anything else missing?

*Reveal* (teacher) shows what a simulated record was simulated with (a real record has no known answer).
"""
