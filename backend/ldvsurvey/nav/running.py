"""Running filters along a sampled signal: a centred running mean, a running median's test
against a limit, and "true for the next n samples".

They replace scipy.ndimage's ``uniform_filter1d``, ``median_filter`` and ``minimum_filter1d`` (mode
"nearest" and the windows the still detection uses): importing scipy.ndimage costs a fresh process
about 0.16 s of CPU, a tenth of a short ``ldv-survey run navigate``
(``tests/pipelines/test_running_filters.py`` checks them against scipy.ndimage: the same numbers bit
for bit, the same booleans).
"""

from __future__ import annotations

import numpy as np


def _padded(x, w: int):
    """``x`` along axis 0 extended by its edge values (scipy's mode "nearest") for a window of ``w``."""
    a, b = w // 2, w - w // 2 - 1
    return np.concatenate([np.repeat(x[:1], a, axis=0), x, np.repeat(x[-1:], b, axis=0)])


def running_mean(x, w: int) -> np.ndarray:
    """Centred running mean over ``w`` samples along axis 0, edges held (float64): the arithmetic of
    ``scipy.ndimage.uniform_filter1d(x, w, axis=0, mode="nearest")``: a running sum (the first
    window summed in order, then each step adding entering − leaving) divided by ``w``."""
    x = np.asarray(x, float)
    p = _padded(x, w)
    steps = np.empty_like(x)
    steps[0] = np.add.accumulate(p[:w], axis=0)[-1]
    steps[1:] = p[w : w + len(x) - 1] - p[: len(x) - 1]
    return np.add.accumulate(steps, axis=0) / w


def running_median_within(x, w: int, limit: float) -> np.ndarray:
    """|median of the ``w`` samples around each one| < ``limit``, edges held: the booleans of
    ``abs(scipy.ndimage.median_filter(x, w, mode="nearest")) < limit`` (the median of an even
    window is its upper middle value), from counts of the window's samples. A NaN has no place in
    an order: with one in ``x`` scipy's filter is used, so its answer stays what it was."""
    x = np.asarray(x, float)
    if np.isnan(x).any():
        from scipy.ndimage import median_filter

        return np.abs(median_filter(x, size=w, mode="nearest")) < limit
    p = _padded(x, w)
    r = w // 2  # the rank of the median in the sorted window

    def counts(flags):
        c = np.concatenate([[0], np.cumsum(flags, dtype=np.int64)])
        return c[w:] - c[:-w]

    # the r-th smallest is < limit when more than r samples are; it is > −limit when at most r are ≤ −limit
    return (counts(p < limit) > r) & (counts(p <= -limit) <= r)


def all_ahead(flags, n: int) -> np.ndarray:
    """``flags[i:i + n]`` all true (false where the window runs past the end): the booleans of
    ``scipy.ndimage.minimum_filter1d(flags, n, mode="constant", cval=0, origin=-(n // 2)) > 0``."""
    f = np.asarray(flags, bool)
    c = np.concatenate([[0], np.cumsum(f, dtype=np.int64), np.full(n - 1, f.sum(), np.int64)])
    return c[n : len(f) + n] - c[: len(f)] == n
