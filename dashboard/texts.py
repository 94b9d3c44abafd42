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
