"""The energy of one step, E(u)/dx = 1/2 u.K u + (H - p_applied).u - sigma_a sum_e M_e, and the
memory of the last K u a solve can start from without a transform.

M_e is the mean of the cohesive ramp max(dmax - g, 0) over element e of the piecewise-linear
gap (docs/model.md, "Discretisation"); K the step's stiffness (|q|/2) Eeff per mode.
"""
from __future__ import annotations

import numpy as np

from ...parallel.fft import aligned_empty
from ..step_kernels import energy_terms
from . import kernels


class StepEnergy:
    """Energies of displacements of one step on this rank's block, and the K u they cost.

    Parameters
    ----------
    domain : hpcgfmd.parallel.domain.Domain
    fft : SerialRealFFT, HalvedRealFFT or TransposedRealFFT
    law : hpcgfmd.model.interface.DugdaleMaugis
    """

    def __init__(self, domain, fft, law):
        self.domain, self.fft, self.law = domain, fft, law
        n = domain.local_n
        self._n = n
        self._gap_ext = np.empty(n + 2)
        self._k_u = aligned_empty(n)
        self._mask = np.empty(n, dtype=bool)
        # The lowest-energy vector passed to energy() since the last solve began (the
        # predictor's start of the next solve) and its K: see recall.
        self._guess = np.empty(n)
        self._k_guess = np.empty(n)
        self._guess_stiffness = None
        self._guess_energy = np.inf
        self._spectrum_mask = None

    def energy(self, u, wall, ops, history, applied=None, stiffness_u=None):
        """Collective: energy of the step per unit length, divided by dx (one FFT pair to
        form K u, none when it is given as ``stiffness_u``).

        The lowest-energy vector evaluated since the last solve began is kept with its K
        (:meth:`recall`: the next solve starts from it without a transform).
        """
        k_u = stiffness_u
        if k_u is None:
            k_u = self._k_u
            self.fft.apply_diagonal(u, ops.stiffness, k_u)
        value = self.energy_with(u, k_u, wall, history, applied)
        if value < self._guess_energy:
            np.copyto(self._guess, u)
            np.copyto(self._k_guess, k_u)
            self._guess_stiffness = _keep(self._guess_stiffness, ops.stiffness)
            self._guess_energy = value
        return value

    def energy_with(self, u, k_u, wall, history, applied=None):
        """Collective: energy (per unit length, divided by dx) of u with K u given."""
        value = self._bulk_energy(u, k_u, history, wall)
        if applied is not None:
            value -= float(applied @ u)
        return self._interface_energy(value)

    def energy_linear(self, u, k_u, wall, linear):
        """:meth:`energy_with` with the linear term H - p_applied given as one vector."""
        return self._interface_energy(self._bulk_energy(u, k_u, linear, wall))

    def _bulk_energy(self, u, k_u, linear, wall):
        """Local: 1/2 u.K u + linear.u, and the gaps wall - u into the ghosted buffer."""
        return energy_terms(u, k_u, linear, wall, self._gap_ext[1:-1])

    def _interface_energy(self, value):
        """Collective: ``value`` plus the cohesive energy of the gaps in the buffer, summed
        (the law's :meth:`~hpcgfmd.model.interface.DugdaleMaugis.energy` with dx = 1, in one
        compiled loop over the zone)."""
        gap_ext = self._gap_ext
        self.domain.fill_halo(gap_ext)
        law = self.law
        if law.sigma_a > 0.0 and gap_ext.shape[0] > 2:
            value -= law.sigma_a * kernels.cohesive_energy(gap_ext, law.dmax)
        return self.domain.sum(value)

    def forget(self):
        """Drop the kept vector: the memory lives within one step (see :meth:`recall`)."""
        self._guess_energy = np.inf

    def recall(self, u, stiffness, out):
        """Collective: True (and K u in ``out``) when K u is known for these exact bits.

        Kept: the lowest-energy vector passed to :meth:`energy` since the last solve began,
        with its K. The protocol's predictor evaluates its guesses and the previous solution
        and starts the solve from the lowest, so the solve's first transform is saved. A
        match needs the same stiffness values and the same bits of u on every rank, so the
        result is bitwise the transform's. The solver forgets the vector when a solve
        begins, so it never carries over from one step to the next: a run resumed from a
        checkpoint does the same transforms as an uninterrupted one. A miss costs a sample
        comparison, a match a full one (~0.1 pair).
        """
        same = (self._guess_energy < np.inf
                and self._matches(u, self._guess, self._guess_stiffness, stiffness))
        if self.domain.max(0.0 if same else 1.0) > 0.0:
            return False
        np.copyto(out, self._k_guess)
        return True

    def _matches(self, u, kept_u, kept_stiffness, stiffness):
        """Local: u and the stiffness are bitwise the kept ones (a sample of u first)."""
        if kept_stiffness is None or kept_stiffness.shape != stiffness.shape:
            return False
        sample = max(1, self._n // 256)
        if np.not_equal(u[::sample], kept_u[::sample]).any():
            return False
        if np.not_equal(u, kept_u, out=self._mask).any():
            return False
        if self._spectrum_mask is None or self._spectrum_mask.shape != stiffness.shape:
            self._spectrum_mask = np.empty(stiffness.shape, dtype=bool)
        return not np.not_equal(kept_stiffness, stiffness, out=self._spectrum_mask).any()


def _keep(kept, stiffness):
    """Copy of ``stiffness`` in the buffer ``kept`` (reallocated only on a shape change)."""
    if kept is None or kept.shape != stiffness.shape:
        kept = np.empty_like(stiffness)
    np.copyto(kept, stiffness)
    return kept
