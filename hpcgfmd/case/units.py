"""The case's units, and the ``[physical]`` (SI) form of a case turned into its groups
(docs/model.md, "Units in the code"; docs/case-file.md, "[physical]").

Internally R = E0 = tau = 1. A ``[physical]`` case keeps R, E0 and tau (tau_r, the
modulus-weighted mean time, for a Prony series: (M41)) as its units, so that the output is in
m, Pa and s; a ``[case]`` case's units are R, E0 and tau themselves.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import CaseError
from ..model import sphere_theory
from .keys import number, prony_series, stiffness

PHYSICAL_KEYS = (
    "radius",
    "modulus_relaxed",
    "modulus_instantaneous",
    "relaxation_time",
    "work_of_adhesion",
    "interaction_range",
    "velocity",
    "depth",
    "cell_length",
)


@dataclass(frozen=True)
class Units:
    """The case's units expressed in the internal units R = E0 = tau = 1.

    Attributes
    ----------
    length, stress, time : float
        R, E0 and tau in the case's units (metre, pascal, second; or 1 with ``[case]``).
    """

    length: float = 1.0
    stress: float = 1.0
    time: float = 1.0

    @property
    def load(self) -> float:
        """Load per unit length: E0 R."""
        return self.stress * self.length

    @property
    def force(self) -> float:
        """Force: E0 R^2 (a sphere's load)."""
        return self.stress * self.length**2


def finite_scales(where, scales):
    """CaseError unless each derived scale (name -> function) is finite and > 0: extreme
    values (1e308, 1e-300) pass one by one but over- or underflow in combination."""
    for name, scale in scales.items():
        try:
            value = scale()
        except (OverflowError, ZeroDivisionError):  # ** overflowed; a divisor underflowed
            value = math.inf
        if not 0.0 < value < math.inf:
            raise CaseError(
                f"{where}: {name} = {value:g} is out of the floating-point range;"
                " expected values whose derived scales are finite and > 0"
            )


def groups_from_physical(table: dict, geometry: str = "cylinder"):
    """``[physical]`` SI values -> (the ``[case]`` keys and values, the units).

    ``geometry`` "sphere": the sphere's Maugis parameter and V_z (docs/model.md, (M48) and
    (M49)) in place of the cylinder's (M19)-(M20).

    A Prony series (relaxation_moduli in Pa, relaxation_times in s) stands in for
    modulus_instantaneous and relaxation_time: Einf = E0 + sum E_i and the reference time
    tau_r = sum E_i tau_i / sum E_i (docs/model.md, (M41)) is the case's unit of time.
    """
    t = dict(table)
    prony = {}
    if "relaxation_moduli" in t or "relaxation_times" in t:
        for key in ("modulus_instantaneous", "relaxation_time"):
            if key in t:
                raise CaseError(
                    f"[physical] {key}: a Prony series (relaxation_moduli,"
                    " relaxation_times) sets the moduli and the times; leave"
                    f" {key} out"
                )
        moduli, times = prony_series(
            t.get("relaxation_moduli"), t.get("relaxation_times"), "physical"
        )
        t["modulus_instantaneous"] = number(t, "physical", "modulus_relaxed") + math.fsum(moduli)
        t["relaxation_time"] = math.fsum(m * x for m, x in zip(moduli, times)) / math.fsum(moduli)
        e0, tau = t["modulus_relaxed"], t["relaxation_time"]
        prony = {
            "relaxation_moduli": tuple(m / e0 for m in moduli),
            "relaxation_times": tuple(x / tau for x in times),
        }
    radius, e0, einf, tau, work, dmax, velocity, depth, cell = (
        number(t, "physical", key) for key in PHYSICAL_KEYS
    )
    if einf < e0:
        raise CaseError(
            f"[physical] modulus_instantaneous = {einf}: must be >= modulus_relaxed"
            f" = {e0} (k = E0/Einf in (0, 1])"
        )
    values = (radius, e0, einf, tau, work, dmax, velocity, depth, cell)
    formulas = {
        "maugis": lambda: (work**2 * radius / (e0**2 * dmax**3)) ** (1.0 / 3.0),
        "modulus_ratio": lambda: e0 / einf,
        "velocity": lambda: velocity * tau * radius / ((radius**2 * work / e0) ** (1.0 / 3.0)) ** 2,
        "depth": lambda: depth / radius,
        "cell": lambda: cell / radius,
        "adhesion": lambda: work / (e0 * radius),
    }
    if geometry == "sphere":  # Maugis's lambda0 and the sphere's V_z (M48), (M49)
        formulas["maugis"] = lambda: sphere_theory.physical_groups(*values)["maugis"]
        formulas["velocity"] = lambda: sphere_theory.physical_groups(*values)["velocity"]
    finite_scales(
        "[physical] "
        + ", ".join(f"{key} = {value:g}" for key, value in zip(PHYSICAL_KEYS, values)),
        formulas,
    )
    groups = {key: formula() for key, formula in formulas.items()}
    if prony:  # k from the series itself
        groups.update(prony, modulus_ratio=None)
    if "drive_stiffness" in t:  # Pa (N/m per m of cylinder and m of travel) -> E0
        groups["drive_stiffness"] = stiffness(t, "physical") / e0
    return groups, Units(length=radius, stress=e0, time=tau)
