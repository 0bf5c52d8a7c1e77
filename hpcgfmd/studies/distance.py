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
        out[done : done + len(chunk)] = np.sqrt(((rel - s[..., None] * seg[None]) ** 2).sum(2)).min(
            1
        )
        done += len(chunk)
    return out


def load_area_distances(abar, lbar, reference_abar, reference_lbar) -> np.ndarray:
    """Distance of the points (abar, Lbar) to a reference's attached load-area curve.

    The reference curve is its polyline from the start to its pull-off (its most tensile
    load), points without contact (abar = 0: the contact can vanish before the pull-off on
    fast retractions) included, and on along its attached branch past the pull-off while
    it keeps a contact (abar > 0): under displacement control the load rises again while
    the contact shrinks, until the contact jumps off. The pull-off is the flat minimum of
    the load along that branch, where a load error of e moves the pull-off's contact width
    by about sqrt(e): a run whose pull-off sample comes a little later on the same branch
    is measured against the branch, not against its cut end. Both coordinates are divided
    by the reference's abar at t = 0 and its |Lbar| at pull-off (dimensionless).

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
    pull_off, end = _attached_branch(reference_lbar, reference_abar)
    a_scale, l_scale = reference_abar[0], abs(reference_lbar[pull_off])
    line = np.stack([reference_abar[:end] / a_scale, reference_lbar[:end] / l_scale], 1)
    points = np.stack([np.asarray(abar) / a_scale, np.asarray(lbar) / l_scale], 1)
    if len(line) < 2 or not len(points):
        return np.full(len(points), np.nan)
    return polyline_distances(points, line)


def _attached_branch(reference_lbar, reference_abar):
    """The reference's pull-off index and the end (exclusive) of its polyline: the pull-off
    and on along its attached branch while it keeps a contact (abar > 0)."""
    pull_off = int(np.argmin(reference_lbar))
    end = pull_off + 1
    while end < len(reference_abar) and reference_abar[end] > 0.0:
        end += 1
    return pull_off, end


def load_depth_distances(dbar, lbar, reference_dbar, reference_lbar, reference_abar):
    """Distance of the points (Dbar, Pbar) to a reference's attached load-depth curve: a
    sphere's curve error, both exact observables (the indenter's depth and the force; its
    contact radius is a node count's, a staircase on the lattice).

    The reference curve is its polyline from the start to its pull-off and on along its
    attached branch (reference_abar > 0), as in :func:`load_area_distances`. Both
    coordinates are divided by the reference's: its largest |Dbar| on that polyline (its
    preload's depth, or its least, where the contact jumps off) and its |Pbar| at pull-off.

    Parameters
    ----------
    dbar, lbar : ndarray, shape (m,)
        The points' depths (delta / delta_s) and forces (Pbar, docs/model.md (M47)).
    reference_dbar, reference_lbar, reference_abar : ndarray, shape (k,)
        The reference's depths, forces and contact radii, from t = 0 (or its widest
        contact).

    Returns
    -------
    ndarray, shape (m,)
        NaN when the reference has fewer than two points up to its pull-off.
    """
    pull_off, end = _attached_branch(reference_lbar, reference_abar)
    d_scale = np.abs(reference_dbar[:end]).max()
    l_scale = abs(reference_lbar[pull_off])
    line = np.stack([reference_dbar[:end] / d_scale, reference_lbar[:end] / l_scale], 1)
    points = np.stack([np.asarray(dbar) / d_scale, np.asarray(lbar) / l_scale], 1)
    if len(line) < 2 or not len(points):
        return np.full(len(points), np.nan)
    return polyline_distances(points, line)
