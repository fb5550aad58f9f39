"""Bars for work that reports no progress of its own (COLMAP's global mapper)."""

import threading
import time

import pytest

from coverplan.progress import clock_bar
from coverplan.sfm.mapping import GLOBAL_MAPPING_S_PER_PHOTO, global_mapping_seconds


class Bar:
    def __init__(self):
        self.n = 0
        self.lock = threading.Lock()

    def update(self, k=1):
        with self.lock:
            self.n += k


@pytest.mark.parametrize("work_s", [0.0, 0.3])
def test_clock_bar_ends_full_and_never_runs_past_its_total(work_s):
    bar = Bar()
    total = 5
    with clock_bar(bar.update, total, period_s=0.01):
        time.sleep(work_s)
        # Running over the estimate (0.3 s is 30 periods) leaves the bar one short of full.
        assert bar.n <= total - 1
    assert bar.n == total


def test_clock_bar_fills_and_stops_when_the_work_fails():
    bar = Bar()
    with pytest.raises(RuntimeError):
        with clock_bar(bar.update, 40, period_s=0.01):
            raise RuntimeError("mapper failed")
    done = bar.n
    time.sleep(0.05)
    assert done == bar.n == 40  # the ticker thread has stopped


def test_global_mapping_estimate_grows_with_photos_and_shrinks_with_threads():
    assert global_mapping_seconds(1053, threads=2) == round(GLOBAL_MAPPING_S_PER_PHOTO * 1053)
    assert global_mapping_seconds(2000, threads=2) > global_mapping_seconds(1000, threads=2)
    assert global_mapping_seconds(1000, threads=8) < global_mapping_seconds(1000, threads=2)
    assert global_mapping_seconds(1, threads=64) >= 1


def test_line_progress_when_the_stream_is_not_a_terminal():
    """A log file gets a line per tenth of a counted stage (count, share, time left) and one at
    the end; a terminal-less run without ``lines`` and a quiet one get none."""
    import io
    import re

    from coverplan.progress import Progress

    stream = io.StringIO()
    progress = Progress(bars=True, lines=True, stream=stream, line_period_s=0.0)
    with progress.stage("SfM features", total=40, unit="photos") as update:
        for _ in range(40):
            update(1)
            for line in stream.getvalue().splitlines():
                assert "left" in line or "done in" in line
    lines = stream.getvalue().splitlines()
    counted = [line for line in lines if "left" in line]
    assert lines[-1].startswith("[coverplan] SfM features: done in")
    assert 1 <= len(counted) <= 9
    shares = [int(re.search(r"\((\d+) %\)", line).group(1)) for line in counted]
    assert shares == sorted(shares) and all(0 < s < 100 for s in shares)
    for quiet in (Progress(bars=True, stream=io.StringIO()), Progress(bars=False, lines=True, stream=io.StringIO())):
        with quiet.stage("x", total=10) as update:
            update(10)
        assert quiet.stream.getvalue() == ""


def test_the_simulate_estimate_scales_as_its_stages_do():
    from coverplan.sfm.estimate import simulate_seconds

    def est(**kw):
        base = dict(photos=52, draws=1, width=640, max_features=4096, neighbours=20, threads=2)
        return simulate_seconds(**{**base, **kw})

    assert est(draws=3) == pytest.approx(3 * est())
    assert est(width=1280) > 2.0 * est()
    assert est(threads=4) < est()
    assert est(photos=500) > 8 * est()
