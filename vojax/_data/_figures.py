"""The record figures, drawn in worker processes while the batch computes."""


import collections
import concurrent.futures
import os
import time

from .._plotting_record import warm_record_figure
from ._pipeline import (
    finish_outputs,
)

MIN_RECORDS_FOR_WORKERS = 4  # fewer records are drawn here: a worker takes ~2 s to start


class _Figures:
    """Each record's figure, then its ``summary.json`` (`finish_outputs`), written by worker
    processes while this process computes the next records, and by this process as well once
    it has none left (`drain`). Workers are started by spawn (forking a process that runs JAX's
    threads is unsafe) with `workers` processes (None: the cores but one, at least one, at most
    four; 0, or fewer than `MIN_RECORDS_FOR_WORKERS` records: none, all drawn here); each
    builds its figure at once, while the batch compiles. At most two records per worker are
    handed over at a time, so that the rest can still be drawn here."""

    def __init__(self, workers, count):
        import os

        if workers is None:
            workers = max(1, min(4, (os.cpu_count() or 2) - 1))
        if workers < 0:
            raise ValueError(f"`figure_workers` must be ≥ 0, got {workers}.")
        self.pool = None
        self.waiting = collections.deque()  # (key, arguments) not handed over yet
        self.running = []  # (key, future)
        self.ready = []  # (key, error or None)
        if workers and count >= MIN_RECORDS_FOR_WORKERS:
            import concurrent.futures
            import multiprocessing

            self.pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                initializer=_figure_worker_init, initargs=(os.getpid(),),
            )
            self.limit = 2 * workers
            for _ in range(workers):
                self.running.append((None, self.pool.submit(warm_record_figure), None))

    def add(self, key, *arguments):
        """Queues `finish_outputs(*arguments)` for the record `key`."""
        if self.pool is None:
            self._here(key, arguments)
        else:
            self.waiting.append((key, arguments))
            self._hand_over()

    def _here(self, key, arguments):
        try:
            finish_outputs(*arguments)
        except Exception as e:  # noqa: BLE001
            self.ready.append((key, e))
        else:
            self.ready.append((key, None))

    def _hand_over(self):
        self._poll()
        while self.pool is not None and self.waiting and len(self.running) < self.limit:
            key, arguments = self.waiting.popleft()
            try:
                future = self.pool.submit(finish_outputs, *arguments)
            except concurrent.futures.BrokenExecutor:  # a worker died: draw here from now on
                self.waiting.appendleft((key, arguments))
                self._lost()
                return
            self.running.append((key, future, arguments))

    def _poll(self, wait=False):
        for item in list(self.running):
            key, future, arguments = item
            if wait or future.done():
                self.running.remove(item)
                try:
                    future.result()
                except concurrent.futures.BrokenExecutor:
                    # a worker was killed (out of memory, a signal): the record loses nothing,
                    # its figure and summary are drawn here
                    if key is not None:
                        self.waiting.append((key, arguments))
                    self._lost()
                    return
                except Exception as e:  # noqa: BLE001 - a bad figure fails its record only
                    if key is not None:  # a failed warm-up only costs time
                        self.ready.append((key, e))
                else:
                    if key is not None:
                        self.ready.append((key, None))

    def _lost(self):
        """The pool is broken: every record it held goes back to the queue, drawn here."""
        if self.pool is None:
            return
        for key, _, arguments in self.running:
            if key is not None:
                self.waiting.append((key, arguments))
        self.running = []
        self.pool.shutdown(wait=False, cancel_futures=True)
        self.pool = None

    def collect(self):
        """``(key, error or None)`` of the records finished since the last call."""
        if self.pool is not None:
            self._hand_over()
        ready, self.ready = self.ready, []
        return ready

    def drain(self):
        """Draws the records not handed over here, alongside the workers, yielding after each
        (for `collect`); returns when all are written (a worker lost on the way: its records
        are drawn here too)."""
        while self.waiting or self.running:
            if self.waiting:
                self._here(*self.waiting.popleft())
                self._hand_over()
            elif self.pool is not None:
                self._poll(wait=True)
            yield

    def close(self):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)


def _figure_worker_init(parent):
    """A figure worker: Ctrl-C is its parent's to handle (the terminal sends it to the whole
    group; the parent stops the pool), and it exits as soon as its parent is gone, however
    the parent ended (SIGKILL included), so that nothing keeps running or holds the
    terminal's output. Linux asks the kernel for a signal at the parent's death; elsewhere a
    thread watches the parent's id."""
    import signal
    import threading

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass

    def watch():
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(0)

    if os.getppid() != parent:  # the parent died before the request took effect
        os._exit(0)
    threading.Thread(target=watch, daemon=True).start()
