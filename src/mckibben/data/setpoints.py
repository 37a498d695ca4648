"""Set points behind measured values: loads or pressures grouped into the levels a rig was set to.

Used where a table is checked (:mod:`mckibben.data.tables`), tared
(:mod:`mckibben.data.preprocessing`) and fitted (:mod:`mckibben.fit`).
"""

from __future__ import annotations

import numpy as np


#: Measured (continuous) set points: values are split into groups where the gap between sorted
#: neighbours exceeds this fraction of their range (a set weight read by a load cell scatters by
#: far less; a sweep of truly continuous values leaves no such gap and stays one group). [-]
GROUP_GAP = 0.05


def set_point_groups(values, decimals=9):
    """Group label per value and the groups' centres: the set points behind measured values.

    Set weights (or pressures) typed in exactly group by value, as the paper's tables do. Values
    read by an instrument (a load cell's force, a transducer's pressure) scatter around the set
    point: when there are more distinct values than a third of the points, they are grouped by
    gaps wider than :data:`GROUP_GAP` of their range.

    Parameters
    ----------
    values : array_like
        Loads [N] or pressures [Pa].
    decimals : int, default 9
        Rounding before exact grouping. [-]

    Returns
    -------
    labels : numpy.ndarray
        Group index per value. [-]
    centres : numpy.ndarray
        Mean of each group, sorted. [SI]
    """
    v = np.round(np.asarray(values, dtype=float), decimals)
    uniq = np.unique(v)
    if uniq.size <= max(v.size // 3, 1):
        labels = np.searchsorted(uniq, v)
        return labels, uniq
    order = np.sort(uniq)
    cuts = order[1:][np.diff(order) > GROUP_GAP * max(float(np.ptp(order)), 1e-300)]
    labels = np.searchsorted(cuts, v, side="right")
    centres = np.array([float(np.mean(v[labels == k])) for k in range(cuts.size + 1)])
    return labels, centres
