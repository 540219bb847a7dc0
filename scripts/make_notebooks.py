"""Writes the notebooks in notebooks/ from the cells below (kept in code for review)."""

from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

CELLS = [
    (
        "md",
        """# The paper's simulation study, step by step

Variable-order system (34): $D^{\\alpha^*(t)} x^* = p^{*T} u$, identified online with the adaptive law
of Theorem 1 (eqs. 29–30) in the exact discrete form of `docs/method.md` §3. Step
$h = 0.05$ s, noise variance 0.25, $\\lambda = 0.9$, $\\gamma = 0.01$, $\\hat\\alpha(0) = 0.5$.""",
    ),
    (
        "code",
        """import vojax
vojax.use_fast_cpu_loops()  # one kernel per scan on a CPU; before the first JAX computation
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
from vojax import reference""",
    ),
    ("md", "## 1. Simulate the true system in its integral form (12)"),
    (
        "code",
        """data = vojax.simulate_study(0.05, seed=0)
t, u, y = data["t"], data["u"], data["y"]
fig, ax = plt.subplots(figsize=(7, 2.5))
ax.plot(t, y, lw=0.5, label="measured"); ax.plot(t, data["x"], "k", lw=1, label="$x^*$")
ax.set(xlabel="time (s)", ylabel="output x"); ax.legend();""",
    ),
    (
        "md",
        """## 2. The order sensitivity: autodiff against the closed form (14)

`vojax.order_sensitivity` is a `jax.jvp` through the memory kernel; `vojax.reference` applies eq. (14)
to the same quadrature by hand.""",
    ),
    (
        "code",
        """n = 600
ad = vojax.order_sensitivity(u[:n], data["alpha"][:n], 0.05)
closed = reference.order_sensitivity(u[:n], data["alpha"][:n], 0.05)
print("max relative difference:", float(np.max(np.abs(ad - closed)) / np.max(np.abs(closed))))""",
    ),
    ("md", "## 3. Identify with the paper's gains"),
    (
        "code",
        """res = vojax.identify(u, y, 0.05, lam=0.9, gamma=0.01, alpha0=0.5, x0=0.0, r0=np.eye(2), method="gradient")
e = np.asarray(res.alpha) - data["alpha"]
print("order RMS error, t > 50 s:   %.4f" % np.sqrt(np.mean(e[t > 50] ** 2)))
print("order RMS error, last 100 s: %.4f" % np.sqrt(np.mean(e[t > 200] ** 2)))
print("p RMS error, t > 50 s:       %.3f" % np.sqrt(np.mean((np.asarray(res.p) - data["p"])[t > 50] ** 2)))
fig, ax = plt.subplots(figsize=(7, 2.5))
ax.fill_between(t, res.alpha_lower, res.alpha_upper, color="C3", alpha=0.2, lw=0, label="law's ±2σ (noise only)")
ax.plot(t, data["alpha"], "k", label=r"$\\alpha^*$"); ax.plot(t, res.alpha, "C3--", label=r"$\\hat\\alpha$")
ax.set(xlabel="time (s)", ylabel="order (dimensionless)"); ax.legend();""",
    ),
    (
        "md",
        """## 4. The printed and corrected equations

**(26).** The paper prints $\\varphi\\,\\partial p^T/\\partial\\beta$ where differentiating $R$ gives
$\\varphi\\,\\partial\\varphi^T/\\partial\\beta$ (Lemma 3 defines exactly this $G$). On the identified
trajectory, the law's $\\partial p/\\partial\\beta$ (autodiff of the LSFF step) matches the corrected
closed form and not the printed one.""",
    ),
    (
        "code",
        """m = 400
alpha = np.asarray(res.alpha[:m])
phi = vojax.fractional_integral(u[:m], alpha, 0.05)
dphi = vojax.order_sensitivity(u[:m], alpha, 0.05)
law = vojax.identify(u[:m], y[:m], 0.05, gamma=0.01, lam=0.9, x0=0.0, r0=np.eye(2), memory="direct", method="gradient")
corrected = reference.lsff_sensitivity(phi, dphi, y[:m], 0.05, 0.9)
printed = reference.lsff_sensitivity(phi, dphi, y[:m], 0.05, 0.9, printed=True)
scale = np.max(np.abs(corrected))
print("autodiff vs corrected (26): %.1e" % (np.max(np.abs(law.dp - corrected)) / scale))
print("printed vs corrected (26):  %.1e" % (np.max(np.abs(printed - corrected)) / scale))""",
    ),
    (
        "md",
        """**(29).** With $R = \\int e^{-\\lambda(t-\\tau)}\\varphi\\varphi^T d\\tau$, $\\dot R = -\\lambda R + \\varphi\\varphi^T$
and $\\dot P = -P\\dot R P = \\lambda P - P\\varphi\\varphi^T P$; the printed sign does not give $R^{-1}$.""",
    ),
    (
        "code",
        """lam, dt = 0.9, 1e-3
ts = np.arange(1000) * dt
f = lambda s: 0.3 * np.array([np.sin(s) + 1.2, np.cos(0.7 * s)])
R, Pc, Pp = np.eye(2), np.eye(2), np.eye(2)
for s in ts:  # explicit Euler is enough to see the difference
    ff = np.outer(f(s), f(s))
    R = R + dt * (-lam * R + ff)
    Pc = Pc + dt * (lam * Pc - Pc @ ff @ Pc)
    Pp = Pp + dt * (-lam * Pp + Pp @ ff @ Pp)
print("corrected: |P − R⁻¹| = %.1e" % np.abs(Pc - np.linalg.inv(R)).max())
print("printed:   |P − R⁻¹| = %.1e" % np.abs(Pp - np.linalg.inv(R)).max())""",
    ),
    (
        "md",
        """## 5. The order gain matters

The paper gives no rule for $\\gamma$: at 0.04 the order chatters between the bounds.
`vojax.tune_gains` picks $(\\gamma, \\lambda)$ from the data alone (lagged prediction error).""",
    ),
    (
        "code",
        """for gamma in (0.003, 0.01, 0.04):
    r = vojax.identify(u, y, 0.05, gamma=gamma, x0=0.0, r0=np.eye(2), method="gradient")
    print("gamma = %.3f: order RMS error (t > 50 s) = %.4f"
          % (gamma, np.sqrt(np.mean((np.asarray(r.alpha) - data["alpha"])[t > 50] ** 2))))
gains = vojax.tune_gains(u, y, 0.05)
r = vojax.identify(u, y, 0.05, gamma=gains.gamma, lam=gains.lam, x0=0.0, method="gradient")
print("tuned gamma = %.4g, lam = %.3g: order RMS error = %.4f"
      % (gains.gamma, gains.lam, np.sqrt(np.mean((np.asarray(r.alpha) - data["alpha"])[t > 50] ** 2))))""",
    ),
]


TISSUE_CELLS = [
    ("md", """# Identifying recorded tests: an adhesive and a tissue

Two real recordings ship with vojax (MIT-licensed; `vojax/examples/README.md` says where they
come from):

- an optically clear adhesive film in simple shear: a staircase of strain ramps and holds
  (stress → strain), and
- passive myocardium stretched in a 10 s ramp and held (tension → stretch).

Each is identified with the springpot σ = η D^{q(t)} ε in two ways: the Bayesian tracker
(`identify(method="kalman")`: a variable order with its ±2σ band) and the constant-order refit
(`vojax.refit`: one q with its 95 % interval). Where they disagree, the models behind them,
and the misfit that no band includes, say why."""),
    ("code", """import warnings
import vojax
vojax.use_fast_cpu_loops()  # one kernel per scan on a CPU; before the first JAX computation
import jax
jax.config.update("jax_enable_x64", True)
import matplotlib.pyplot as plt
import numpy as np


def nrmse(fit, y):
    return float(np.sqrt(np.mean((np.asarray(fit) - y) ** 2)) / np.ptp(y))


def report(name, t, u, y, tracker, fit, u_label, y_label):
    print("%s: %d samples; baseline (the mean) NRMSE %.4f" % (name, y.size, nrmse(np.full_like(y, y.mean()), y)))
    d = tracker.diagnostics
    eta = 1 / np.asarray(tracker.p[:, 0])
    edges = " (tuned at the edge of its search: " + ", ".join(d.at_edge) + ")" if d.at_edge else ""
    print("tracker: q from %.3f to %.3f, median band ±%.3f, identified: %s%s%s, eta from %.4g to %.4g, NRMSE %.4f"
          % (float(tracker.alpha.min()), float(tracker.alpha.max()), d.band_halfwidth, d.identified,
             " (" + d.message + ")" if d.message else "", edges, eta.min(), eta.max(),
             nrmse(tracker.y_hat, y)))
    print("refit: q = %.4f [%.4f, %.4f], eta = %.4g ± %.2g, NRMSE %.4f"
          % (float(fit.order[0]), float(fit.order_lower[0]), float(fit.order_upper[0]),
             1 / float(fit.p[0]), float(fit.p_stderr[0]) / float(fit.p[0]) ** 2, nrmse(fit.y_hat, y)))
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.2), layout="constrained")
    axes[0].plot(t, u[:, 0], "k")
    axes[0].set(xlabel="time (s)", ylabel=u_label, title="input")
    axes[1].plot(t, y, "k", lw=1.5, label="measured")
    axes[1].plot(t, tracker.y_hat, "C3--", label="tracker")
    axes[1].plot(t, fit.y_hat, "C0:", label="refit")
    axes[1].set(xlabel="time (s)", ylabel=y_label, title="output and fits")
    axes[1].legend()
    axes[2].fill_between(t, tracker.alpha_lower, tracker.alpha_upper, color="C3", alpha=0.2, lw=0, label="tracker ±2σ")
    axes[2].plot(t, tracker.alpha, "C3", label="tracker")
    axes[2].fill_between(t, fit.order_lower, fit.order_upper, color="C0", alpha=0.2, lw=0, label="refit 95 %")
    axes[2].plot(t, fit.order, "C0:", label="refit")
    axes[2].set(xlabel="time (s)", ylabel="order q (dimensionless)", title="order", ylim=(0, 1))
    axes[2].legend()
    return fig"""),
    ("md", """## The adhesive staircase

Its time steps are uneven at the ends of the holds (2.4 s, then 6 s). vojax uses the samples
as recorded: the kernels integrate exactly between any increasing times, and `record.grid`
hands the clock to every function (`t=` on an irregular clock, `dt=` on a uniform one)."""),
    ("code", """(oca,) = vojax.load_records(vojax.io.example_file("adhesive"), time="time_s",
                            inputs=["nominal_shear_stress_kPa"], output="shear_strain")
steps = np.diff(oca.time)
print("uniform clock: %s; steps from %.3g to %.3g s" % (oca.uniform, steps.min(), steps.max()))
tracker = vojax.identify(oca.inputs, oca.output, **oca.grid, method="kalman", warn=False)
fit = vojax.refit(oca.inputs, oca.output, **oca.grid)
report("adhesive", oca.time, oca.inputs, oca.output, tracker, fit,
       "shear stress (kPa)", "shear strain (–)");"""),
    ("md", """The tracker reproduces the strain almost exactly (NRMSE about 5e-5), with an order near
0.25 and a band of ±0.03 (its own smoothing's band widened to the other explanations that
fit). Then it refuses that band. The refit, with one constant q and one η, finds q ≈ 0.40
with an interval of ±0.014 and leaves an NRMSE of 0.017. Both bands are narrow, and they are
far apart. What differs is the model: the tracker lets η drift, and it drifts by about 15 %
over the test. With one input, an order and a drifting η trade off (see the identifiability
page of the docs). So wherever the tuned parameters drift, the tracker smooths the order
again with them held, and its diagnostics compare the two. The next cell does the same by
hand: η held (a parameter drift at the floor states it constant), the noise set to the
refit's residual scatter."""),
    ("code", """noise = {"order_drift": tracker.tuning.order_drift, "parameter_drift": 1e-10,
         "noise_std": float(np.std(oca.output - np.asarray(fit.y_hat)))}
held = vojax.identify(oca.inputs, oca.output, **oca.grid, method="kalman", noise=noise, warn=False)
print("tracker, eta held: q from %.3f to %.3f, median band ±%.3f, NRMSE %.4f"
      % (float(held.alpha.min()), float(held.alpha.max()), held.diagnostics.band_halfwidth,
         nrmse(held.y_hat, oca.output)))"""),
    ("md", """With η held, the order moves to about 0.32, as the tracker's message says. That gives three
springpots and three orders,
0.25, 0.32 and 0.40, each with a band a few hundredths wide or less. A band is the
uncertainty *given its model*: white noise around a springpot whose η may drift, or may not.
None of the bands includes the misfit of its own model, and that misfit is what separates
them here. On this record the data support an order between about 0.25 and 0.40, depending
on how much η may change during the test. Report the refit's q with that caveat, or fit a law
with more structure, such as the fractional Kelvin–Voigt (`vojax.KelvinVoigt`)."""),
    ("md", """## Passive myocardium: a 10 s ramp, then a hold

Tension (kPa) drives the stretch ε = (L − 0.95)/0.95. The hold is log-spaced in the file;
on its own clock the ramp keeps every recorded sample."""),
    ("code", """(myo,) = vojax.load_records(vojax.io.example_file("myocardium"), time="Time",
                            inputs=["F"], output="L")
steps = np.diff(myo.time)
print("uniform clock: %s; %d samples, steps from %.3g to %.3g s" % (myo.uniform, myo.time.size, steps.min(), steps.max()))
strain = (myo.output - 0.95) / 0.95
tracker2 = vojax.identify(myo.inputs, strain, **myo.grid, method="kalman", warn=False)
fit2 = vojax.refit(myo.inputs, strain, **myo.grid)
report("myocardium", myo.time, myo.inputs, strain, tracker2, fit2, "tension (kPa)", "stretch ε (–)");"""),
    ("md", """Here the tracker settles on a constant order and a constant η: both drift intensities are
tuned to the lower edge of their search (`diagnostics.at_edge` names both). It agrees with the
refit, q ≈ 0.07 ± 0.02 from both, with the same NRMSE. A single ramp and hold does not excite
a moving order, and the tracker's evidence prefers none. Its fit leaves a misfit of 7 % of
the range, systematic rather than noise, which neither band includes."""),
]


MODEL_CELLS = [
    (
        "md",
        """# Which model, and which test

Two questions before and after a test, on the adhesive shear staircase shipped with vojax
(stress → strain):

1. **Which model do the data support?** `vojax.compare` fits a constant-order springpot, the
   fractional Kelvin–Voigt, Maxwell and Zener laws and a variable-order springpot and ranks
   them by evidence.
2. **Which test would identify the order best?** `vojax.fisher_information` predicts, before
   a test is run, the band that a loading protocol can give on the order (from the exact
   order sensitivities); `vojax.optimal_protocol` searches a protocol's parameters for the
   narrowest band.

With your own file, replace the loading cell by
`load_records("my_test.csv", time="time_s", inputs=["stress_kPa"], output="strain")`.""",
    ),
    (
        "code",
        """import vojax
vojax.use_fast_cpu_loops()  # one kernel per scan on a CPU; before the first JAX computation
import jax
jax.config.update("jax_enable_x64", True)
import jax.numpy as jnp
import matplotlib.pyplot as plt
import numpy as np
from vojax.io import example_file, load_records

(rec,) = load_records(example_file("adhesive"), time="time_s",
                      inputs=["nominal_shear_stress_kPa"], output="shear_strain")
# 300 uniform samples over the test (the comparison and the design take a uniform step)
t = np.linspace(0.0, rec.time[-1], 300)
dt = t[1]
stress = np.interp(t, rec.time, rec.inputs[:, 0])
strain = np.interp(t, rec.time, rec.output)
print(f"{t.size} samples over {t[-1]:.0f} s, stress up to {stress.max():.1f} kPa")""",
    ),
    ("md", "## 1. Which model"),
    (
        "code",
        """comparison = vojax.compare(stress, strain, dt)
print(comparison.table())
print("best:", comparison.best)
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3))
ax1.plot(t, strain, "k", lw=1, label="measured")
for row in comparison.rows[:2]:
    fitted = np.asarray(row["refit"].y_hat)
    ax1.plot(t, fitted, "--", label=row["model"])
    ax2.plot(t, strain - fitted, lw=0.8, label=row["model"])
ax1.set(xlabel="time (s)", ylabel="shear strain"); ax1.legend()
ax2.set(xlabel="time (s)", ylabel="residual"); ax2.legend();""",
    ),
    (
        "md",
        """The table is sorted by the log evidence (the Schwarz approximation), with each law's
evidence weight, AIC, the error on the held-out last quarter and the residuals' lag-1
autocorrelation. Read the verdict's last sentence too: when the best law's residuals are
correlated, the Bayes factors are too large, and no law in the list describes every feature
of the record.""",
    ),
    ("md", "## 2. Which test"),
    (
        "code",
        """fit = vojax.refit(stress, strain, dt)  # the hypothesis: this record's own constant-order fit
q, p, noise = fit.order_value, np.asarray(fit.p), float(fit.sigma)
peak, span = float(stress.max()), float(t[-1])
recorded = vojax.fisher_information(stress, q, p, dt, noise_std=noise, knots=3)


def staircase(heights, times):
    # three steps of a third of the test each, reached by ramps of 2 % of it
    level, previous = jnp.zeros_like(times), 0.0
    for k, edge in enumerate(span * jnp.array([0.0, 1 / 3, 2 / 3])):
        level = level + (heights[k] - previous) * jnp.clip((times - edge) / (0.02 * span), 0, 1)
        previous = heights[k]
    return level


heights, designed = vojax.optimal_protocol(
    staircase, [0.3 * peak, 0.6 * peak, 0.9 * peak], [0.0] * 3, [peak] * 3, q, p, dt,
    noise_std=noise, knots=3, num_samples=t.size,
)
print(f"order {q:.3f}; predicted ±2σ of the order (3 knots), median over the second half:")
print(f"recorded protocol: ±{recorded.order_band:.4f}")
print(f"designed staircase (heights {np.round(heights / peak, 2)} × peak): ±{designed.order_band:.4f}")
print(f"band ratio, recorded / designed: {recorded.order_band / designed.order_band:.2f}")
fig, ax = plt.subplots(figsize=(7, 2.8))
ax.plot(t, 2 * recorded.order_stderr, "k", label="recorded")
ax.plot(t, 2 * designed.order_stderr, "C3", label="designed staircase")
ax.set(xlabel="time (s)", ylabel="predicted ±2σ of α(t)", yscale="log"); ax.legend();""",
    ),
    (
        "md",
        """The designed staircase loads, unloads completely and loads again: the unloading shows
the memory of the first load on its own. The same comparison for the tracker, whose order
may move at every sample: `order_drift` is the intensity of its random walk (the tracker
tunes it; here three values), and the band is the one the tracker would report at it.""",
    ),
    (
        "code",
        """for drift in (0.1, 1.0, 10.0):
    a = vojax.fisher_information(stress, q, p, dt, noise_std=noise, order_drift=drift)
    b = vojax.fisher_information(staircase(jnp.asarray(heights), jnp.asarray(t)), q, p, dt,
                                 noise_std=noise, order_drift=drift)
    print(f"order drift {drift:5.1f}: tracker's band ±{a.order_band:.4f} recorded, "
          f"±{b.order_band:.4f} designed")""",
    ),
    (
        "md",
        """These are bands of a model whose parameters are constant. With one input, a drifting
parameter can stand in for a moving order, which no protocol of one input removes: see the
identifiability page of the docs.""",
    ),
]


def main():
    folder = Path(__file__).resolve().parent.parent / "notebooks"
    for cells, name in ((CELLS, "paper_simulation.ipynb"),
                        (TISSUE_CELLS, "tissue_identification.ipynb"),
                        (MODEL_CELLS, "which_model_which_test.ipynb")):
        nb = new_notebook()
        nb.cells = [new_markdown_cell(s) if kind == "md" else new_code_cell(s) for kind, s in cells]
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3",
                                     "language": "python"}
        nbformat.write(nb, folder / name)
        print("wrote", folder / name)

if __name__ == "__main__":
    main()
