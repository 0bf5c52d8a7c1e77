"""Compiled passes of the transforms over their spectra (numba, cached per machine).

:func:`scale` multiplies a spectrum by a real multiplier in place (numpy's complex-times-real
goes through a temporary and takes about twice as long). The others are the two-rank
transform's passes over the odd modes (:mod:`hpcgfmd.parallel.fft_halved`, whose docstring
has the algebra): L = n/4, t_k = w^(2k+1) and twist[m] = w^(2m), w = exp(-2 pi i / n).
Each pass over the odd modes takes the modes k and L-1-k together, which their symmetry
couples.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def scale(spectrum, diagonal):
    """spectrum *= diagonal (real), in place."""
    f = spectrum.view(np.float64)
    for k in range(diagonal.shape[0]):
        f[2 * k] *= diagonal[k]
        f[2 * k + 1] *= diagonal[k]


@njit(cache=True)
def twist_difference(a, b, twist, v):
    """v[m] = (d[2m] + i d[2m+1]) twist[m], d = a - b."""
    for m in range(v.shape[0]):
        re = a[2 * m] - b[2 * m]
        im = a[2 * m + 1] - b[2 * m + 1]
        c, s = twist[m].real, twist[m].imag
        v[m] = complex(re * c - im * s, re * s + im * c)


@njit(cache=True)
def combine(p, v, twist, sign, out):
    """out[2m] + i out[2m+1] = p[2m] + i p[2m+1] + sign v[m] conj(twist[m]) (sign +-1)."""
    for m in range(v.shape[0]):
        c, s = twist[m].real, twist[m].imag
        re, im = v[m].real, v[m].imag
        out[2 * m] = p[2 * m] + sign * (re * c + im * s)
        out[2 * m + 1] = p[2 * m + 1] + sign * (im * c - re * s)


@njit(cache=True)
def odd_modes(v, odd):
    """In place: V = fft_L(v) -> the odd modes X[2k+1] (module docstring).

    For the pair k, j = L-1-k: with c = conj V_j, P = (V_k + c) / 2 and
    Q = -i t_k (V_k - c) / 2, X[2k+1] = P + Q and conj X[2j+1] = P - Q.
    """
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        pr, pi, qr, qi = _odd_pair(
            f[2 * k], f[2 * k + 1], f[2 * j], f[2 * j + 1], t[2 * k], t[2 * k + 1]
        )
        f[2 * j], f[2 * j + 1] = pr - qr, qi - pi
        f[2 * k], f[2 * k + 1] = pr + qr, pi + qi


@njit(cache=True)
def odd_modes_backward(v, odd):
    """In place: the odd modes Y[2k+1] -> W, whose ifft_L untwisted is q.

    For the pair k, j = L-1-k: with S = Y_k + conj Y_j and Z = i conj(t_k) (Y_k - conj Y_j),
    W_k = S + Z and W_j = conj(S - Z).
    """
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        wkr, wki, wjr, wji = _back_pair(
            f[2 * k], f[2 * k + 1], f[2 * j], -f[2 * j + 1], t[2 * k], t[2 * k + 1]
        )
        f[2 * j], f[2 * j + 1] = wjr, wji
        f[2 * k], f[2 * k + 1] = wkr, wki


@njit(cache=True)
def odd_modes_multiplied(v, odd, diagonal):
    """In place, fused: V -> X[2k+1] -> Y = diagonal X -> W (one pass for apply_diagonal)."""
    f, t = v.view(np.float64), odd.view(np.float64)
    count = v.shape[0]
    for k in range((count + 1) // 2):
        j = count - 1 - k
        tr, ti = t[2 * k], t[2 * k + 1]
        pr, pi, qr, qi = _odd_pair(f[2 * k], f[2 * k + 1], f[2 * j], f[2 * j + 1], tr, ti)
        dk, dj = diagonal[k], diagonal[j]
        wkr, wki, wjr, wji = _back_pair(
            dk * (pr + qr), dk * (pi + qi), dj * (pr - qr), dj * (pi - qi), tr, ti
        )
        f[2 * j], f[2 * j + 1] = wjr, wji
        f[2 * k], f[2 * k + 1] = wkr, wki


@njit(cache=True, inline="always")
def _odd_pair(vkr, vki, vjr, vji, tr, ti):
    """P and Q of :func:`odd_modes` as (Re P, Im P, Re Q, Im Q)."""
    er, ei = vkr - vjr, vki + vji  # V_k - conj V_j
    return (
        0.5 * (vkr + vjr),
        0.5 * (vki - vji),
        0.5 * (er * ti + ei * tr),
        -0.5 * (er * tr - ei * ti),
    )


@njit(cache=True, inline="always")
def _back_pair(ykr, yki, ycr, yci, tr, ti):
    """W_k and W_j of :func:`odd_modes_backward` from Y_k and conj Y_j = (ycr, yci)."""
    sr, si = ykr + ycr, yki + yci
    fr, fi = ykr - ycr, yki - yci
    zr, zi = -(fi * tr - fr * ti), fr * tr + fi * ti  # i conj(t) (Y_k - conj Y_j)
    return sr + zr, si + zi, sr - zr, zi - si


def compile_all():
    """Compile these passes into numba's cache (scripts/setup.sh, via
    :func:`hpcgfmd.solvers.kernels.compile_all`)."""
    a, b = np.linspace(-1.0, 1.0, 8), np.linspace(0.0, 1.0, 8)
    twist = np.exp(-1j * np.linspace(0.0, 1.0, 4))
    v = np.zeros(4, dtype=np.complex128)
    twist_difference(a, b, twist, v)
    odd_modes(v, twist)
    odd_modes_backward(v, twist)
    odd_modes_multiplied(v, twist, np.ones(4))
    combine(a, v, twist, 1.0, b)
    scale(v, np.ones(4))
