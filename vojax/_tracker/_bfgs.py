"""BFGS on a few variables, as one small `lax.while_loop`: the tuner's refinement of the noise
intensities (`_track._refine`).

The algorithm is optimistix's `BFGS` with its defaults: an inverse-Hessian update, a
backtracking Armijo search from a unit step, and termination when both the accepted step and
the change of the loss are small. Its iterates are optimistix's: on the tracker's refinement
the two agree to the last bit (``scripts/bench_bfgs.py``); ``tests/test_bfgs.py`` checks the
rules below, transcribed in NumPy, and optimistix's minima. Written out here, the program
takes about half the time to trace (a first call of `identify` pays it, with the compilation
cache warm or not); it compiles and runs in the same time (``scripts/bench_bfgs.py`` and its
results).

One evaluation of the loss per iteration, at the point ``y_eval``, linearised there:

- accept it where this is the first iteration, or where the loss fell by at least `SLOPE`
  times the decrease its gradient at the last accepted point ``y`` predicts (and that
  prediction is a decrease); then the gradient ``g_eval`` is computed (the linearisation
  transposed), the step returns to 1, the inverse Hessian ``H`` takes the BFGS update
  (skipped where ``(g_eval − g)·(y_eval − y)`` is not above the machine epsilon, which keeps
  ``H`` positive definite), and the direction becomes ``H g_eval``;
- reject it otherwise, and halve the step (`DECREASE`) along the same direction;
- the next point is ``y − step · direction``.

It stops after an accepted iteration (not the first) whose move and change of the loss are
both within ``atol + rtol·|·|`` of the new point's (largest component), or after
`max_steps` evaluations; it returns the last accepted point.
"""

import jax
import jax.numpy as jnp
from jax import lax

DECREASE = 0.5  # the step's factor after a rejected point
SLOPE = 0.1  # the fraction of the predicted decrease an accepted point must achieve


def minimise(loss, y0, max_steps: int, rtol: float, atol: float):
    """Minimises the scalar `loss` of a vector from `y0` (see the module's docstring).
    Returns ``(y, evaluations)``: the last accepted point and how many evaluations ran."""
    dtype = y0.dtype
    eps = jnp.finfo(dtype).eps
    zero = jnp.zeros((), dtype)
    one = jnp.ones((), dtype)
    # y, y_eval, f(y), g(y), H, direction, step, first, stop, evaluations
    start = (y0, y0, zero, jnp.zeros_like(y0), jnp.eye(y0.shape[0], dtype=dtype),
             jnp.zeros_like(y0), one, jnp.asarray(True), jnp.asarray(False),
             jnp.asarray(0, jnp.int32))

    def small(new, diff, f_new, f_diff):
        y_ok = jnp.max(jnp.abs(diff) / (atol + rtol * jnp.abs(new))) < 1
        f_ok = jnp.abs(f_diff) / (atol + rtol * jnp.abs(f_new)) < 1
        return y_ok & f_ok

    def cond(carry):
        *_, stop, count = carry
        return ~stop & (count < max_steps)

    def body(carry):
        y, y_eval, f, g, h, direction, step, first, _, count = carry
        f_eval, linear = jax.linearize(loss, y_eval)
        s = y_eval - y
        predicted = jnp.dot(g, s)
        accept = first | ((f_eval - f <= SLOPE * predicted) & (predicted <= 0))
        # the gradient only where the point is accepted (a rejected one keeps g)
        g_eval = lax.cond(accept, lambda: jax.linear_transpose(linear, y_eval)(
            jnp.ones((), dtype))[0], lambda: g)
        # the inverse Hessian's BFGS update from the move s and the change of the gradient
        d = g_eval - g
        inner = jnp.dot(d, s)
        hd = h @ d
        safe = jnp.where(inner > eps, inner, one)
        updated = (h + (inner + jnp.dot(d, hd)) * jnp.outer(s, s) / safe**2
                   - (jnp.outer(hd, s) + jnp.outer(s, hd)) / safe)
        h_new = jnp.where(inner > eps, updated, h)
        stop = ~first & small(y_eval, s, f_eval, f_eval - f)
        pick = lambda a, b: jnp.where(accept, a, b)  # noqa: E731
        y, f, g, h = pick(y_eval, y), pick(f_eval, f), pick(g_eval, g), pick(h_new, h)
        direction = pick(h_new @ g_eval, direction)
        step = jnp.where(accept, one, DECREASE * step)
        return (y, y - step * direction, f, g, h, direction, step, jnp.asarray(False),
                accept & stop, count + 1)

    y, *_, count = lax.while_loop(cond, body, start)
    return y, count
