"""Distance of computed points to a curve given as a polyline: the curve error of the
accuracy knob, the benchmark and the paper's checks (docs/numerics.md, "The accuracy knob")."""
from __future__ import annotations

import numpy as np


def polyline_distances(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Euclidean distance of each point to the polyline through ``line``'s vertices.

    Parameters
    ----------
    points : ndarray, shape (m, 2)
    line : ndarray, shape (k, 2), k >= 2
        Vertices in order; the distance is to the nearest of its k - 1 segments.

    Returns
    -------
    ndarray, shape (m,)
    """
    start, seg = line[:-1], line[1:] - line[:-1]
    length2 = np.maximum((seg**2).sum(1), 1e-300)
    out = np.empty(len(points))
    done = 0
    for chunk in np.array_split(points, max(1, len(points) // 256)):
        rel = chunk[:, None, :] - start[None, :, :]
        s = np.clip((rel * seg[None]).sum(2) / length2[None], 0.0, 1.0)
        out[done:done + len(chunk)] = np.sqrt(((rel - s[..., None] * seg[None]) ** 2)
                                              .sum(2)).min(1)
        done += len(chunk)
    return out


def load_area_distances(abar, lbar, reference_abar, reference_lbar) -> np.ndarray:
    """Distance of the points (abar, Lbar) to a reference's attached load-area curve.

    The reference curve is its polyline from the start to its pull-off (its most tensile
    load), points without contact (abar = 0: the contact can vanish before the pull-off on
    fast retractions) included, so a point near the curve's end is measured against the
    end; after the pull-off the contact jumps off and nothing is compared. Both coordinates
    are divided by the reference's abar at t = 0 and its |Lbar| at pull-off
    (dimensionless).

    Parameters
    ----------
    abar, lbar : ndarray, shape (m,)
        The points' contact half-widths and loads (the paper's scaled abar_c and Lbar).
    reference_abar, reference_lbar : ndarray, shape (k,)
        The reference's series, from t = 0.

    Returns
    -------
    ndarray, shape (m,)
        NaN when the reference has fewer than two points up to its pull-off.
    """
    end = int(np.argmin(reference_lbar)) + 1
    a_scale, l_scale = reference_abar[0], abs(reference_lbar[end - 1])
    line = np.stack([reference_abar[:end] / a_scale, reference_lbar[:end] / l_scale], 1)
    points = np.stack([np.asarray(abar) / a_scale, np.asarray(lbar) / l_scale], 1)
    if len(line) < 2 or not len(points):
        return np.full(len(points), np.nan)
    return polyline_distances(points, line)
