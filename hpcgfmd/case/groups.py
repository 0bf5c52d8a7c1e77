"""The dimensionless groups of a case, checked, and the scales derived from them
(docs/model.md, "Scales and dimensionless groups", (M16)-(M24), and "Units in the code").

Internal units are R = E0 = tau = 1 (tau_r, the modulus-weighted mean time (M41), for a
Prony series). The groups keep their case-file names: ``maugis`` is lambda0, ``modulus_ratio``
k = E0/Einf, ``velocity`` V_z, ``depth`` h0/R, ``cell`` L/R and ``adhesion``
alpha = dgamma0/(E0 R); everything else is derived from them. ``geometry`` is the indenter:
the cylinder of the paper (a line in plane strain) or a sphere on a surface, whose Maugis
parameter, speed and scales are the sphere's (docs/model.md, "The sphere").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..errors import CaseError
from ..model import sphere_theory, theory
from ..model.geometry import GEOMETRIES, Cylinder, Sphere
from ..model.material import GeneralizedMaxwell
from .keys import number, prony_series, shown, stiffness
from .units import Units, finite_scales

GROUP_KEYS = ("maugis", "modulus_ratio", "velocity", "depth", "cell", "adhesion")
PRONY_KEYS = ("relaxation_moduli", "relaxation_times")
DRIVE_KEYS = ("drive_stiffness",)  # in E0 ([case]) or Pa ([physical]): the compliant drive
GEOMETRY_KEYS = ("geometry",)  # "cylinder" (the default) or "sphere"
# The geometric contact width sqrt(2 R h0) bounds a_c; with L >= 6 sqrt(2 R h0) the periodic
# image correction pi^2 a^2 / (6 L^2) to the load stays below 5 %.
MIN_CELL_PER_CONTACT = 6.0
MEAN_TIME_TOLERANCE = 1e-6  # [case] relaxation_times: their weighted mean is 1 to this


@dataclass(frozen=True)
class Groups:
    """The checked groups of a case (:func:`checked_groups` makes them).

    Attributes
    ----------
    maugis, modulus_ratio, velocity, depth, cell, adhesion : float
        lambda0, k in (0, 1], V_z, h0/R, L/R and alpha (dimensionless).
    relaxation_moduli, relaxation_times : tuple of float
        A Prony series' E_i / E0 and tau_i / tau_r (empty: the SLS of k).
    drive_stiffness : float
        k_s / E0 of the spring holding the indenter (inf: displacement control, 0: load
        control).
    geometry : {"cylinder", "sphere"}
        The indenter.
    units : Units
        The case's units in the internal ones.
    form : {"case", "physical"}
        The section the case was given in (messages name its keys).
    """

    maugis: float
    modulus_ratio: float
    velocity: float
    depth: float
    cell: float
    adhesion: float
    relaxation_moduli: tuple = ()
    relaxation_times: tuple = ()
    drive_stiffness: float = math.inf
    geometry: str = "cylinder"
    units: Units = field(default_factory=Units)
    form: str = "case"

    # --- the substrate, the indenter and the drive ---------------------------------------
    def material(self) -> GeneralizedMaxwell:
        """The substrate's material in internal units (E0 = tau_r = 1): the Prony series, or
        the SLS of k (one branch; k = 1 the elastic solid)."""
        if self.relaxation_moduli:
            return GeneralizedMaxwell(1.0, self.relaxation_moduli, self.relaxation_times)
        return GeneralizedMaxwell.standard_linear(1.0, 1.0 / self.modulus_ratio, 1.0)

    def indenter(self) -> Cylinder | Sphere:
        """The indenter (internal units, R = 1)."""
        return GEOMETRIES[self.geometry]()

    @property
    def sphere(self) -> bool:
        """The indenter is a sphere on a surface (else the paper's cylinder on a line)."""
        return self.geometry == "sphere"

    @property
    def compliant(self) -> bool:
        """The indenter hangs on a spring (finite drive_stiffness) or the load is controlled
        (drive_stiffness = 0)."""
        return self.drive_stiffness != math.inf

    @property
    def load_control(self) -> bool:
        """The protocol moves the load (drive_stiffness = 0)."""
        return self.drive_stiffness == 0.0

    # --- derived scales (internal units) -------------------------------------------------
    def _sphere(self) -> sphere_theory.SphereGroups:
        """The sphere's groups and scales (docs/model.md, "The sphere")."""
        return sphere_theory.SphereGroups(
            self.maugis, self.modulus_ratio, self.velocity, self.depth, self.cell, self.adhesion
        )

    @property
    def beta(self) -> float:
        """Length scale of the contact: the cylinder's (R^2 dgamma0 / E0)^(1/3) = alpha^(1/3)
        (M16), the sphere's contact radius scale a_s = (pi dgamma0 R^2 / K)^(1/3) (M52)."""
        if self.sphere:
            return self._sphere().beta
        return self.adhesion ** (1.0 / 3.0)

    @property
    def load_scale(self) -> float:
        """Load scale: the cylinder's (R dgamma0^2 E0)^(1/3) = alpha^(2/3) per length (M17),
        the sphere's force pi dgamma0 R (M47), (M52)."""
        if self.sphere:
            return self._sphere().load_scale
        return self.adhesion ** (2.0 / 3.0)

    @property
    def depth_scale(self) -> float:
        """The scale of the indenter's travel: beta^2 / R (M18), the sphere's delta_s =
        a_s^2 / R (M49)."""
        return self.beta**2

    @property
    def sigma_a(self) -> float:
        """Adhesive traction sigma_a: the cylinder's lambda0 (E0^2 dgamma0 / R)^(1/3) (M20),
        the sphere's from Maugis's lambda0 (M48), (M50)."""
        if self.sphere:
            return self._sphere().sigma_a
        return self.maugis * self.adhesion ** (1.0 / 3.0)

    @property
    def dmax(self) -> float:
        """Interaction range dgamma0 / sigma_a."""
        return self.adhesion / self.sigma_a

    @property
    def indenter_speed(self) -> float:
        """Retraction velocity v_z = V_z beta^2 / (R tau) (M19); the sphere's V_z delta_s
        / tau (M49)."""
        if self.sphere:
            return self._sphere().indenter_speed
        return self.velocity * self.beta**2

    @property
    def lambda_inf(self) -> float:
        """Instantaneous Maugis parameter lambda0 k^(2/3) (M21)."""
        return self.maugis * self.modulus_ratio ** (2.0 / 3.0)

    @property
    def chi_ve(self) -> float:
        """chi_ve: V_z lambda0^2 for the cylinder (paper Eq. 22, (M22)), (pi/3) V_z lambda0^2
        for the sphere (M53)."""
        if self.sphere:
            return self._sphere().chi_ve
        return theory.chi_ve(self.velocity, self.maugis)

    @property
    def zone_width(self) -> float:
        """Relaxed cohesive-zone width w = pi E0 dmax / (4 sigma_a): beta pi / (4 lambda0^2)
        for the cylinder (M23), 3 a_s / (4 lambda0^2) for the sphere (M53)."""
        if self.sphere:
            return self._sphere().zone_width
        return self.beta * theory.cohesive_width(self.maugis)

    def cell_key(self) -> str:
        """The case file's name for the cell length ([case] cell or [physical] cell_length)."""
        return "[case] cell" if self.form == "case" else "[physical] cell_length"


def checked_geometry(raw: Mapping, section: str) -> str:
    """The ``geometry`` key: "cylinder" (the default) or "sphere"."""
    geometry = raw.get("geometry", "cylinder")
    if geometry not in GEOMETRIES:
        raise CaseError(
            f"[{section}] geometry = {shown(geometry)}: expected one of"
            f" {', '.join(repr(name) for name in GEOMETRIES)}"
        )
    return geometry


def checked_groups(raw: Mapping, units: Units, form: str) -> Groups:
    """The :class:`Groups` of the ``[case]`` keys ``raw`` (numbers as given, or from
    ``[physical]`` through :func:`~.units.groups_from_physical`), each checked.

    Raises
    ------
    CaseError
        A value out of range, a Prony series or spring that is not one, derived scales out
        of the floating-point range, a cell too small for the contact.
    """
    section = "case" if form == "case" else "physical"
    values = {key: raw[key] for key in GROUP_KEYS if key in raw}
    moduli, times = raw.get("relaxation_moduli"), raw.get("relaxation_times")
    if _given(moduli) or _given(times):
        moduli, times = prony_series(moduli, times, section)
        values["modulus_ratio"] = _prony_modulus_ratio(
            moduli, times, values.get("modulus_ratio"), form, section
        )
    else:
        moduli, times = (), ()
    drive = raw.get("drive_stiffness", math.inf)
    if drive != math.inf:
        drive = stiffness({"drive_stiffness": drive}, section)
    if form == "case":
        values = {key: number(values, "case", key) for key in GROUP_KEYS}
        if values["modulus_ratio"] > 1.0:
            raise CaseError(
                f"[case] modulus_ratio = {values['modulus_ratio']}: expected"
                " k = E0/Einf in (0, 1] (1 is the elastic solid)"
            )
    groups = Groups(
        **values,
        relaxation_moduli=tuple(moduli),
        relaxation_times=tuple(times),
        drive_stiffness=float(drive),
        geometry=checked_geometry(raw, section),
        units=units,
        form=form,
    )
    _check_scales(groups)
    min_cell = MIN_CELL_PER_CONTACT * math.sqrt(2.0 * groups.depth)
    if groups.cell < min_cell:
        raise CaseError(
            f"{groups.cell_key()} = {groups.cell * units.length:.6g}: too small"
            f" for the contact; need L >= {MIN_CELL_PER_CONTACT:g} sqrt(2 R h0) ="
            f" {min_cell * units.length:.4g}"
        )
    return groups


def _given(value) -> bool:
    """A Prony list is given: anything but None or an empty sequence."""
    return value is not None and not (hasattr(value, "__len__") and len(value) == 0)


def _prony_modulus_ratio(moduli, times, given, form, section):
    """k = E0 / Einf = 1 / (1 + sum E_i / E0) of a Prony series ([case] times with a
    weighted mean of 1; a given modulus_ratio must be that k)."""
    mean = math.fsum(m * t for m, t in zip(moduli, times)) / math.fsum(moduli)
    if form == "case" and not abs(mean - 1.0) <= MEAN_TIME_TOLERANCE:
        scaled = ", ".join(f"{t / mean:.10g}" for t in times)
        raise CaseError(
            f"[case] relaxation_times = {shown(list(times))}: expected times in units of the"
            " reference time sum E_i tau_i / sum E_i, whose mean weighted by"
            f" relaxation_moduli is 1; these average {mean:.10g}: the same solid is"
            f" relaxation_times = [{scaled}] with velocity times {mean:.10g}"
        )
    k = 1.0 / (1.0 + math.fsum(moduli))
    if given is not None and (
        isinstance(given, bool)
        or not isinstance(given, (int, float))
        or not abs(given - k) <= 1e-12 * k
    ):
        raise CaseError(
            f"[{section}] modulus_ratio = {shown(given)}: a Prony series sets"
            f" k = 1 / (1 + sum of relaxation_moduli) = {k:.12g}; leave"
            " modulus_ratio out"
        )
    return k


def _check_scales(groups: Groups):
    """The derived scales the numerics divide by, finite and > 0."""
    where = (
        f"[case] {', '.join(f'{key} = {getattr(groups, key):g}' for key in GROUP_KEYS)}"
        if groups.form == "case"
        else "[physical] values"
    )
    finite_scales(
        where,
        {
            "lambda_inf = lambda0 k^(2/3)": lambda: groups.lambda_inf,
            "beta = alpha^(1/3)": lambda: groups.beta,
            "sigma_a = lambda0 beta": lambda: groups.sigma_a,
            "dmax = alpha / sigma_a": lambda: groups.dmax,
            "chi_ve = V_z lambda0^2": lambda: groups.chi_ve,
            "v_z = V_z beta^2": lambda: groups.indenter_speed,
            "w = pi beta / (4 lambda0^2)": lambda: groups.zone_width,
        },
    )


def python_numbers(value):
    """``value`` with every numpy scalar in it (in dicts, lists and tuples too) replaced by
    the Python number, bool or str it holds, and numpy arrays by lists."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, dict):
        return {key: python_numbers(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(python_numbers(item) for item in value)
    return value
