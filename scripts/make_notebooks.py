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
ax.plot(t, y, lw=0.5, label="measured"); ax.plot(t, data["x"], "k", lw=1, label="$x^*$"); ax.legend();""",
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
        """res = vojax.identify(u, y, 0.05, lam=0.9, gamma=0.01, alpha0=0.5, x0=0.0, r0=np.eye(2))
e = np.asarray(res.alpha) - data["alpha"]
print("order RMS error, t > 50 s:   %.4f" % np.sqrt(np.mean(e[t > 50] ** 2)))
print("order RMS error, last 100 s: %.4f" % np.sqrt(np.mean(e[t > 200] ** 2)))
print("p RMS error, t > 50 s:       %.3f" % np.sqrt(np.mean((np.asarray(res.p) - data["p"])[t > 50] ** 2)))
fig, ax = plt.subplots(figsize=(7, 2.5))
ax.plot(t, data["alpha"], "k", label=r"$\\alpha^*$"); ax.plot(t, res.alpha, "C3--", label=r"$\\hat\\alpha$"); ax.legend();""",
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
law = vojax.identify(u[:m], y[:m], 0.05, gamma=0.01, lam=0.9, x0=0.0, r0=np.eye(2), memory="direct")
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
    r = vojax.identify(u, y, 0.05, gamma=gamma, x0=0.0, r0=np.eye(2))
    print("gamma = %.3f: order RMS error (t > 50 s) = %.4f"
          % (gamma, np.sqrt(np.mean((np.asarray(r.alpha) - data["alpha"])[t > 50] ** 2))))
gains = vojax.tune_gains(u, y, 0.05)
r = vojax.identify(u, y, 0.05, gamma=gains.gamma, lam=gains.lam, x0=0.0)
print("tuned gamma = %.4g, lam = %.3g: order RMS error = %.4f"
      % (gains.gamma, gains.lam, np.sqrt(np.mean((np.asarray(r.alpha) - data["alpha"])[t > 50] ** 2))))""",
    ),
]


TISSUE_CELLS = [
    ("md", """# Identifying recorded tissue and adhesive tests

Two real recordings from `../shared/data` (read each folder's SOURCE.md; the beef data are GPL-3.0
and stay outside the package, so this notebook reads them from there):

- one beef indentation record (force → indentation depth, a ramp then a hold, 10 Hz), and
- the adhesive (OCA) shear staircase (stress → strain).

Each is identified with the springpot σ = η D^{q(t)} ε online (the adaptive law, gains tuned from
the data) and offline (`vojax.refit`, constant order, with standard errors)."""),
    ("code", """import warnings
from pathlib import Path
import vojax
vojax.use_fast_cpu_loops()  # one kernel per scan on a CPU; before the first JAX computation
import jax
jax.config.update("jax_enable_x64", True)
import matplotlib.pyplot as plt
import numpy as np
from vojax._data import load_records
DATA = Path("..").resolve().parent / "shared" / "data"
assert DATA.is_dir(), "this notebook needs ../shared/data"  # the test skips when it is absent"""),
    ("md", "## A beef record: force in, indentation depth out (pre-contact samples trimmed)"),
    ("code", """beef = load_records(DATA / "beef-indentation-relaxation" / "beef_indentation_relaxation.csv",
                    time="time_s", inputs=["force_N"], output="displacement_mm",
                    group_by="specimen", trim_column="force_N", trim_below=0.02)
rec = next(r for r in beef if r.name == "230331-FF1 1B")
u, y = rec.inputs, rec.output
adaptive = vojax.identify(u, y, rec.dt, gamma="auto")
fit = vojax.refit(u, y, rec.dt)
def nrmse(a): return float(np.sqrt(np.mean((np.asarray(a) - y) ** 2)) / np.ptp(y))
print("beef %s: %d samples; baseline (the mean) NRMSE %.4f" % (rec.name, y.size, nrmse(np.full_like(y, y.mean()))))
print("adaptive: gamma %.3g, lam %.3g, q in [%.3f, %.3f], NRMSE %.4f"
      % (float(adaptive.gamma), float(adaptive.lam), float(adaptive.alpha.min()), float(adaptive.alpha.max()), nrmse(adaptive.y_hat)))
print("refit:    q = %.4f +- %.4f, eta = %.4g N/mm, NRMSE %.4f"
      % (float(fit.order[0]), float(fit.order_stderr[0]), 1 / float(fit.p[0]), nrmse(fit.y_hat)))"""),
    ("code", """fig, axes = plt.subplots(1, 3, figsize=(12, 3), layout="constrained")
axes[0].plot(rec.time, y, "k", label="measured"); axes[0].plot(rec.time, adaptive.y_hat, "C3--", label="adaptive")
axes[0].plot(rec.time, fit.y_hat, "C0:", label="refit"); axes[0].set_title("depth (mm)"); axes[0].legend()
axes[1].plot(rec.time, u[:, 0]); axes[1].set_title("force (N)")
axes[2].plot(rec.time, adaptive.alpha, "C3", label="adaptive"); axes[2].plot(rec.time, fit.order, "C0:", label="refit")
axes[2].set_title("order q"); axes[2].legend();"""),
    ("md", "## The adhesive staircase (its time steps are uneven: resampled, with a warning)"),
    ("code", """with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    oca = load_records(DATA / "oca-shear-staircase" / "oca_shear_relaxation_1.csv", time="time_s",
                       inputs=["nominal_shear_stress_kPa"], output="shear_strain")[0]
print(caught[0].message)
u2, y2 = oca.inputs, oca.output
adaptive2 = vojax.identify(u2, y2, oca.dt, gamma="auto")
fit2 = vojax.refit(u2, y2, oca.dt)
def nrmse2(a): return float(np.sqrt(np.mean((np.asarray(a) - y2) ** 2)) / np.ptp(y2))
print("baseline (the mean) NRMSE %.4f" % nrmse2(np.full_like(y2, y2.mean())))
print("adaptive: q in [%.3f, %.3f], NRMSE %.4f" % (float(adaptive2.alpha.min()), float(adaptive2.alpha.max()), nrmse2(adaptive2.y_hat)))
print("refit:    q = %.4f +- %.4f, eta = %.4g kPa s^q, NRMSE %.4f"
      % (float(fit2.order[0]), float(fit2.order_stderr[0]), 1 / float(fit2.p[0]), nrmse2(fit2.y_hat)))
fig, axes = plt.subplots(1, 2, figsize=(10, 3), layout="constrained")
axes[0].plot(oca.time, y2, "k"); axes[0].plot(oca.time, adaptive2.y_hat, "C3--"); axes[0].plot(oca.time, fit2.y_hat, "C0:")
axes[0].set_title("shear strain"); axes[1].plot(oca.time, adaptive2.alpha, "C3"); axes[1].plot(oca.time, fit2.order, "C0:")
axes[1].set_title("order q");"""),
]


def main():
    nb = new_notebook()
    nb.cells = [new_markdown_cell(s) if kind == "md" else new_code_cell(s) for kind, s in CELLS]
    nb.metadata["kernelspec"] = {
        "name": "python3",
        "display_name": "Python 3",
        "language": "python",
    }
    path = Path(__file__).resolve().parent.parent / "notebooks" / "paper_simulation.ipynb"
    nbformat.write(nb, path)
    print("wrote", path)
    nb = new_notebook()
    nb.cells = [new_markdown_cell(s) if kind == "md" else new_code_cell(s) for kind, s in TISSUE_CELLS]
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    path = path.with_name("tissue_identification.ipynb")
    nbformat.write(nb, path)
    print("wrote", path)


if __name__ == "__main__":
    main()
