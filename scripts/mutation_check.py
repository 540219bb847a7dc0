"""Does the test suite catch small, plausible bugs? Each planted bug (`mutations_*.py`, by
area) is applied, one at a time, to a temporary copy of the repository; the tests that should
catch it are run there; the table says which bugs survived. Run it before closing an issue
that changes the law, the refit, the models, the tracker or the batch, and report the count.

    python scripts/mutation_check.py [--only NAME ...] [--list] [--workers N]

A mutation whose text is no longer found in the code is reported as STALE (update it with the
code). Exit status: the number of survivors (0 = every planted bug was caught).
"""

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))  # the planted bugs, by area

import mutations_data  # noqa: E402
import mutations_design  # noqa: E402
import mutations_figures  # noqa: E402
import mutations_kernels  # noqa: E402
import mutations_law  # noqa: E402
import mutations_reach  # noqa: E402
import mutations_refit  # noqa: E402
import mutations_scores  # noqa: E402
import mutations_tracker_band  # noqa: E402
import mutations_tracker_clock  # noqa: E402
import mutations_tracker_damping  # noqa: E402
import mutations_tracker_fit  # noqa: E402
import mutations_tracker_freedom  # noqa: E402
import mutations_tracker_noise  # noqa: E402

# name: (file, [(old, new), ...], tests that should fail)
AREAS = (mutations_law, mutations_design, mutations_refit, mutations_tracker_fit,
         mutations_tracker_damping, mutations_tracker_noise, mutations_tracker_band,
         mutations_tracker_clock, mutations_tracker_freedom, mutations_reach,
         mutations_data, mutations_figures, mutations_scores, mutations_kernels)
MUTATIONS = {name: bug for area in AREAS for name, bug in area.MUTATIONS.items()}
assert len(MUTATIONS) == sum(len(area.MUTATIONS) for area in AREAS), "a name planted twice"


def _copy(dst: Path):
    ignore = shutil.ignore_patterns(".venv", ".git", "__pycache__", "*.egg-info", ".pytest_cache")
    shutil.copytree(ROOT, dst, ignore=ignore, dirs_exist_ok=True)


def plant(text: str, edits):
    """`text` with a planted bug's `edits` (old, new) applied in order, and the old texts not
    found exactly once in `text` (a stale entry: it plants nothing)."""
    stale = [old for old, _ in edits if text.count(old) != 1]
    for old, new in edits:
        text = text.replace(old, new)
    return text, stale


def _run_one(tmp: Path, index: int, name: str, path: str, edits, tests, timeout: int):
    """Plants one bug in a fresh copy of the repository and runs its tests: (status, s)."""
    work = tmp / f"repo{index}"
    _copy(work)
    try:
        target = work / path
        text, stale = plant(target.read_text(), edits)
        if stale:
            print(f"STALE     {name}: {stale[0][:60]!r} not found exactly once", flush=True)
            return "STALE", 0.0
        target.write_text(text)
        # the copy's package must be the one imported (cwd first on sys.path)
        env = dict(os.environ, PYTHONPATH=str(work))
        env.pop("XLA_FLAGS", None)
        started = time.perf_counter()
        try:
            proc = subprocess.run(
                [sys.executable, "-m", "pytest", "-q", "-x", "-n", "0", "-p", "no:cacheprovider",
                 "-m", "slow or not slow", *tests],  # both tiers
                cwd=work, env=env, capture_output=True, text=True, timeout=timeout,
            )
            status = "caught" if proc.returncode != 0 else "SURVIVED"
        except subprocess.TimeoutExpired:
            status = "timeout"
        took = time.perf_counter() - started
        print(f"{status:9s} {name} ({took:.0f} s)", flush=True)
        return status, took
    finally:
        shutil.rmtree(work, ignore_errors=True)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--only", nargs="*")
    parser.add_argument("--list", action="store_true")
    parser.add_argument("--timeout", type=int, default=900)
    parser.add_argument("--workers", type=int, default=1,
                        help="planted bugs tested at once, each in its own copy and one "
                        "process (the tests of one bug are too few to gain from pytest-xdist)")
    args = parser.parse_args()
    chosen = {k: v for k, v in MUTATIONS.items() if not args.only or k in args.only}
    if args.list:
        print("\n".join(chosen))
        return 0
    from concurrent.futures import ThreadPoolExecutor

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # the recorded inputs, where tests look for them (../shared), or the checkout's copy
        for shared in (ROOT.parent / "shared", ROOT / "shared"):
            if (shared / "data").is_dir():
                (tmp / "shared").symlink_to(shared)
                break
        with ThreadPoolExecutor(max(args.workers, 1)) as pool:
            futures = [pool.submit(_run_one, tmp, i, name, *entry, args.timeout)
                       for i, (name, entry) in enumerate(chosen.items())]
            rows = [(name, *f.result()) for name, f in zip(chosen, futures)]
    survived = [r for r in rows if r[1] in ("SURVIVED", "STALE")]
    print(f"\n{len(rows) - len(survived)} of {len(rows)} planted bugs caught")
    print("| planted bug | result | s |\n|---|---|---|")
    for name, status, took in rows:
        print(f"| {name} | {status} | {took:.0f} |")
    return len(survived)


if __name__ == "__main__":
    sys.exit(main())
