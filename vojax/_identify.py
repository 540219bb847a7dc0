"""`identify`: the paper's law (Theorem 1) or the Bayesian tracker over a whole record."""

from . import _validate as check
from ._adaptive._build import DEFAULT_BOUNDS
from ._adaptive._estimator import LawEstimator
from ._identification import Identification
from ._settings import TrackerSettings
from ._tracker._estimator import KALMAN_BOUNDS, Tracker
from ._xla import spare_mappings


def identify(
    u,
    y=None,
    dt=None,
    *,
    t=None,
    method: str = "kalman",
    smooth: bool = True,
    lam=None,
    gamma=None,
    alpha0=None,
    alpha_bounds=None,
    memory: str = "exponential",
    rule: str = "trapezoid",
    x0=None,
    r0=None,
    noise=None,
    parameters=None,
    mask=None,
    window=None,
    max_points: int | None = None,
    tol: float = 1e-10,
    warn: bool = True,
    time_scale=None,
    settings=None,
) -> Identification:
    """Identifies the order α(t) and parameters p of ``D^{α(t)} x = pᵀu`` with a band for each.

    Two methods over the same memory kernels (the same names as the CLI's ``--method`` and
    the keys of its ``summary.json``):

    - ``method="kalman"`` (default): a joint Bayesian tracker of ``(α, p, x0)`` — order
      (through a logistic map of `alpha_bounds`) and parameters as random walks, the offset
      estimated — whose noise intensities are chosen by maximising the innovation likelihood,
      started from a constant-order least-squares fit. ``smooth=True`` returns the posterior
      mode of the whole trajectory (iterated extended Kalman smoother: Gauss–Newton) with its
      Laplace bands; ``smooth=False`` the online iterated EKF's causal estimates.
    - ``method="gradient"``: the paper's adaptive law (Theorem 1) in the exact discrete form,
      one jit-compiled `lax.scan` — LSFF with forgetting ``λ`` for ``p``, the order-gradient
      law with gain ``γ`` and projection onto `alpha_bounds`, ``∂p/∂β`` (26) by forward-mode
      autodiff. The law sees ``y − x0`` with ``x0 = y[0]`` unless given (Remark 4). Its band
      is its spread over the measurement noise, not a confidence band: it never reports
      the order identified.

    With one input a variable order is not determined by the data alone: a rescaled ``p`` has
    an order trajectory that fits as well, and what settles it is the regularity assumed (the
    law's gains, the tracker's drift intensities). The bands say how well the data pin the
    estimate down *under that assumption*; `diagnostics` flags wide bands, orders at a bound
    and settings at the edge of their search, and an `IdentifiabilityWarning` is issued then
    (``warn=False`` to silence it).

    **Arguments:**

    - `u`: inputs, ``(N,)`` or ``(N, n)``; `y`: measured output ``(N,)``. Or `u` a
      `Record` (`vojax.load_records`) and no `y`, `dt` or `t`: its inputs, output and own
      clock (uniform or not), ``identify(record)``.
    - `dt`: the step; or `t`: the sample times ``(N,)``, strictly increasing (exactly one).
      On a non-uniform grid the memory uses exact weights for every step and the law
      integrates over the local step ``t_k − t_{k−1}`` (LSFF's forgetting ``e^{−λh_k}``, the
      order law's ``h_k γ``); gains and forgetting keep their units (1/time).
    - `method`, `smooth`: see above.
    - `gamma`, `lam`, `alpha0`, `r0`: the law's settings (``method="gradient"`` only;
      given with the tracker they are an error, never ignored).
    - `gamma`: the law's order gain γ > 0, or ``"auto"`` (the default, None) to choose it by
      `tune_gains` from normalised signals (unit-free). A number is taken literally, as the
      paper's 0.01.
    - `lam`: forgetting factor λ > 0; ``None`` (default): tuned with γ when ``gamma="auto"``,
      the paper's 0.9 otherwise. A number with ``gamma="auto"`` tunes γ alone at that λ.
    - `alpha0`: α̂(0) of the law, inside `alpha_bounds` (default 0.5).
    - `alpha_bounds`: the order range ⊂ (0, 1); default (0.05, 0.95) for the law (its
      projection), (0.01, 0.99) for the tracker.
    - `memory`: ``"exponential"`` (O(1) per sample) or ``"direct"``; `rule`: the quadrature.
    - `x0`: the output's offset, in the units of `y`: the output the system gives before
      any input (the reading of a tared sensor at rest, often 0). The law's initial output
      (default ``y[0]``). The tracker estimates it unless given (None, the default); given,
      the tracker holds it there. A known offset removes a trade-off that one input leaves:
      a lower order with larger parameters and a shifted offset can fit a record almost as
      well; with the parameters stated constant as well, it narrows the band most
      (`docs/tracker.md`). Give it only where it is measured: a wrong offset moves
      the order.
    - `r0`: the law's initial information ``R_0``: ``"auto"`` (the default, None: one sample's worth at
      α̂(0), scaled to the inputs), or an ``(n, n)`` matrix taken literally (the paper's
      ``P(0) = I`` is ``np.eye(n)``).
    - `noise`: the tracker's noise intensities, instead of tuning them: a dict with
      ``order_drift`` (variance of the logistic order coordinate's change over the record),
      ``parameter_drift`` (variance of each normalised parameter's change over the record;
      1e-6 or less states the parameters constant, as ``parameters="constant"`` does) and
      ``noise_std`` (of the measurement, in the units of `y`).
    - `parameters`: ``method="kalman"`` only: what you know of the parameters' drift over
      the record, relative, ``(max − min)/|mean|`` (in units of the record's span).
      ``"free"`` (the default, None; ``"drifting"`` says the same): they may drift, their
      drift tuned with the order's. With one input a drifting parameter can stand in for a
      moving order, so the band covers every order that an explanation with drifting
      parameters fits as well, and `diagnostics.verdict` says "conditional" where the order
      is pinned down only while the parameters drift less than
      `diagnostics.breakdown_drift` (the band that holds then: `conditional`).
      ``"constant"`` (or 0): known not to drift (a calibrated instrument, a test short
      against any ageing); their drift is held, and the band holds under that assumption
      only, the parameters' scale (which trades off with the order's level) integrated
      over. A number D > 0: they drift by at most D; the band covers the explanations whose
      parameters drift no more.
    - `mask`: ``method="kalman"`` only: an ``(N,)`` array of 0 and 1; samples with 0 are not
      fitted (the tracker still estimates the states there, from its random-walk model). Used
      to pad records to a common length so that one compiled program serves many lengths;
      the diagnostics cover the samples up to the last one fitted.
    - `window`: ``method="kalman"`` only: ``(from, to)`` in the record's time (an end None:
      open): only the samples with ``from ≤ t_k ≤ to`` are fitted, e.g. the hold of a
      ramp–hold test or a creep record after the rheometer's inertial ringing. The whole
      input history still drives the memory (cutting the record would lose it). Outside the
      window the estimates follow the random-walk model (the band widens); the diagnostics,
      the verdict and `summary()` speak of the window (`Identification.fitted`). With
      `mask`, the samples fitted are those of both.
    - `max_points`: ``method="kalman"`` only: the most points the tracker fits (None: 1,000;
      from 100 to 50,000). A longer record is fitted as the means of blocks of ``B``
      consecutive samples (its first sample kept alone, so that the integral starts where the
      record does): block means of time, input and output, on that coarser clock. The
      estimates are brought back to every sample (linear between block times, ``y_hat`` from
      one memory run over the whole record at that order), and `diagnostics` gives ``B`` and
      the coarse clock's model error against the noise of a block mean (above 0.5 the order
      is not reported identified). Where blocks of 10 samples or more leave the prediction
      errors correlated, the record is fitted once more on up to 3 × `max_points` points,
      and that fit is the answer (`TrackerSettings.block_refine`, `block_refine_from`; the
      first fit stops once its tuned smoothing shows the correlation). The
      tracker's cost grows with its points, not the record's length (`docs/benchmarks.md`).
    - `tol`: accuracy of the exponential memory; `warn`: issue `IdentifiabilityWarning`.
    - `time_scale`: ``method="kalman"`` only: the unit of time in which `parameters`
      states the parameters constant or drift-bounded (None: the record's span). The order
      then does not depend on the unit the times are given in: with a variable order, a
      parameter constant in seconds drifts in milliseconds (``p·1000^(−α(t))``). Unless it
      is given, the tracker also fits with the parameters constant in the data's unit
      (``time_scale=1``); where that order lies outside the band, the band covers it
      (reason ``clock``), except where that account is excluded: with the parameters
      stated constant (on the span's clock its parameters drift), or, free or constant,
      where the span's fit explains the data better by more than
      ``settings.clock_evidence`` nats per fitted point; then it is covered only where
      covering it still leaves an answer (±0.1).
    - `settings`: the tracker's tuned numbers (a `vojax.TrackerSettings`; its defaults where
      None); ``method="kalman"`` only.

    **Returns:** an `Identification`. **Raises:** `ValueError` for bad input, and when the
    estimate is not finite (the law diverged), naming the sample.
    """
    u, y, dt, t = check.record_arguments(u, y, dt, t)
    check.choice(method, ("kalman", "gradient"), "method")
    spare_mappings()  # a long process never reaches the cap on memory mappings
    if alpha_bounds is None:
        alpha_bounds = DEFAULT_BOUNDS if method == "gradient" else KALMAN_BOUNDS
    if method == "kalman":
        law = dict(gamma=gamma, lam=lam, alpha0=alpha0, r0=r0)
        given = [f"`{k}`" for k, v in law.items() if v is not None]
        if given:
            raise ValueError(
                f"{', '.join(given)} set the paper's law, which method='kalman' (the default) "
                "does not use; add method='gradient', or leave them out."
            )
        tracker = Tracker(
            parameters=parameters, x0=x0, smooth=smooth,
            alpha_bounds=alpha_bounds, memory=memory, rule=rule, noise=noise,
            max_points=max_points, tol=tol, time_scale=time_scale,
            settings=TrackerSettings() if settings is None else settings,
        )
        return tracker._fit(u, y, dt, t, mask, warn, stacklevel=3, window=window)
    tracker_only = dict(
        settings=settings, time_scale=time_scale, max_points=max_points, parameters=parameters,
        noise=noise, window=window,
    )
    _check_law_arguments(tracker_only, mask, smooth)
    law = LawEstimator(
        gamma="auto" if gamma is None else gamma, lam=lam,
        alpha0=0.5 if alpha0 is None else alpha0, alpha_bounds=alpha_bounds, memory=memory,
        rule=rule, x0=x0, r0=r0, tol=tol,
    )
    return law._fit(u, y, dt, t, warn, stacklevel=3)


def _check_law_arguments(tracker_only, mask, smooth):
    """The tracker's arguments given with ``method="gradient"``: an error, never ignored."""
    for name, value in tracker_only.items():
        if value is not None:
            raise ValueError(
                f"`{name}` sets the tracker (method='kalman'); the paper's law does not use it."
            )
    if mask is not None:
        raise ValueError("`mask` is for method='kalman'; the paper's law fits every sample.")
    if not check.flag(smooth, "smooth"):  # the tracker checks its own
        raise ValueError(
            "`smooth=False` sets the tracker (method='kalman'); the paper's law does not use it."
        )
