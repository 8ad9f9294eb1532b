"""Wall-clock timing of a call: repeated until enough time has passed, reported as quantiles."""
from __future__ import annotations

import gc
import time
from typing import Callable

import numpy as np


def time_calls(call: Callable[[], object], min_repeats: int = 5, max_repeats: int = 200,
               min_seconds: float = 0.3) -> np.ndarray:
    """Seconds per call (R,), R between min_repeats and max_repeats, at least min_seconds in
    all; one untimed warm-up call first, garbage collection off while timing."""
    call()
    times = []
    enabled = gc.isenabled()
    gc.disable()
    try:
        started = time.perf_counter()
        while len(times) < max_repeats and (len(times) < min_repeats
                                            or time.perf_counter() - started < min_seconds):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
    finally:
        if enabled:
            gc.enable()
    return np.array(times)


def median_p95_ms(times: np.ndarray) -> tuple[float, float]:
    """(median, 95th percentile) in milliseconds."""
    return float(np.median(times) * 1e3), float(np.percentile(times, 95) * 1e3)
