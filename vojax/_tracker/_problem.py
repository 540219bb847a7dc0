"""One record as the tracker fits it: its arrays in normalised units, its clock, the prior
and the settings, bundled once (`Problem`) instead of passed value by value."""

import dataclasses

import jax
import numpy as np

from .._settings import TrackerSettings
from .._xla import to_device
from ._smoother import iterated_smoother, resolve_schedule


@dataclasses.dataclass(frozen=True)
class Scales:
    """Normalisation: ``ỹ = (y − y_ref)/y_scale``, ``ũ_j = u_j/u_scale_j``; the tracker's
    parameters are then ``p̃ = p · u_scale / y_scale`` and its offset ``c̃ = (x0 − y_ref)/y_scale``."""

    y_ref: float
    y_scale: float
    u_scale: tuple[float, ...]

    def output(self, y_n):
        """The output in the user's units from the normalised ``ỹ`` (NumPy)."""
        return self.y_ref + self.y_scale * np.asarray(y_n)


def _weighted_mean(x, w):
    return float(np.sum(w * x) / np.sum(w))


def rms(x, w=None):
    """Root mean square without overflow (scaled by the largest magnitude first)."""
    x = np.asarray(x, dtype=float)
    big = float(np.max(np.abs(x))) if x.size else 0.0
    if not big > 0 or not np.isfinite(big):
        return big if np.isfinite(big) else float("inf")
    z = (x / big) ** 2
    mean = float(np.sum(w * z) / np.sum(w)) if w is not None else float(np.mean(z))
    return big * float(np.sqrt(mean))


def data_scales(u, y, mask) -> Scales:
    """Reference level and scale of the output, RMS of each input; errors name what is flat."""
    y, u, w = np.asarray(y), np.asarray(u), np.asarray(mask)
    if not np.all(np.isfinite(y)) or not np.all(np.isfinite(u)):
        raise ValueError("`u` and `y` must be finite (an overflow in a unit conversion?).")
    y_ref = _weighted_mean(y, w)
    y_scale = rms(y - y_ref, w)
    if not y_scale > 0 or not np.isfinite(y_scale):
        raise ValueError("`y` is constant over the fitted samples: there is nothing to identify.")
    u_scale = np.array([rms(u[:, j], w) for j in range(u.shape[1])])
    if np.any(~(u_scale > 0)) or not np.all(np.isfinite(u_scale)):
        j = int(np.argmax(~(u_scale > 0) | ~np.isfinite(u_scale)))
        raise ValueError(f"input column {j} of `u` is zero everywhere: its parameter is undefined.")
    return Scales(y_ref, y_scale, tuple(float(s) for s in u_scale))


def prior(num_inputs, dtype, settings: TrackerSettings, coloured=False, offset_known=False):
    """Prior of θ_0 in normalised units, the same whatever the start: the order's β centred
    on the middle of the range, parameters and offset centred on zero, all wide; `coloured`:
    with a coloured noise's AR(1) part last, centred on zero (its variance, here 1, is set by
    the intensities: `Hyper.initial`); `offset_known`: the offset held at zero (variance
    `offset_pin`: the same program as an estimated offset)."""
    s = settings
    offset = s.offset_pin if offset_known else s.prior_var
    var = [s.prior_beta_var] + [s.prior_var] * num_inputs + [offset] + [1.0] * coloured
    return to_device(np.zeros(len(var), dtype)), to_device(np.diag(np.asarray(var, dtype)))


@dataclasses.dataclass(frozen=True)
class Problem:
    """What every pass of the tracker reads: the memory designed for the record's clock, the
    normalised inputs `u` (N, n) and output `y` (N,), the 0/1 `mask` of fitted samples, the
    `steps` ``t_{k+1} − t_k`` (N,) and the `horizon` T (device arrays), the prior ``(m0,
    p0)`` of θ_0, the order `bounds`, the sample `times` (host), the index `last` of the last
    fitted sample, the `settings`, and how runs execute: the filter's `schedule`, and
    whether a pass's runs go `batched` through one vmapped program."""

    memory: object
    u: jax.Array
    y: jax.Array
    mask: jax.Array
    steps: jax.Array
    horizon: jax.Array
    m0: jax.Array
    p0: jax.Array
    bounds: tuple[float, float]
    times: np.ndarray
    last: int
    settings: TrackerSettings
    schedule: str = dataclasses.field(default_factory=resolve_schedule)
    batched: bool = False

    @property
    def n(self) -> int:
        """The number of inputs."""
        return int(self.u.shape[1])

    @property
    def span(self) -> int:
        """The samples up to the last fitted one (padding after it is not the record's)."""
        return self.last + 1

    @property
    def record(self):
        """``(memory, u, y, mask, steps, horizon)``: the compiled smoother's first arguments."""
        return self.memory, self.u, self.y, self.mask, self.steps, self.horizon

    def with_prior(self, m0, p0) -> "Problem":
        return dataclasses.replace(self, m0=m0, p0=p0)

    def smooth(self, hyper, nominal, max_iter=None):
        """One smoothing at the intensities `hyper` from the trajectory `nominal` (N, d)."""
        budget = self.settings.max_iter if max_iter is None else max_iter
        return iterated_smoother(*self.record, hyper, self.m0, self.p0, nominal, self.bounds,
                                 budget, self.schedule)

    def smooth_from(self, hyper, start):
        """One smoothing at fixed intensities `hyper`, from the constant trajectory `start`
        (d,)."""
        start = np.asarray(start, np.dtype(self.u.dtype))
        return self.smooth(hyper, to_device(np.broadcast_to(start, (self.u.shape[0],
                                                                    start.shape[0]))))
