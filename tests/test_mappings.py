"""`spare_mappings`: a long process drops JAX's compiled programs before it exhausts the
memory mappings Linux allows it (XLA:CPU maps each program; past ``vm.max_map_count`` the
compiler aborts), and what ran before is compiled again where it has to be."""

import mmap
import sys
import threading
import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import vojax
from vojax import _xla
from vojax._tracker import _threads

pytestmark = pytest.mark.skipif(
    not sys.platform.startswith("linux"), reason="memory mappings are counted on Linux only"
)


def _probe():
    """A jitted function with one compiled program held in its cache."""
    f = jax.jit(lambda x: jnp.cumsum(x) * 2.0)
    f(jnp.ones(7))
    assert f._cache_size() == 1
    return f


def test_the_count_follows_the_mappings_the_process_makes():
    """Mappings made one by one, read and writable in turn (so that the kernel cannot merge
    neighbours): the count rises by as many, to within the few the interpreter makes."""
    before, limit = _xla._mapping_count_and_limit()
    with open("/proc/sys/vm/max_map_count") as f:
        assert limit == int(f.read())
    maps = [mmap.mmap(-1, mmap.PAGESIZE, prot=mmap.PROT_READ | (mmap.PROT_WRITE * (k % 2)))
            for k in range(400)]
    after, _ = _xla._mapping_count_and_limit()
    assert 390 <= after - before <= 420
    for m in maps:
        m.close()


def test_below_the_share_nothing_is_dropped():
    f, dropped = _probe(), _xla.programs_dropped()
    assert not _xla.spare_mappings(share=1.0, every_s=0)
    assert f._cache_size() == 1 and _xla.programs_dropped() == dropped


def test_past_the_share_the_programs_and_their_mappings_go():
    """Forty programs compiled, then dropped: their mappings are returned (each holds at
    least one), the counter says so, and a dropped function compiles again to the same
    value."""
    f, dropped = _probe(), _xla.programs_dropped()
    others = [jax.jit(lambda x, k=k: jnp.sin(x) + k) for k in range(40)]
    for k, g in enumerate(others):
        g(jnp.ones(k + 1))
    held, _ = _xla._mapping_count_and_limit()
    assert _xla.spare_mappings(share=0.0, every_s=0)
    left, _ = _xla._mapping_count_and_limit()
    assert held - left >= 40
    assert f._cache_size() == 0 and _xla.programs_dropped() == dropped + 1
    np.testing.assert_array_equal(np.asarray(f(jnp.ones(7))), 2.0 * np.arange(1, 8))


@pytest.mark.parametrize("call", ["identify", "refit"])
def test_identify_and_refit_spare_the_mappings_on_entry(call, monkeypatch):
    """With the share at 0 every entry drops the programs (`compare` goes through `refit`)."""
    monkeypatch.setattr(_xla, "MAPPINGS_SHARE", 0.0)
    monkeypatch.setattr(_xla, "CHECK_EVERY_S", 0.0)
    f, dropped = _probe(), _xla.programs_dropped()
    u = np.ones(60)
    y = np.asarray(vojax.fractional_integral(u, 0.4, dt=0.1))
    if call == "identify":
        vojax.identify(u, y, dt=0.1, method="gradient", warn=False)
    else:
        vojax.refit(u, y, dt=0.1)
    assert f._cache_size() == 0 and _xla.programs_dropped() > dropped


def test_the_entry_check_counts_at_most_once_per_interval(monkeypatch):
    """Within `every_s` of a count the check neither counts nor drops; past it, it counts
    again (and, past the share, drops)."""
    reads = []
    count = _xla._mapping_count_and_limit
    monkeypatch.setattr(_xla, "_mapping_count_and_limit", lambda: reads.append(1) or count())
    monkeypatch.setattr(_xla, "_counted_at", -np.inf)
    dropped = _xla.programs_dropped()
    assert _xla.spare_mappings(share=0.0, every_s=60.0) and len(reads) == 1
    f = _probe()
    assert not _xla.spare_mappings(share=0.0, every_s=60.0) and len(reads) == 1
    assert f._cache_size() == 1 and _xla.programs_dropped() == dropped + 1
    monkeypatch.setattr(_xla, "_counted_at", _xla._counted_at - 61.0)
    assert _xla.spare_mappings(share=0.0, every_s=60.0) and len(reads) == 2
    assert f._cache_size() == 0 and _xla.programs_dropped() == dropped + 2


@pytest.mark.parametrize("kwargs, words", [
    (dict(share=1.5), "`share` must be a number in [0, 1], got 1.5."),
    (dict(share=float("nan")), "`share` must be a number in [0, 1], got nan."),
    (dict(share=True), "`share` must be a number in [0, 1], got True."),
    (dict(every_s=-1.0), "`every_s` must be a number of seconds ≥ 0, got -1.0."),
    (dict(every_s="1"), "`every_s` must be a number of seconds ≥ 0, got '1'."),
])
def test_a_share_or_interval_out_of_range_is_refused_in_one_sentence(kwargs, words):
    with pytest.raises(ValueError) as raised:
        _xla.spare_mappings(**kwargs)
    assert str(raised.value) == words


@pytest.mark.skipif((__import__("os").cpu_count() or 1) < 2, reason="needs two cores")
def test_after_a_drop_the_tracker_runs_its_shares_one_after_another_again(monkeypatch):
    """`in_threads` runs a pass's shares in threads only once they have run for their shapes
    (two threads would compile the same program); a drop makes them cold again."""
    problem = types.SimpleNamespace(settings=types.SimpleNamespace(run_threads=2),
                                    schedule="sequential")
    fn = object()  # a key of its own

    def threads_used():
        seen = []
        _threads.in_threads(problem, fn, 2, lambda lo, hi: seen.append(threading.get_ident()),
                            ("shape",))
        return set(seen) - {threading.get_ident()}

    assert not threads_used()  # cold: in this thread
    assert threads_used()  # warm: in the pool's
    monkeypatch.setattr(_xla, "_dropped", _xla.programs_dropped() + 1)
    assert not threads_used()
    assert threads_used()


@pytest.mark.skipif((__import__("os").cpu_count() or 1) < 2, reason="needs two cores")
def test_a_thread_that_is_done_takes_the_next_run():
    """Warm, `in_threads` gives each run to the first free thread: while one thread is held
    by a long first run, the other runs every other one (equal shares gave runs 0–2 to the
    held thread); the outputs come back in the runs' order."""
    problem = types.SimpleNamespace(settings=types.SimpleNamespace(run_threads=2),
                                    schedule="sequential")
    fn, release = object(), threading.Event()  # a key of its own

    def call(lo, hi):
        if lo == 0:  # the long run: held until every other run is done
            release.wait(timeout=30)
        done.append(lo)
        if len(done) == 5:
            release.set()
        return lo, threading.get_ident()

    for _ in range(2):  # cold (in this thread), then warm (side by side)
        done = []
        release.clear()
        if not _:  # cold: the first run must not wait for the others
            release.set()
        out = _threads.in_threads(problem, fn, 6, call, ("shape",))
    assert [share for share, _ in out] == [(k, k + 1) for k in range(6)]
    assert [lo for _, (lo, _) in out] == list(range(6))
    assert done[-1] == 0  # the long run finished last: the others did not wait behind it
    held = out[0][1][1]
    assert {ident for _, (_, ident) in out[1:]} - {held}  # another thread ran the rest


def test_two_at_once_runs_the_second_beside_the_first_only_once_warm_and_where_allowed():
    """`two_at_once`: cold, one after the other in this thread; warm, the second in a thread
    of its own; the outputs in order; one thread where `run_threads` is 1, a parallel-in-time
    schedule runs on a CPU, or the machine has one core; no second: it is not called; cold,
    nor where the first gives None."""
    here = threading.get_ident()

    def run(settings, schedule="sequential", key=("k",), cores=2):
        seen = []
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(_threads.os, "cpu_count", lambda: cores)
            out = _threads.two_at_once(
                settings, schedule, key, lambda: seen.append(("a", threading.get_ident())) or 1,
                lambda: seen.append(("b", threading.get_ident())) or 2)
        assert out == (1, 2) and [name for name, _ in seen] in (["a", "b"], ["b", "a"])
        return dict(seen)["b"] != here

    two, one = types.SimpleNamespace(run_threads=2), types.SimpleNamespace(run_threads=1)
    key = (object(),)  # a key of its own
    assert not run(two, key=key)  # cold: in this thread
    assert run(two, key=key)  # warm: in a thread of its own
    assert not run(one, key=key)
    assert not run(two, key=key, cores=1)
    if jax.default_backend() == "cpu":
        other = (object(),)
        run(two, "associative", key=other)
        assert not run(two, "associative", key=other)
    assert _threads.two_at_once(two, "sequential", key, lambda: 1, None) == (1, None)
    # cold, a first that gives None (a fit given up): the second is not run
    called = []
    assert _threads.two_at_once(two, "sequential", (object(),), lambda: None,
                                lambda: called.append(1) or 2) == (None, None)
    assert called == []


def test_a_thread_runs_under_the_callers_float64_and_device_scopes():
    """`callers_scope`: a new thread does not inherit JAX's thread-local scopes; the function
    it runs sees the caller's float64 setting and default device (here float64 off and the
    CPU, against the process's float64 on and no default device)."""
    cpu = jax.devices("cpu")[0]

    def seen():
        return bool(jax.config.jax_enable_x64), jax.config.jax_default_device

    def in_a_thread(fn):
        out = []
        worker = threading.Thread(target=lambda: out.append(fn()))
        worker.start()
        worker.join()
        return out[0]

    with _xla.x64_scope(False), jax.default_device(cpu):
        assert seen() == (False, cpu)
        assert in_a_thread(seen) == (True, None)  # what a bare thread sees
        assert in_a_thread(_threads.callers_scope(seen)) == (False, cpu)
    assert in_a_thread(_threads.callers_scope(seen)) == (True, None)


def test_identify_under_a_float64_scope_runs_its_threads_in_float64(tmp_path):
    """In a process whose float64 is on only in a scope (``jax.enable_x64``), the second
    call (its smoothings side by side in threads) gives the first call's answer."""
    code = """
import jax, numpy as np
import vojax
from vojax import _xla
from vojax._tracker import _threads
_threads.os.cpu_count = lambda: 2
with _xla.x64_scope(True):
    n = 160
    t = np.linspace(0.0, 40.0, n)
    u = 1.0 + 0.5 * np.floor(4 * t / 40.0)
    x = np.asarray(vojax.simulate(u, np.full(n, 0.4), np.array([2.0]), t[1] - t[0]))
    y = x + 0.01 * np.std(x) * np.random.default_rng(1).standard_normal(n)
    a, b = (vojax.identify(u, y, t[1] - t[0], warn=False) for _ in range(2))
    assert np.asarray(b.alpha).dtype == np.float64
    assert np.array_equal(np.asarray(a.alpha_upper), np.asarray(b.alpha_upper))
print("ok", jax.config.jax_enable_x64)
"""
    import subprocess

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split()[-2:] == ["ok", "False"]
