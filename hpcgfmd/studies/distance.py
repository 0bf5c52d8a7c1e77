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
