"""A progress bar for long runs (the batch), drawn with tqdm on stderr.

``progress=None`` means automatic: a bar when stderr is a terminal, nothing in a log file or a
pipe. The time left is paced on the records after the first (`time_left`), which also compiles
the programs; tqdm's own estimate would count the compilation."""

from __future__ import annotations

import sys
import time


def wanted(progress) -> bool:
    """`progress` (True, False or None = on when stderr is a terminal) as a bool."""
    if progress is None:
        isatty = getattr(sys.stderr, "isatty", None)
        return bool(isatty and isatty())
    if not isinstance(progress, bool):
        raise TypeError(f"`progress` must be True, False or None, got {progress!r}.")
    return progress


def time_left(elapsed, first, done, total):
    """Seconds left in a batch, from the pace after its first record (`first`: seconds to the
    end of it), which also compiled the programs: timed from the start, the first estimate
    was 8 times too long. None until two records are done."""
    if done < 2 or total <= done:
        return None if done < 2 and total > done else 0.0
    return (elapsed - first) / (done - 1) * (total - done)


class Bar:
    """``vojax batch: 12/40 done |████      | 1 failed, 3 up to date; about 52 s left``.

    `update(failed=, skipped=)` after each record settles; `note(text)` replaces the counts
    for a while (a bucket that compiles). A disabled bar does nothing."""

    def __init__(self, total, enabled, desc="vojax batch"):
        self.total, self.desc, self.enabled = total, desc, enabled
        self.started = time.perf_counter()
        self.first = None
        self.failed = self.skipped = 0
        self._bar = None
        if enabled:
            from tqdm import tqdm

            self._bar = tqdm(
                total=total, desc=desc, file=sys.stderr, unit="record", dynamic_ncols=True,
                bar_format="{desc}: {n_fmt}/{total_fmt} done |{bar}| {postfix}", leave=True,
                mininterval=0.2,
            )
            self._bar.set_postfix_str(self._counts(), refresh=True)

    def _counts(self):
        now = time.perf_counter()
        n = self._bar.n if self._bar is not None else 0
        left = time_left(
            now - self.started, (self.first or now) - self.started, n, self.total
        )
        left = "estimating the time left" if left is None else f"about {left:.0f} s left"
        return f"{self.failed} failed, {self.skipped} up to date; {left}"

    def note(self, text):
        """Shows `text` in place of the counts until the next update."""
        if self._bar is not None:
            self._bar.set_postfix_str(text, refresh=True)

    def update(self, done=1, *, failed=None, skipped=None):
        """`done` more records settled; the running counts of failed and skipped ones."""
        if self._bar is None:
            return
        if failed is not None:
            self.failed = failed
        if skipped is not None:
            self.skipped = skipped
        self._bar.update(done)
        if self.first is None and self._bar.n >= 1:
            self.first = time.perf_counter()
        self._bar.set_postfix_str(self._counts(), refresh=True)

    def close(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False
