"""Progress bars on a terminal, stage timings always, and per-stage log lines with --verbose."""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager


class Progress:
    """Reports long stages. Bars only when ``bars`` and the stream is a terminal."""

    def __init__(self, bars: bool = False, verbose: bool = False, stream=None):
        self.stream = stream or sys.stderr
        self.bars = bars and hasattr(self.stream, "isatty") and self.stream.isatty()
        self.verbose = verbose
        self.timings: dict[str, float] = {}

    @contextmanager
    def stage(self, name: str, total: int | None = None, unit: str = "it"):
        """Time a stage; yields ``update(n)`` to advance its bar."""
        start = time.perf_counter()
        bar = None
        if self.bars:
            from tqdm import tqdm
            bar = tqdm(total=total, desc=name, unit=unit, file=self.stream, leave=False,
                       dynamic_ncols=True)
        try:
            yield (bar.update if bar is not None else _ignore)
        finally:
            if bar is not None:
                bar.close()
            elapsed = time.perf_counter() - start
            self.timings[name] = self.timings.get(name, 0.0) + elapsed
            if self.verbose:
                print(f"[coverplan] {name}: {elapsed:.2f} s", file=self.stream)

    def note(self, text: str) -> None:
        if self.verbose:
            print(f"[coverplan] {text}", file=self.stream)


def _ignore(_n: int = 1) -> None:
    return None


@contextmanager
def clock_bar(update, total_s: int, period_s: float = 1.0):
    """Advance a bar of ``total_s`` seconds by the clock while the block runs, for work that
    reports no progress of its own but whose duration can be estimated. The bar stops one
    short of its total if the work runs over, and fills up when the block ends.

    Parameters
    ----------
    update : callable
        A stage's ``update(n)``.
    total_s : int
        The estimated duration in seconds: the bar's total.
    period_s : float
        Seconds between updates.
    """
    total_s = max(int(total_s), 1)
    done = [0]
    stop = threading.Event()

    def run():
        while not stop.wait(period_s):
            if done[0] < total_s - 1:
                done[0] += 1
                update(1)

    ticker = threading.Thread(target=run, daemon=True)
    ticker.start()
    try:
        yield
    finally:
        stop.set()
        ticker.join()
        update(total_s - done[0])
