"""Which model do the data support: constant-order springpot, fractional Kelvin–Voigt,
Maxwell and Zener laws, and a variable-order springpot (its order on K knots), each fitted
by `refit` to one stress–strain record and compared by the Schwarz (BIC) approximation of
the log evidence, AIC, the prediction error on a held-out end of the record, and the
residuals' lag-1 autocorrelation."""

import math

import numpy as np

from . import _validate as check
from ._refit_inputs import _check_x0, _weights
from ._stats import correlation_limit
from ._tracker._blocks import block_average, block_size

MODELS = ("springpot", "kelvin-voigt", "maxwell", "zener", "variable")
# Bayes factors: below 3 the data cannot tell two models apart; above 10 one is favoured
# strongly (the conventional scale of Jeffreys, as Kass and Raftery give it)
UNDECIDED_BF = 3.0
OUTPUT_ERROR_ROUNDS = 4  # refits of a law with the strain as a regressor (see `_fit`)
STRONG_BF = 10.0
MIN_POINTS = 20  # the fewest samples compared: each law's fit of its first part needs a
# few more than the variable order's free numbers (knots + coefficient + offset)
MAX_POINTS = 20_000  # a longer record is compared on block means (about 1.5 s per 1,000
# points and law on two cores, growing a little faster than the points)


class Comparison:
    """The models fitted to one record, best first (`rows`: one dict per model with
    ``model``, ``quantities`` (free numbers, the offset and the order's included),
    ``log_likelihood``, ``aic``, ``bic``, ``log_evidence`` (−BIC/2), ``weight`` (evidence
    weights, summing to 1), ``holdout_nrmse`` (fitted before the held-out end, predicted over
    it, RMS error / the output's range there), ``lag1`` (residuals' lag-1 autocorrelation),
    ``order`` (the refit's order: its value, or the range of a variable order), the
    ``refit`` itself, and ``solved``: whether the residuals behind these numbers are those
    of the fitted law solved exactly (``False``: the refit's own, with the reason in
    ``unsolved``); the Zener's row holds the Maxwell fit where that fits better, the
    Zener with E0 = 0, and says so in ``note``), `verdict`: one sentence, and `block`: the
    samples averaged into each point fitted (1: none; see `compare`'s `max_points`)."""

    def __init__(self, rows, verdict, block=1):
        self.rows = rows
        self.verdict = verdict
        self.block = block

    @property
    def best(self) -> str:
        return self.rows[0]["model"]

    def bayes_factor(self, a: str, b: str) -> float:
        """The Bayes factor of model `a` over model `b` (Schwarz approximation)."""
        ev = {r["model"]: r["log_evidence"] for r in self.rows}
        for name in (a, b):
            if not isinstance(name, str) or name not in ev:
                raise ValueError(
                    f"{name!r} was not compared here; the models compared are {', '.join(ev)}."
                )
        return float(math.exp(min(ev[a] - ev[b], 700.0)))

    def table(self) -> str:
        head = (f"{'model':<14}{'quantities':>11}{'log evidence':>14}{'weight':>9}"
                f"{'AIC':>12}{'held-out NRMSE':>16}{'lag-1':>8}  order")
        lines = [head]
        for r in self.rows:
            lines.append(
                f"{r['model']:<14}{r['quantities']:>11d}{r['log_evidence']:>14.2f}"
                f"{r['weight']:>9.3f}{r['aic']:>12.2f}{r['holdout_nrmse']:>16.4g}"
                f"{r['lag1']:>8.2f}  {r['order']}"
                + "".join(f"  ({r[k]})" for k in ("note", "unsolved") if r.get(k))
            )
        return "\n".join(lines + [self.verdict])

    def __repr__(self):
        return self.table()


def _law(model):
    """The constant-order law of a model's name."""
    from ._models import FractionalMaxwell, FractionalZener, KelvinVoigt, Springpot

    return {"springpot": Springpot, "kelvin-voigt": KelvinVoigt,
            "maxwell": FractionalMaxwell, "zener": FractionalZener}[model]()


def _fit(model, stress, strain, grid, knots, window=None, fitting=None):
    """One law's refit over `window`, with the shared refit options `fitting` (the offset,
    the test's start, relative residuals)."""
    from ._refit import refit

    law = _law("springpot" if model == "variable" else model)

    def once(regressor):
        return refit(
            law.inputs(stress, regressor), strain, **grid,
            order=knots if model == "variable" else "constant",
            direct=law.direct(stress, regressor), p_signs=law.p_signs, window=window,
            warn=False, **(fitting or {}),
        )

    fit = once(strain)
    if model in ("kelvin-voigt", "zener"):
        # these laws feed the strain back through the memory; the measured strain carries
        # its noise into that regressor and biases the fit (errors in variables): refitted
        # with the model's own strain in its place until it settles (an output-error fit)
        for _ in range(OUTPUT_ERROR_ROUNDS):
            fit = once(np.asarray(fit.y_hat))
    return fit


class _Fitted:
    """A law's `refit` and the strain it predicts over the whole record: the fitted law solved
    exactly (`fitted_strain`), or the refit's own ``y_hat`` with the reason in `unsolved`."""

    def __init__(self, refit, strain, unsolved=None):
        self.refit, self.strain, self.unsolved = refit, strain, unsolved


def _solved(model, fit, stress, grid, origin):
    """`fit` with the strain of its law solved exactly where the law has a closed form (the
    constant-order laws) and the solve is not `too_costly` on the clock."""
    from ._models._fitted import too_costly

    if model == "variable":  # the refit is the variable-order law's own solve
        return _Fitted(fit, np.asarray(fit.y_hat))
    why = too_costly(grid.get("t"))
    if why:
        return _Fitted(fit, np.asarray(fit.y_hat),
                       f"the refit's residual: {why}; fewer `max_points` allow it")
    try:
        strain = _law(model).fitted_strain(fit, stress, **grid, origin=origin)
    except ValueError as err:  # an unphysical law (its signs held, a Zener spring E1 ≤ 0)
        return _Fitted(fit, np.asarray(fit.y_hat), f"the refit's residual: {err}")
    return _Fitted(fit, np.asarray(strain))


def _at_least_nested(fit, early, nested, nested_early, scaled, inside, tail):
    """The fit (and the fit of the record's first part) of a law, or of the law it nests
    where that fits better: ``(fit, early, note or None)``; `scaled` gives a fit's residuals
    as fitted (relative where asked), `inside` and `tail` the samples compared."""
    def rss(f, where):
        r = scaled(f)[where]
        return float(r @ r)

    note = None
    if rss(nested, inside) < rss(fit, inside):
        fit, note = nested, "E0 at 0: the Maxwell fit"
    early_part = inside & ~tail  # the part they were fitted to
    if rss(nested_early, early_part) < rss(early, early_part):
        early = nested_early
    return fit, early, note


def compare(stress, strain=None, dt=None, *, t=None, models=MODELS, knots: int = 3,
            holdout: float = 0.25, max_points: int = MAX_POINTS, window=None,
            x0="estimate", origin=None, relative: bool = False) -> Comparison:
    """Fits each of `models` to one record (the strain as output, the stress as input, as
    in ``σ = η D^{q} ε``) and ranks them by evidence. The samples lie at ``k·dt`` or at the
    times `t`; or `stress` is a `Record` (`vojax.load_records`, one input) given alone,
    ``compare(record)``: its input, output and own clock.

    - `models`: any of ``"springpot"``, ``"kelvin-voigt"``, ``"maxwell"``, ``"zener"`` (the
      constant-order laws of `vojax.Springpot` … `vojax.FractionalZener`, with their sign
      constraints) and ``"variable"`` (a springpot whose order moves on `knots` knots, from
      2 to a quarter of the points compared); one name alone is that model alone;
    - `holdout`: the fraction at the end of the record (of the window, with one) that a
      second fit of each model does not see and predicts (the whole loading history still
      drives it).

    As `refit`'s, and passed to every law's refit: `window` ``(from, to)``, the samples fitted
    and compared (e.g. after a rheometer's inertial ringing; N below is their number);
    `x0`, the strain's offset, ``"estimate"`` (default, one free number), ``None`` (the
    first sample) or a number (a tared sensor); `origin`, the test's start before the first
    sample (a step load there); `relative`, residuals relative to the strain (for data over
    decades: the likelihood is then that of noise proportional to the data, and the held-out
    error the RMS relative error).

    Each constant-order law's residuals, and so its likelihood, held-out error and lag-1,
    are those of the fitted law solved exactly for the strain from the stress alone
    (`fitted_strain`; the variable order's refit is its own solve). A law that feeds the
    strain back (Kelvin–Voigt, Zener) is fitted by output error: refitted with its own
    strain as the regressor, where the measured strain's noise would bias it. The exact
    solve sums N²/2 lags on a clock that is not uniform (fewer where it turns uniform); one
    of more than `vojax._models._fitted.EXACT_SOLVE_LAGS` keeps the refit's residuals and
    says so in the row.

    The log evidence is the Schwarz approximation ``log L̂ − (k/2) ln N`` (k the free
    numbers, the noise level's included; L̂ the Gaussian likelihood at the fit), whose
    differences are log Bayes factors for large N. The verdict names the best model and its
    Bayes factor over the next; below 3 it says the data cannot tell them apart.

    A record longer than `max_points` samples (from 100 to 1,000,000) is compared on the
    means of blocks of ``B`` consecutive samples, as `identify`'s tracker fits one (its
    first sample alone, then blocks: mean time, stress and strain, on that coarser clock);
    ``Comparison.block`` is ``B`` (1: every sample), and the rows' fits, N and evidence are
    those of the block means (each law's refit costs time in proportion to its points:
    `docs/benchmarks.md`).
    """
    stress, strain, dt, t = check.record_arguments(
        stress, strain, dt, t, output="strain", call="compare")
    models = (models,) if isinstance(models, str) else models  # one model, by its name
    stress, strain = _checked_arrays(stress, strain, models, holdout, dt, t)
    max_points = check.count(max_points, "max_points", 100, 1_000_000)
    if "variable" in models:  # a moving order needs two knots; each a few points to fit it
        knots = check.count(knots, "knots", 2, max(2, min(stress.size, max_points) // 4))
    _check_x0(x0, origin)
    check.flag(relative, "relative")
    num = stress.size
    times = float(dt) * np.arange(num) if t is None else np.asarray(t, float)
    grid = dict(dt=dt) if t is None else dict(t=times)
    block = block_size(num, max_points)
    if block > 1:  # block means on the coarser clock, as the tracker fits a long record
        times, stress, strain = (block_average(v, block) for v in (times, stress, strain))
        num, grid = stress.size, dict(t=times)
    inside = _weights(num, None, None, window, relative, times, strain) > 0
    first, split = _parts(times, inside, holdout, window)
    tail = inside & (times > split)
    fitting = dict(x0=x0, origin=origin, relative=relative)
    fits = {}

    def fitted(model, part=window):  # each law's fit once, over the window or its first part
        key = (model, None if part is None else tuple(part))
        if key not in fits:
            fit = _fit(model, stress, strain, grid, knots, part, fitting)
            fits[key] = _solved(model, fit, stress, grid, origin)
        return fits[key]

    def scaled(fit):  # a fit's residuals (its law solved exactly), relative where asked
        r = np.asarray(strain) - fit.strain
        return r / np.where(inside, strain, 1.0) if relative else r  # y ≠ 0 where compared

    part = (first, split)
    offset = 1 if isinstance(x0, str) else 0  # an estimated offset is a free number
    rows = []
    for model in dict.fromkeys(models):
        fit, early = fitted(model), fitted(model, part)
        k = np.asarray(fit.refit.knots).size + np.asarray(fit.refit.p).size + offset + 1  # + σ
        nested = None
        if model == "zener":
            # the Zener with E0 = 0 is the Maxwell law: its output-error fit (the strain fed
            # back, refitted until it settles) can stop short of that, so the Maxwell fit
            # stands in where it fits better (the Zener's count of quantities kept)
            fit, early, nested = _at_least_nested(
                fit, early, fitted("maxwell"), fitted("maxwell", part), scaled, inside, tail
            )
        rows.append(
            _row(model, int(k), fit, early, strain, scaled, inside, tail, nested, relative))
    for r in rows:
        bad = [k for k, v in r.items() if isinstance(v, float) and not math.isfinite(v)]
        if bad:
            raise ValueError(
                f"the fit of {r['model']} gave a non-finite {bad[0]}: this record does not "
                "determine that law (check that the stress drives the strain)."
            )
    rows.sort(key=lambda r: -r["log_evidence"])
    top = rows[0]["log_evidence"]
    weights = np.exp([r["log_evidence"] - top for r in rows])
    for r, w in zip(rows, weights / weights.sum()):
        r["weight"] = float(w)
    num = int(inside.sum())
    return Comparison(rows, verdict_of(rows, num), block)


def _parts(times, inside, holdout, window):
    """The first fitted time and the split before the held-out end, both inside the window;
    refuses a window too short to compare on."""
    idx = np.flatnonzero(inside)
    if idx.size < MIN_POINTS:
        where = ("the record" if window is None
                 else f"`window` {tuple(float(v) for v in window)}")
        raise ValueError(
            f"{where} holds {idx.size} samples; compare needs at least {MIN_POINTS} to fit "
            "each law and predict its held-out end."
        )
    return times[idx[0]], times[idx[int(round((1 - holdout) * (idx.size - 1)))]]


def _row(model, k, fit, early, strain, scaled, inside, tail, nested, relative):
    """One law's row: its likelihood and criteria over the `inside` samples (with relative
    residuals, the density of noise proportional to the data), the held-out prediction's
    error on `tail`, the residuals' lag-1 correlation, the order (a range where it moves)
    and its refit."""
    num = int(inside.sum())
    res = scaled(fit)[inside]
    rss = float(res @ res)
    loglik = -0.5 * num * (math.log(2 * math.pi * max(rss, 1e-300) / num) + 1.0)
    if relative:  # the Jacobian of y ↦ r/y: a density of the data, as the absolute rows'
        loglik -= float(np.sum(np.log(np.abs(strain[inside]))))
    miss = scaled(early)[tail]
    span = 1.0 if relative else (float(np.ptp(strain[inside])) or 1.0)
    e = res - res.mean()
    lag1 = float(e[1:] @ e[:-1] / (e @ e)) if e @ e > 0 else 0.0  # an exact fit: none
    order = np.asarray(fit.refit.order)
    return dict(
        model=model, quantities=k, log_likelihood=loglik,
        aic=-2 * loglik + 2 * k, bic=-2 * loglik + k * math.log(num),
        log_evidence=loglik - 0.5 * k * math.log(num),
        holdout_nrmse=float(np.sqrt(np.mean(miss**2)) / span), lag1=lag1,
        order=(f"{order[0]:.3f}" if np.all(order == order[0])
               else f"{order.min():.3f}–{order.max():.3f}"),
        refit=fit.refit, solved=fit.unsolved is None,
        **({"note": nested} if nested else {}),
        **({"unsolved": fit.unsolved} if fit.unsolved else {}),
    )


def _checked_arrays(stress, strain, models, holdout, dt, t):
    """The stress and strain as (N,) float arrays, each argument checked."""
    stress = np.asarray(check.samples(stress, "stress"), float)
    strain = np.asarray(check.samples(strain, "strain"), float)
    if stress.ndim == 2 and stress.shape[1] == 1:  # one input column, as a Record holds it
        stress = stress[:, 0]
    if stress.ndim != 1 or stress.shape != strain.shape:
        raise ValueError(
            f"`stress` and `strain` must both have shape (N,) (or the stress (N, 1)), got "
            f"{stress.shape} and {strain.shape}."
        )
    if not hasattr(models, "__iter__"):
        raise TypeError(f"`models` must be a sequence of some of {', '.join(MODELS)}, got "
                        f"{models!r}.")
    unknown = [m for m in models if m not in MODELS]
    if unknown or not models:
        raise ValueError(f"`models` must be some of {', '.join(MODELS)}, got {models!r}.")
    if not 0.05 <= check.real(holdout, "holdout") <= 0.5:
        raise ValueError(f"`holdout` must lie in [0.05, 0.5], got {holdout!r}.")
    if (dt is None) == (t is None):
        raise ValueError("give exactly one of `dt` and `t`.")
    _check_degenerate(stress, strain)
    return stress, strain


def _check_degenerate(stress, strain):
    """Refuses, in one sentence each, a record no law can be compared on: no stress, no
    change of strain, the same series as both, or magnitudes outside `check.MAGNITUDES`."""
    if not np.any(stress):
        raise ValueError("`stress` is 0 at every sample: nothing drives the strain, so no "
                         "law can be fitted to it.")
    if np.ptp(strain) == 0:
        raise ValueError(f"`strain` is {strain[0]:g} at every sample: there is no response "
                         "to fit.")
    if stress.shape == strain.shape and np.array_equal(stress, strain):
        raise ValueError("`stress` and `strain` are the same series: give the measured "
                         "stress as the input and the strain as the output.")
    check.magnitude(stress, "stress")
    check.magnitude(strain, "strain")


def verdict_of(rows, num) -> str:
    """The comparison's verdict from its `rows` (sorted by evidence) on `num` samples: the
    best law and its Bayes factor over the next, "strongly" from `STRONG_BF` on, "cannot
    tell apart" below `UNDECIDED_BF`; and a warning where the best law's residuals are
    correlated beyond `correlation_limit`."""
    if len(rows) == 1:
        verdict = f"only {rows[0]['model']} was fitted."
    else:
        bf = math.exp(min(rows[0]["log_evidence"] - rows[1]["log_evidence"], 700.0))
        a, b = rows[0]["model"], rows[1]["model"]
        if bf < UNDECIDED_BF:
            verdict = (f"the data cannot tell {a} and {b} apart (Bayes factor {bf:.2g}); "
                       f"prefer the simpler unless the held-out error says otherwise.")
        else:
            strength = "strongly " if bf >= STRONG_BF else ""
            verdict = f"{a} is {strength}favoured over {b} by a Bayes factor of {bf:.3g}."
    limit = correlation_limit(num)
    if rows[0]["lag1"] > limit:
        verdict += (
            f" Its residuals are correlated (lag-1 autocorrelation {rows[0]['lag1']:.2f} > "
            f"{limit:.2g}): the evidence assumes white noise, so these Bayes factors are too "
            "large; no model here describes every feature of the record."
        )
    return verdict
