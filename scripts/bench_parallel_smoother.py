"""The tracker's Kalman filter and RTS smoother as parallel prefix sums over the samples,
measured against the sequential scans that vojax uses: alone (N = 1,000 samples, 3 states)
and inside the tracker (`vojax.identify` on 400 and 1,000 samples, every filter and smoother
of its smoothings and of its likelihood's gradient replaced), under XLA's default CPU loops and with `vojax.use_fast_cpu_loops()`.

Each sample is an affine Gaussian map of the state before it. For the filter, sample k's
element is the law of θ_k given θ_{k−1} and z_k, ``θ_k | θ_{k−1} ~ N(A θ_{k−1} + b, C)``, with
the information that z_k carries about θ_{k−1}, ``exp(−½ θᵀ J θ + ηᵀ θ)``; the first element
holds the prior. Elements combine associatively and the prefix of elements 0…k is the filtered
law of θ_k; the smoother's elements ``θ_k | θ_{k+1} ~ N(E θ_{k+1} + g, L)`` combine from the
end (Särkkä and García-Fernández, "Temporal parallelization of Bayesian smoothers", IEEE TAC
2021). Here the measurements are in information form, so that a sample's scalar measurement
(precision ``mask/r`` along ``H_k``) and the Levenberg–Marquardt anchor (precision μ on every
component) enter as one term, and no process variance is inverted (the offset's is zero).

Two schedules of the prefix sums: `associative` (`lax.associative_scan`, 2·log₂N vectorised
sweeps, no loop) and `chunked` (two loops of about √N steps over all chunks at once, then one
vectorised step). The script checks that both equal the sequential scans to rounding, then
times each case in a fresh process.

    python scripts/bench_parallel_smoother.py [--out FILE]
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import jax
import jax.numpy as jnp
from jax import lax

from vojax._tracker._kalman import LOG_2PI, Filtered

from _bench import publish

_mm = lambda a, b: jnp.einsum("...ij,...jk->...ik", a, b)  # noqa: E731
_mv = lambda a, v: jnp.einsum("...ij,...j->...i", a, v)  # noqa: E731
_t = lambda a: jnp.swapaxes(a, -1, -2)  # noqa: E731


def _inv(a):
    """Inverse of a batch (..., d, d) of small matrices whose leading principal minors are
    nonzero (here I + CJ with C, J positive semidefinite), by Gauss–Jordan elimination
    unrolled into elementwise operations that XLA fuses."""
    d = a.shape[-1]
    m = [[a[..., i, j] for j in range(d)] for i in range(d)]
    inv = [[jnp.ones_like(m[0][0]) if i == j else jnp.zeros_like(m[0][0]) for j in range(d)]
           for i in range(d)]
    for k in range(d):
        piv = 1.0 / m[k][k]
        m[k] = [x * piv for x in m[k]]
        inv[k] = [x * piv for x in inv[k]]
        for i in range(d):
            if i != k:
                fac = m[i][k]
                m[i] = [x - fac * y for x, y in zip(m[i], m[k])]
                inv[i] = [x - fac * y for x, y in zip(inv[i], inv[k])]
    return jnp.stack([jnp.stack(row, -1) for row in inv], -2)


def chunked_scan(fn, elems, identity, reverse=False):
    """All prefix sums of `elems` (leaves with leading axis N) under the associative `fn`,
    like ``lax.associative_scan(fn, elems, reverse=reverse)``, in two short loops: the
    samples are cut into about √N chunks of about √N; one loop runs along the chunks, all
    chunks at once; a second one adds up the chunks' totals; one vectorised step applies each
    chunk's offset. `identity` is the neutral element (leaves without the leading axis)."""
    leaves, tree = jax.tree_util.tree_flatten(elems)
    ids = jax.tree_util.tree_leaves(identity)
    num = leaves[0].shape[0]
    width = max(1, math.isqrt(num - 1) + 1)  # chunk length, ⌈√N⌉
    count = -(-num // width)
    pad = count * width - num

    def shape(x, i):
        x = x[::-1] if reverse else x
        x = jnp.concatenate([x, jnp.broadcast_to(i, (pad,) + i.shape).astype(x.dtype)])
        return jnp.swapaxes(x.reshape((count, width) + x.shape[1:]), 0, 1)  # (width, count, …)

    def op(a, b):
        return jax.tree_util.tree_leaves(
            fn(jax.tree_util.tree_unflatten(tree, a), jax.tree_util.tree_unflatten(tree, b))
        )

    def step(carry, x):
        carry = op(carry, x)
        return carry, carry

    start = [jnp.broadcast_to(i, (count,) + i.shape).astype(x.dtype) for i, x in zip(ids, leaves)]
    totals, local = lax.scan(step, start, [shape(x, i) for x, i in zip(leaves, ids)])

    def before(carry, x):
        return op(carry, x), carry

    _, offsets = lax.scan(before, [i.astype(x.dtype) for i, x in zip(ids, leaves)], totals)
    out = op([jnp.broadcast_to(o[None], x.shape) for o, x in zip(offsets, local)], local)
    out = [jnp.swapaxes(x, 0, 1).reshape((count * width,) + x.shape[2:])[:num] for x in out]
    out = [x[::-1] if reverse else x for x in out]
    return jax.tree_util.tree_unflatten(tree, out)


def _sym(a):
    return 0.5 * (a + _t(a))


def _filter_combine(first, second):
    a1, b1, c1, e1, j1 = first
    a2, b2, c2, e2, j2 = second
    eye = jnp.eye(a1.shape[-1], dtype=a1.dtype)
    w = _inv(eye + _mm(c1, j2))  # (I + C₁J₂)⁻¹; (I + J₂C₁)⁻¹ = wᵀ
    m = _mm(a2, w)
    n = _mm(_t(a1), _t(w))
    return (
        _mm(m, a1),
        _mv(m, b1 + _mv(c1, e2)) + b2,
        _sym(_mm(_mm(m, c1), _t(a2)) + c2),
        _mv(n, e2 - _mv(j2, b1)) + e1,
        _sym(_mm(_mm(n, j2), a1) + j1),
    )


def parallel_filter(h, z, r, q, m0, p0, mask=None, anchor=None, damping=None, f=None):
    """`vojax._tracker.kalman_filter`, as a prefix sum; same arguments and result."""
    num, d = h.shape
    dtype = h.dtype
    if mask is None:
        mask = jnp.ones(z.shape, dtype)
    eye = jnp.eye(d, dtype=dtype)
    prec = mask / r
    lam = prec[:, None, None] * h[:, :, None] * h[:, None, :]
    iota = (prec * z)[:, None] * h
    if damping is not None:
        lam = lam + damping * eye
        iota = iota + damping * anchor
    fk = jnp.ones((num - 1, d), dtype) if f is None else f[:-1]
    qk = q[:-1]  # from sample k−1 to k, for k ≥ 1
    # elements k ≥ 1: θ_k | θ_{k−1} ~ N(F θ, Q) observed through (Λ_k, ι_k)
    lam1, iota1 = lam[1:], iota[1:]
    w = _inv(eye + qk[:, :, None] * lam1)  # (I + QΛ)⁻¹
    a = w * fk[:, None, :]
    b = _mv(w, qk * iota1)
    c = _sym(w * qk[:, None, :])
    wt = _t(w)  # (I + ΛQ)⁻¹
    e = fk * _mv(wt, iota1)
    j = _sym(fk[:, :, None] * _mm(lam1, w) * fk[:, None, :])
    # element 0: the prior N(m0, P0) observed through (Λ_0, ι_0)
    w0 = _inv(eye + p0 @ lam[0])
    c0 = _sym(w0 @ p0)
    b0 = w0 @ (m0 + p0 @ iota[0])
    elems = (
        jnp.concatenate([jnp.zeros((1, d, d), dtype), a]),
        jnp.concatenate([b0[None], b]),
        jnp.concatenate([c0[None], c]),
        jnp.concatenate([jnp.zeros((1, d), dtype), e]),
        jnp.concatenate([jnp.zeros((1, d, d), dtype), j]),
    )
    eye0, zero = jnp.eye(d, dtype=dtype), jnp.zeros((d, d), dtype)
    ident = (eye0, jnp.zeros(d, dtype), zero, jnp.zeros(d, dtype), zero)
    _, mean, cov, _, _ = SCAN(_filter_combine, elems, ident)
    pred_mean = jnp.concatenate([m0[None], fk * mean[:-1]])
    pred_cov = jnp.concatenate(
        [p0[None], cov[:-1] * fk[:, :, None] * fk[:, None, :] + _diag(qk)]
    )
    ph = _mv(pred_cov, h)
    s = jnp.sum(h * ph, -1) + r
    innov = z - jnp.sum(h * pred_mean, -1)
    ll = -0.5 * mask * (LOG_2PI + jnp.log(s) + innov * innov / s)
    return Filtered(mean, cov, pred_mean, pred_cov, innov, s, jnp.sum(ll))


def _diag(v):
    return v[..., :, None] * jnp.eye(v.shape[-1], dtype=v.dtype)


def _smoother_combine(later, earlier):
    # associative_scan(reverse=True) passes (element k+1 side, element k side)
    e2, g2, l2 = later
    e1, g1, l1 = earlier
    return _mm(e1, e2), _mv(e1, g2) + g1, _sym(_mm(_mm(e1, l2), _t(e1)) + l1)


def parallel_smoother(filtered: Filtered, q, f=None):
    """`vojax._tracker.rts_smoother`, as a suffix sum; same arguments and result."""
    m, p = filtered.mean, filtered.cov
    num, d = m.shape
    fk = jnp.ones((num - 1, d), m.dtype) if f is None else f[:-1]
    mk, pk = m[:-1], p[:-1]
    p_pred = pk * fk[:, :, None] * fk[:, None, :] + _diag(q[:-1])
    # E = P Fᵀ (P⁻)⁻¹ = (P⁻⁻¹ F P)ᵀ, both symmetric
    gain = _t(jnp.linalg.solve(p_pred, pk * fk[:, :, None]))
    g = mk - _mv(gain, fk * mk)
    ell = _sym(pk - _mm(gain * fk[:, None, :], pk))
    elems = (
        jnp.concatenate([gain, jnp.zeros((1, d, d), m.dtype)]),
        jnp.concatenate([g, m[-1:]]),
        jnp.concatenate([ell, p[-1:]]),
    )
    ident = (jnp.eye(d, dtype=m.dtype), jnp.zeros(d, m.dtype), jnp.zeros((d, d), m.dtype))
    _, ms, ps = SCAN(_smoother_combine, elems, ident, reverse=True)
    return ms, ps


def _associative(fn, elems, identity, reverse=False):
    del identity
    return lax.associative_scan(fn, elems, reverse=reverse)


SCAN = chunked_scan


def child(case, schedule, loops):
    """One measurement in this (fresh) process; prints one JSON line."""
    import numpy as np

    jax.config.update("jax_enable_x64", True)
    import vojax
    from vojax._tracker import _smoother
    from vojax._tracker._kalman import kalman_filter, rts_smoother

    if loops == "fast":
        vojax.use_fast_cpu_loops()
    global SCAN
    SCAN = _associative if schedule == "associative" else chunked_scan
    filt, smooth = (kalman_filter, rts_smoother) if schedule == "sequential" else (
        parallel_filter, parallel_smoother)
    if case == "alone":
        rng = np.random.default_rng(1)
        num, d = 1000, 3
        h, z = rng.standard_normal((num, d)), rng.standard_normal(num)
        q = np.abs(rng.standard_normal((num, d))) * 1e-3
        q[:, -1] = 0.0  # the offset's
        mask = (rng.random(num) > 0.1).astype(float)
        anchor = rng.standard_normal((num, d))
        f = np.where(np.arange(d) == 0, 0.9, 1.0) * np.ones((num, d))
        m0, p0 = np.zeros(d), 2.0 * np.eye(d)

        @jax.jit
        def run(z):
            fl = filt(h, z, 0.1, q, m0, p0, mask, anchor, 0.5, f)
            return fl, smooth(fl, q, f)

        begun = time.perf_counter()
        out = jax.block_until_ready(run(z))
        first = time.perf_counter() - begun
        begun = time.perf_counter()
        for k in range(20):
            jax.block_until_ready(run(z * (1.0 + 1e-3 * k)))
        warm = (time.perf_counter() - begun) / 20
        ref = jax.jit(lambda z: (lambda fl: (fl, rts_smoother(fl, q, f)))(
            kalman_filter(h, z, 0.1, q, m0, p0, mask, anchor, 0.5, f)))(z)
        err = max(float(jnp.max(jnp.abs(a - b)) / jnp.max(jnp.abs(a))) for a, b in
                  zip(jax.tree_util.tree_leaves(ref), jax.tree_util.tree_leaves(out)))
        print(json.dumps(dict(first=first, warm=warm, err=err)))
        return
    # bench_first_call's record: a ramp and hold, a slowly moving order, 1 % white noise
    n, dt = int(case), 0.05
    t = dt * np.arange(n)
    u = np.minimum(t / (0.2 * t[-1]), 1.0) + 0.05 * np.sin(t)
    x = np.asarray(vojax.simulate(u, 0.35 + 0.2 * t / t[-1], np.array([2.0]), dt,
                                  memory="exponential"))
    y = x + 0.01 * np.ptp(x) * np.random.default_rng(0).standard_normal(n)
    # every filter and smoother of the tracker's smoothings and of its likelihood's gradient
    _smoother.kalman_filter, _smoother.rts_smoother = filt, smooth
    begun = time.perf_counter()
    res = vojax.identify(u, y, dt, warn=False)
    res.alpha.block_until_ready()
    first = time.perf_counter() - begun
    begun = time.perf_counter()
    res = vojax.identify(u, 1.001 * y, dt, warn=False)
    res.alpha.block_until_ready()
    second = time.perf_counter() - begun
    print(json.dumps(dict(first=first, warm=second, alpha=np.asarray(res.alpha).tolist())))


def measure(case, schedule, loops):
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    out = subprocess.run([sys.executable, __file__, "--child", case, schedule, loops],
                         capture_output=True, text=True, env=env, check=True)
    result = json.loads(out.stdout.strip().splitlines()[-1])
    print(f"{case}, {schedule}, {loops} loops: first {result['first']:.2f} s, warm "
          f"{result['warm']:.4f} s", file=sys.stderr, flush=True)  # progress
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--child", nargs=3, help=argparse.SUPPRESS)
    parser.add_argument("--cases", nargs="+", default=["alone", "400", "1000"],
                        help="'alone' (the filter and smoother on 1,000 samples) and record "
                        "lengths for identify")
    parser.add_argument("--loops", nargs="+", choices=("default", "fast"), default=["default", "fast"],
                        help="XLA's default loops, vojax.use_fast_cpu_loops() (a CPU setting: a "
                        "GPU ignores it, so there run `--loops default`)")
    parser.add_argument("--out", default=None)
    args = parser.parse_args(argv)
    if args.child:
        return child(*args.child)
    schedules = ("sequential", "associative", "chunked")
    device = f"{jax.default_backend()} ({jax.devices()[0].device_kind})"
    lines = [f"# bench_parallel_smoother: {device}, {os.cpu_count()} CPUs, JAX {jax.__version__}; "
             "every case in a fresh process; first: compile and run; warm: one more run",
             "| case | loops | schedule | first s | warm ms | warm ÷ sequential | "
             "first − sequential s | max difference |", "|---|---|---|---|---|---|---|---|"]
    for case in args.cases:
        for loops in args.loops:
            rows = {s: measure(case, s, loops) for s in schedules}
            base = rows["sequential"]
            for s, r in rows.items():
                if case == "alone":
                    diff = f"{r['err']:.1e} (relative)"
                else:
                    diff = f"{max(abs(a - b) for a, b in zip(r['alpha'], base['alpha'])):.1e} (order)"
                lines.append(
                    f"| {'filter + smoother alone, 1000 × 3' if case == 'alone' else 'identify, ' + case + ' samples'} "
                    f"| {loops} | {s} | {r['first']:.2f} | {1e3 * r['warm']:.2f} | "
                    f"{r['warm'] / base['warm']:.2f} | {r['first'] - base['first']:+.2f} | {diff} |")
    publish(lines, args.out)


if __name__ == "__main__":
    main()
