"""Progress bars on a terminal, stage timings always, and per-stage log lines with --verbose."""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager


class Progress:
    """Reports long stages. Bars only when ``bars`` and the stream is a terminal; with ``lines``
    as well, a stream that is not a terminal (a log file, a CI job) gets a line per tenth of
    each counted stage, with the time left.

    Parameters
    ----------
    bars : bool
        Show a bar per counted stage when the stream is a terminal.
    verbose : bool
        Print each stage's time when it ends.
    stream : file object, optional
        Where bars and lines go; standard error when None.
    lines : bool
        On a stream that is not a terminal, print a line per tenth of each counted stage.
    line_period_s : float
        The shortest time in seconds between two such lines.
    """

    def __init__(self, bars: bool = False, verbose: bool = False, stream=None, lines: bool = False,
                 line_period_s: float = 5.0):
        self.stream = stream or sys.stderr
        terminal = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.bars = bars and terminal
        self.lines = bars and lines and not terminal
        self.line_period_s = line_period_s
        self.verbose = verbose
        self.timings: dict[str, float] = {}

    @contextmanager
    def stage(self, name: str, total: int | None = None, unit: str = "it"):
        """Time a stage; yields ``update(n)`` to advance its bar.

        Parameters
        ----------
        name : str
            The stage's name, shown on its bar and in ``timings``.
        total : int, optional
            How many units the stage counts; None shows no bar.
        unit : str
            The unit's name on the bar.

        Yields
        ------
        callable
            ``update(n)``, which advances the bar by ``n`` units.
        """
        start = time.perf_counter()
        bar = None
        if self.bars:
            from tqdm import tqdm
            bar = tqdm(total=total, desc=name, unit=unit, file=self.stream, leave=False,
                       dynamic_ncols=True)
        elif self.lines and total:
            bar = LineBar(name, total, unit, self.stream, self.line_period_s)
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
        """Print ``text`` as a line of its own when verbose, without breaking a bar.

        Parameters
        ----------
        text : str
            The line, without its newline.
        """
        if self.verbose:
            print(f"[coverplan] {text}", file=self.stream)


class LineBar:
    """A progress bar as lines: one at each tenth of ``total`` (at most one per ``period_s``),
    with the count, the share and the time left at the rate so far, and one at the end.

    Parameters
    ----------
    name : str
        The stage's name, at the start of each line.
    total : float
        The count at which the stage is done.
    unit : str
        The unit's name.
    stream : file object
        Where the lines go.
    period_s : float
        The shortest time in seconds between two lines.
    """

    def __init__(self, name: str, total: float, unit: str, stream, period_s: float = 5.0):
        self.name, self.total, self.unit, self.stream, self.period_s = name, float(total), unit, stream, period_s
        self.done, self.start, self.last, self.shown = 0.0, time.perf_counter(), 0.0, 0

    def update(self, n: float = 1) -> None:
        """Advance the count, printing a line when it crosses the next tenth.

        Parameters
        ----------
        n : float
            Units done since the last call.
        """
        self.done += n
        tenth = int(10 * self.done / self.total) if self.total else 10
        now = time.perf_counter() - self.start
        if self.shown < tenth < 10 and now - self.last >= self.period_s:
            self.shown, self.last = tenth, now
            left = now * (self.total - self.done) / max(self.done, 1e-9)
            print(f"[coverplan] {self.name}: {self.done:,.0f}/{self.total:,.0f} {self.unit} "
                  f"({100 * self.done / self.total:.0f} %), {format_duration(left)} left",
                  file=self.stream, flush=True)

    def close(self) -> None:
        """Print the closing line with the stage's total time."""
        print(f"[coverplan] {self.name}: done in {format_duration(time.perf_counter() - self.start)}",
              file=self.stream, flush=True)


def format_duration(seconds: float) -> str:
    """Seconds as a person says them: "40 s", "3 min", "1 h 05 min".

    Parameters
    ----------
    seconds : float
        A duration.

    Returns
    -------
    str
        The duration rounded to seconds, minutes, or hours and minutes.
    """
    seconds = max(float(seconds), 0.0)
    if seconds < 90:
        return f"{seconds:.0f} s"
    minutes = seconds / 60.0
    if minutes < 90:
        return f"{minutes:.0f} min"
    return f"{int(minutes // 60)} h {int(minutes % 60):02d} min"


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
