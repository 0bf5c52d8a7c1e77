"""Extremes of float64 blocks as integer extremes of their bits, which LLVM vectorises.

A compiled loop's running ``max``/``min`` of doubles is not vectorised by LLVM unless NaN may
be assumed away (a function attribute numba does not set), so such a loop waits a
compare-and-select per node. The bits b of a double, read as a signed 64-bit integer and
mapped to k(b) = b xor ((b >> 63) and 0x7fff...f), are ordered as the doubles are: for b >= 0
(sign bit clear) k = b grows with the value; for a negative double the sign bit stays set
and the flipped magnitude bits make k fall as |x| grows (-0.0 maps just below +0.0). The map
is its own inverse, and integer extremes vectorise (eight nodes per instruction with
AVX-512: about 20 us instead of 65 for two 2^17 blocks). NaN (magnitude bits above those of
infinity) is replaced by the neutral key, so NaN entries are passed over, as by a running
``max``/``min`` from a number. The extreme of a set does not depend on the order, so the
result is the value a running extreme gives (bitwise, up to the sign of a zero).

Loops index slices from 0: numba's test for negative indices, which an index that may be
negative needs, keeps a loop over ``range(lo, hi)`` from vectorising.
"""

from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

MAGNITUDE = 0x7FFFFFFFFFFFFFFF  # all bits but the sign
INF_BITS = 0x7FF0000000000000  # the magnitude bits of infinity; above them: NaN
KEY_INF = INF_BITS  # the key of +inf
KEY_NEG_INF = -0x7FF0000000000001  # the key of -inf


@intrinsic
def bits(typingctx, x):
    """The bits of the float64 ``x`` as an int64 (a bit cast, no conversion)."""
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def as_float(typingctx, k):
    """The float64 with the bits of the int64 ``k`` (the inverse of :func:`bits`)."""
    if k != types.int64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@njit(cache=True, inline="always")
def key(b):
    """The order-preserving key of the bits ``b`` of a double (its own inverse)."""
    return b ^ ((b >> 63) & MAGNITUDE)


@njit(cache=True, inline="always")
def high_key(b):
    """:func:`key`, with NaN mapped below every number (a maximum passes it over)."""
    return key(b) if (b & MAGNITUDE) <= INF_BITS else KEY_NEG_INF


@njit(cache=True, inline="always")
def low_key(b):
    """:func:`key`, with NaN mapped above every number (a minimum passes it over)."""
    return key(b) if (b & MAGNITUDE) <= INF_BITS else KEY_INF


@njit(cache=True, inline="always")
def value(k):
    """The double of the key ``k``."""
    return as_float(key(k))


@njit(cache=True, inline="always")
def key_extremes(a, b, first, last, hk, lk):
    """(max(hk, keys of a[first:last]), min(lk, keys of b[first:last])): :func:`max_min` on
    keys, for passes that gather extremes over several pieces."""
    if last > first:
        ka = a[first:last].view(np.int64)
        kb = b[first:last].view(np.int64)
        for i in range(ka.shape[0]):
            hk = max(hk, high_key(ka[i]))
            lk = min(lk, low_key(kb[i]))
    return hk, lk


@njit(cache=True)
def max_min(a, b, first, last, high, low):
    """(max(high, max a[first:last]), min(low, min b[first:last])), NaN entries passed over.

    ``a`` and ``b`` are contiguous float64 blocks; ``high`` and ``low`` numbers (not NaN).
    """
    hk, lk = key_extremes(a, b, first, last, key(bits(high)), key(bits(low)))
    return value(hk), value(lk)


@njit(cache=True)
def low_scan(g, level):
    """(first, last, smallest) of the contiguous block ``g``: the first and last index with
    g < level (len(g), -1 when none) and the smallest entry (+inf when empty; NaN passed
    over). One vectorised pass: the indices as integer extremes of selects."""
    m = g.shape[0]
    first, last, lk = m, -1, KEY_INF
    kg = g.view(np.int64)
    for i in range(m):
        near = g[i] < level
        first = min(first, i if near else m)
        last = max(last, i if near else -1)
        lk = min(lk, low_key(kg[i]))
    return first, last, value(lk)


def compile_all():
    """Compile the kernels of this module into numba's cache."""
    a = np.linspace(-1.0, 1.0, 8)
    max_min(a, a, 1, 7, -np.inf, np.inf)
    low_scan(a, 0.5)
