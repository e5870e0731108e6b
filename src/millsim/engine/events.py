"""The event table the compiled loop fills when a model stops a chunk (breakage decisions)."""

import numpy as np
from numba import njit


@njit(cache=True)
def room_for(rows, used, needed):
    """``rows`` with room for ``needed`` rows (doubled when it is too small; ``used`` kept)."""
    if needed <= rows.shape[0]:
        return rows
    grown = np.empty((2 * needed, rows.shape[1]))
    grown[:used] = rows[:used]
    return grown
