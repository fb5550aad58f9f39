"""Bars for work that reports no progress of its own (COLMAP's global mapper)."""

import threading
import time

import pytest

from coverplan.progress import clock_bar
from coverplan.sfm.colmap import GLOBAL_MAPPING_S_PER_PHOTO, global_mapping_seconds


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
