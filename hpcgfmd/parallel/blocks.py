"""Small helpers for the MPI decomposition.

Nothing here talks to a communicator by itself: the functions take sizes and ranks, so the
same code serves any communicator the caller passes around (never a global COMM_WORLD).
"""

from __future__ import annotations


def block_range(n: int, size: int, rank: int) -> tuple[int, int]:
    """Contiguous, balanced block of ``range(n)`` owned by ``rank`` out of ``size`` ranks.

    The first ``n % size`` ranks get one item more than the others, so block lengths differ
    by at most one and the blocks of ranks 0, 1, ..., size-1 tile ``[0, n)`` in order. When
    ``n < size`` the last ranks get empty blocks (``start == stop``).

    Parameters
    ----------
    n : int
        Number of items to distribute (>= 0).
    size : int
        Number of ranks (>= 1).
    rank : int
        Rank whose block is wanted, ``0 <= rank < size``.

    Returns
    -------
    start, stop : int
        Global index range ``[start, stop)`` of this rank's block.
    """
    if n < 0 or size < 1 or not 0 <= rank < size:
        raise ValueError(f"bad block_range arguments n={n}, size={size}, rank={rank}")
    base, extra = divmod(n, size)
    start = rank * base + min(rank, extra)
    return start, start + base + (rank < extra)


def chunks(count: int, size: int) -> list[tuple[int, int]]:
    """``range(count)`` split into balanced ``(start, stop)`` chunks of at most ``size`` items
    (none for ``count`` 0): the cache-sized pieces a transform works through."""
    if count == 0:
        return []
    number = -(-count // max(1, size))
    return [block_range(count, number, i) for i in range(number)]
