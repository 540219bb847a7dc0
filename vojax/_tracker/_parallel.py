"""The Kalman filter and RTS smoother of `_kalman` as parallel prefix sums over the samples
(parallel in time): the same arguments and results, to rounding, in O(log N) or O(√N)
dependent steps instead of N.

Where every step of a loop is a kernel launch (a GPU) the sequential scans cost their N
launches however little each step computes; here each step is a batch of small matrix
operations over all the samples.

**The filter.** Sample k contributes an affine Gaussian map of the state before it: the law
of θ_k given θ_{k−1} and z_k, ``θ_k | θ_{k−1} ~ N(A θ_{k−1} + b, C)``, together with the
information that z_k carries about θ_{k−1}, ``exp(−½ θᵀ J θ + ηᵀ θ)``. Sample 0's element
holds the prior. Two elements compose into one of the same form and the composition is
associative, so the prefix of elements 0…k is the filtered law of θ_k. The measurement enters
in information form (precision ``mask/r`` along ``H_k``), with the Levenberg–Marquardt anchor
(precision μ on every component) as one more term of it, and no process variance is inverted
(the offset's is zero).

**The smoother.** Sample k's element is ``θ_k | θ_{k+1} ~ N(E θ_{k+1} + g, L)`` from the
filtered law; they compose from the end, the last element being the last filtered law.

The formulation follows Särkkä and García-Fernández, "Temporal parallelization of Bayesian
smoothers" (IEEE Transactions on Automatic Control, 2021).

**Schedules** of the prefix sums: ``"associative"`` (`lax.associative_scan`: about 2·log₂N
vectorised sweeps, no loop) and ``"chunked"`` (the samples cut into about √N chunks: one loop
of √N steps along all chunks at once, one over the chunks' totals, one vectorised step).
"""

import math

import jax
import jax.numpy as jnp
from jax import lax

from ._kalman import LOG_2PI, Filtered

SCHEDULES = ("associative", "chunked")


def _mm(a, b):
    return jnp.einsum("...ij,...jk->...ik", a, b)


def _mv(a, v):
    return jnp.einsum("...ij,...j->...i", a, v)


def _t(a):
    return jnp.swapaxes(a, -1, -2)


def _sym(a):
    return 0.5 * (a + _t(a))


def _diag(v):
    return v[..., :, None] * jnp.eye(v.shape[-1], dtype=v.dtype)


def _inv(a):
    """Inverses of a batch (..., d, d) of small matrices whose leading principal minors are
    nonzero (here ``I + C J`` with C and J positive semidefinite), by Gauss–Jordan elimination
    written out as elementwise operations, which XLA fuses (d is the few states here)."""
    d = a.shape[-1]
    m = [[a[..., i, j] for j in range(d)] for i in range(d)]
    one, zero = jnp.ones_like(m[0][0]), jnp.zeros_like(m[0][0])
    inv = [[one if i == j else zero for j in range(d)] for i in range(d)]
    for k in range(d):
        pivot = 1.0 / m[k][k]
        m[k] = [x * pivot for x in m[k]]
        inv[k] = [x * pivot for x in inv[k]]
        for i in range(d):
            if i != k:
                factor = m[i][k]
                m[i] = [x - factor * y for x, y in zip(m[i], m[k])]
                inv[i] = [x - factor * y for x, y in zip(inv[i], inv[k])]
    return jnp.stack([jnp.stack(row, -1) for row in inv], -2)


def chunked_scan(fn, elems, identity, reverse=False):
    """All prefix sums of `elems` (leaves with leading axis N) under the associative `fn`,
    as ``lax.associative_scan(fn, elems, reverse=reverse)`` gives them, in two short loops:
    the samples are cut into about √N chunks of about √N; one loop runs along the chunks, all
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


def _prefix(schedule, fn, elems, identity, reverse=False):
    if schedule == "associative":
        return lax.associative_scan(fn, elems, reverse=reverse)
    if schedule == "chunked":
        return chunked_scan(fn, elems, identity, reverse)
    raise ValueError(f"schedule must be one of {SCHEDULES}, not {schedule!r}.")


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


@jax.named_scope("vojax.parallel_filter")
def parallel_filter(h, z, r, q, m0, p0, mask=None, anchor=None, damping=None, f=None,
                    schedule="associative") -> Filtered:
    """`kalman_filter` as a prefix sum over the samples; the same arguments and result."""
    num, d = h.shape
    dtype = h.dtype
    if mask is None:
        mask = jnp.ones(z.shape, dtype)
    eye = jnp.eye(d, dtype=dtype)
    precision = mask / r
    lam = precision[:, None, None] * h[:, :, None] * h[:, None, :]
    iota = (precision * z)[:, None] * h
    if damping is not None:
        lam = lam + damping * eye
        iota = iota + damping * anchor
    fk = jnp.ones((num - 1, d), dtype) if f is None else f[:-1]
    qk = q[:-1]  # from sample k−1 to k, for k ≥ 1
    # elements k ≥ 1: θ_k | θ_{k−1} ~ N(F θ, Q), observed through (Λ_k, ι_k)
    lam1, iota1 = lam[1:], iota[1:]
    w = _inv(eye + qk[:, :, None] * lam1)  # (I + QΛ)⁻¹
    a = w * fk[:, None, :]
    b = _mv(w, qk * iota1)
    c = _sym(w * qk[:, None, :])
    e = fk * _mv(_t(w), iota1)  # (I + ΛQ)⁻¹ = wᵀ
    j = _sym(fk[:, :, None] * _mm(lam1, w) * fk[:, None, :])
    # element 0: the prior N(m0, P0), observed through (Λ_0, ι_0)
    w0 = _inv(eye + p0 @ lam[0])
    c0 = _sym(w0 @ p0)
    b0 = w0 @ (m0 + p0 @ iota[0])
    square, vector = jnp.zeros((1, d, d), dtype), jnp.zeros((1, d), dtype)
    elems = (
        jnp.concatenate([square, a]),
        jnp.concatenate([b0[None], b]),
        jnp.concatenate([c0[None], c]),
        jnp.concatenate([vector, e]),
        jnp.concatenate([square, j]),
    )
    zero = jnp.zeros((d, d), dtype)
    identity = (eye, jnp.zeros(d, dtype), zero, jnp.zeros(d, dtype), zero)
    _, mean, cov, _, _ = _prefix(schedule, _filter_combine, elems, identity)
    pred_mean = jnp.concatenate([m0[None], fk * mean[:-1]])
    pred_cov = jnp.concatenate(
        [p0[None], cov[:-1] * fk[:, :, None] * fk[:, None, :] + _diag(qk)]
    )
    s = jnp.sum(h * _mv(pred_cov, h), -1) + r
    innovation = z - jnp.sum(h * pred_mean, -1)
    ll = -0.5 * mask * (LOG_2PI + jnp.log(s) + innovation * innovation / s)
    return Filtered(mean, cov, pred_mean, pred_cov, innovation, s, jnp.sum(ll))


def _smoother_combine(later, earlier):
    # associative_scan(reverse=True) passes (the later element, the earlier one)
    e2, g2, l2 = later
    e1, g1, l1 = earlier
    return _mm(e1, e2), _mv(e1, g2) + g1, _sym(_mm(_mm(e1, l2), _t(e1)) + l1)


@jax.named_scope("vojax.parallel_smoother")
def parallel_smoother(filtered: Filtered, q, f=None, schedule="associative"):
    """`rts_smoother` as a suffix sum over the samples; the same arguments and result."""
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
    identity = (jnp.eye(d, dtype=m.dtype), jnp.zeros(d, m.dtype), jnp.zeros((d, d), m.dtype))
    _, ms, ps = _prefix(schedule, _smoother_combine, elems, identity, reverse=True)
    return ms, ps
