"""A case: the dimensionless groups of one retraction, its numerics and its output, validated.

Two equivalent forms of input, exactly one per case (docs/model.md, "Scales and dimensionless
groups"; docs/case-file.md lists every key with its default):

``[case]`` the dimensionless groups in units R = E0 = tau = 1:
    maugis (lambda0), modulus_ratio (k = E0/Einf, in (0, 1]), velocity (V_z),
    depth (h0/R), cell (L/R), adhesion (alpha = dgamma0 / (E0 R)); for a generalized Maxwell
    (Prony) solid relaxation_moduli (E_i / E0) and relaxation_times (tau_i / tau_r, tau_r their
    modulus-weighted mean, docs/model.md (M41)) in place of modulus_ratio.
``[physical]`` SI values:
    radius, modulus_relaxed, modulus_instantaneous (plane-strain moduli E*), relaxation_time,
    work_of_adhesion, interaction_range, velocity, depth, cell_length; for a Prony solid
    relaxation_moduli (Pa) and relaxation_times (s) in place of modulus_instantaneous and
    relaxation_time.

``[[protocol]]`` (optional) lists the loading segments the drive follows
(:mod:`hpcgfmd.model.loading`); without it the paper's preload and retraction.
``[numerics]`` and ``[output]`` are optional; times and lengths there are in the case's units
(tau and R with ``[case]``, seconds and metres with ``[physical]``).

From Python, ``Case(maugis=7.0, modulus_ratio=0.1, velocity=0.45, depth=0.1, cell=10.0,
adhesion=5e-5, numerics={"nx": 4096})`` validates exactly as the case file would;
:meth:`Case.from_toml` reads a file or a text. Every problem is a
:class:`~hpcgfmd.errors.CaseError` naming the key, the value and what is accepted.
"""
from __future__ import annotations

import hashlib
import json
import math
import numbers
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import tomli_w

from ..errors import CaseError
from . import theory
from .keys import (as_float, integer, number, numbers_list, quoted_key, shown,
                   unknown_keys)
from .loading import Segment, paper_protocol, parse_protocol
from .material import GeneralizedMaxwell
from .numerics import (DEFAULT_MAX_ITERATIONS, NUMERICS_KEYS, Numerics, contact_nodes,
                       resolve_numerics)

# The geometric contact width sqrt(2 R h0) bounds a_c; with L >= 6 sqrt(2 R h0) the periodic
# image correction pi^2 a^2 / (6 L^2) to the load stays below 5 %.
MIN_CELL_PER_CONTACT = 6.0
MEAN_TIME_TOLERANCE = 1e-6  # [case] relaxation_times: their weighted mean is 1 to this

CASE_KEYS = ("maugis", "modulus_ratio", "velocity", "depth", "cell", "adhesion")
PHYSICAL_KEYS = ("radius", "modulus_relaxed", "modulus_instantaneous", "relaxation_time",
                 "work_of_adhesion", "interaction_range", "velocity", "depth", "cell_length")
PRONY_KEYS = ("relaxation_moduli", "relaxation_times")  # [case] and [physical]
DRIVE_KEYS = ("drive_stiffness",)  # [case] (in E0) and [physical] (in Pa): the compliant drive
OUTPUT_KEYS = ("snapshot_times", "snapshot_contact_widths", "snapshot_zero_load",
               "progress_interval", "checkpoint_interval", "checkpoint_steps")
SECTIONS = {"case": CASE_KEYS + PRONY_KEYS + DRIVE_KEYS,
            "physical": PHYSICAL_KEYS + PRONY_KEYS + DRIVE_KEYS,
            "numerics": NUMERICS_KEYS, "output": OUTPUT_KEYS}


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


@dataclass(frozen=True)
class Output:
    """What is written besides the series (internal units R, tau; intervals in wall seconds)."""

    snapshot_times: tuple = ()
    snapshot_contact_widths: tuple = ()  # descending
    snapshot_zero_load: bool = False
    progress_interval: float = 10.0
    checkpoint_interval: float = 600.0
    checkpoint_steps: int = 0  # also every this many steps (0: only by wall time)


@dataclass(frozen=True)
class Case:
    """One retraction case, validated; the dimensionless groups under their case-file names.

    Parameters
    ----------
    maugis, modulus_ratio, velocity, depth, cell, adhesion : float
        lambda0, k = E0/Einf in (0, 1], V_z, h0/R, L/R and alpha = dgamma0/(E0 R), all
        dimensionless (docs/model.md, "Scales and dimensionless groups"). With a Prony series
        ``modulus_ratio`` may be None: it is 1 / (1 + sum of relaxation_moduli).
    numerics, output : dict or Numerics / Output, optional
        The ``[numerics]`` and ``[output]`` keys of a case file (in the case's units), or the
        resolved objects; left out, every default applies.
    units : Units
        The case's units (``[physical]`` input); the internal units are R = E0 = tau = 1.
    text : str
        The case file (stored in the output); made from the keys when not given.
    form : {"case", "physical"}
        Which section the case came from (error messages name its keys).
    relaxation_moduli, relaxation_times : sequence of float, optional
        A generalized Maxwell (Prony) substrate (docs/model.md, (M38)-(M41)): E_i / E0 and
        tau_i / tau_r of each branch, tau_r = sum E_i tau_i / sum E_i the reference time (so
        the times' weighted mean is 1). Left out: the standard linear solid of k.
    drive_stiffness : float, optional
        k_s / E0 >= 0 of the spring between the drive and the indenter, per unit length of
        the cylinder (docs/model.md, "Protocol"): the drive follows the protocol and the
        indenter is where the spring balances the load. inf (the default): displacement
        control; 0: load control (the protocol moves the applied load).
    protocol : list of dict or tuple of Segment, optional
        The ``[[protocol]]`` tables (case units) or resolved segments
        (:mod:`hpcgfmd.model.loading`); empty: the paper's preload and retraction.

    Raises
    ------
    CaseError
        A value out of range, a cell too small for the contact, an unresolved grid.
    """

    maugis: float
    modulus_ratio: float
    velocity: float
    depth: float
    cell: float
    adhesion: float
    numerics: Numerics | dict | None = None
    output: Output | dict | None = None
    units: Units = field(default_factory=Units)
    text: str = ""
    form: str = "case"
    relaxation_moduli: tuple = ()
    relaxation_times: tuple = ()
    drive_stiffness: float = math.inf
    protocol: tuple = ()

    def __post_init__(self):
        # numpy scalars (a sweep over numpy arrays) as the Python numbers a case file gives
        for name in CASE_KEYS + PRONY_KEYS + DRIVE_KEYS + ("numerics", "output", "protocol"):
            object.__setattr__(self, name, _python_numbers(getattr(self, name)))
        given = {"numerics": self.numerics, "output": self.output}
        for name, resolved in (("numerics", Numerics), ("output", Output)):
            value = given[name]
            if not (value is None or isinstance(value, (Mapping, resolved))):
                raise CaseError(f"{name} = {shown(value)}: expected a dict of the [{name}]"
                                " keys (or None for the defaults)")
        given_protocol = self.protocol
        if any(value is not None and not (hasattr(value, "__len__") and len(value) == 0)
               for value in (self.relaxation_moduli, self.relaxation_times)):
            self._resolve_prony()
        if self.drive_stiffness != math.inf:
            section = "case" if self.form == "case" else "physical"
            stiffness = self.drive_stiffness
            if not (isinstance(stiffness, (int, float)) and not isinstance(stiffness, bool)
                    and stiffness == 0.0):  # 0 is load control
                stiffness = number({"drive_stiffness": stiffness}, section, "drive_stiffness")
            object.__setattr__(self, "drive_stiffness", float(stiffness))
        if self.form == "case":
            groups = {key: getattr(self, key) for key in CASE_KEYS}
            for key in CASE_KEYS:
                object.__setattr__(self, key, number(groups, "case", key))
            if self.modulus_ratio > 1.0:
                raise CaseError(f"[case] modulus_ratio = {self.modulus_ratio}: expected"
                                " k = E0/Einf in (0, 1] (1 is the elastic solid)")
        self._check_scales()
        self._resolve_protocol()
        min_cell = MIN_CELL_PER_CONTACT * math.sqrt(2.0 * self.depth)
        if self.cell < min_cell:
            raise CaseError(f"{self.cell_key()} = {self.cell * self.units.length:.6g}: too"
                            f" small for the contact; need L >= {MIN_CELL_PER_CONTACT:g}"
                            f" sqrt(2 R h0) = {min_cell * self.units.length:.4g}")
        if not isinstance(self.numerics, Numerics):
            object.__setattr__(self, "numerics", resolve_numerics(self, self.numerics or {}))
        if not isinstance(self.output, Output):
            object.__setattr__(self, "output", _resolve_output(self.output or {}, self.units))
        if not self.text:  # built from keywords: the case file that gives this case
            keys = CASE_KEYS if not self.prony else (
                tuple(key for key in CASE_KEYS if key != "modulus_ratio") + PRONY_KEYS)
            if self.compliant:
                keys += DRIVE_KEYS
            doc = {"case": {key: _plain(getattr(self, key)) for key in keys}}
            if isinstance(given_protocol, list):
                doc["protocol"] = given_protocol
            doc.update({name: value for name, value in given.items()
                        if isinstance(value, dict) and value})
            object.__setattr__(self, "text", tomli_w.dumps(doc))

    def _resolve_prony(self):
        """Check a Prony series (two lists of numbers > 0, one length; [case] times with a
        weighted mean of 1) and derive k = E0 / Einf = 1 / (1 + sum E_i / E0) from it."""
        section = "case" if self.form == "case" else "physical"
        moduli, times = _prony_series(self.relaxation_moduli, self.relaxation_times, section)
        mean = math.fsum(m * t for m, t in zip(moduli, times)) / math.fsum(moduli)
        if self.form == "case" and not abs(mean - 1.0) <= MEAN_TIME_TOLERANCE:
            scaled = ", ".join(f"{t / mean:.10g}" for t in times)
            raise CaseError(
                f"[case] relaxation_times = {shown(list(times))}: expected times in units of the"
                " reference time sum E_i tau_i / sum E_i, whose mean weighted by"
                f" relaxation_moduli is 1; these average {mean:.10g}: the same solid is"
                f" relaxation_times = [{scaled}] with velocity times {mean:.10g}")
        k = 1.0 / (1.0 + math.fsum(moduli))
        given = self.modulus_ratio
        if given is not None and (isinstance(given, bool) or not isinstance(given, (int, float))
                                  or not abs(given - k) <= 1e-12 * k):
            raise CaseError(f"[{section}] modulus_ratio = {shown(given)}: a Prony series sets"
                            f" k = 1 / (1 + sum of relaxation_moduli) = {k:.12g}; leave"
                            " modulus_ratio out")
        object.__setattr__(self, "relaxation_moduli", moduli)
        object.__setattr__(self, "relaxation_times", times)
        object.__setattr__(self, "modulus_ratio", k)

    def _resolve_protocol(self):
        """``[[protocol]]`` tables (case units) -> segments (internal units), checked."""
        if self.load_control and not self.protocol:
            raise CaseError(f"[{self.form}] drive_stiffness = 0: load control needs a"
                            " [[protocol]] whose segments give a load_rate")
        if not self.protocol or all(isinstance(s, Segment) for s in self.protocol):
            return
        units = self.units
        scale = (self.alpha ** (2.0 / 3.0) if self.form == "case"  # V_z units: beta^2
                 else units.time / units.length)  # m/s
        segments = parse_protocol(
            self.protocol if isinstance(self.protocol, list) else list(self.protocol),
            length=units.length, time=units.time, load=units.load, speed=self.indenter_speed,
            speed_scale=scale, load_control=self.load_control)
        object.__setattr__(self, "protocol", segments)

    @property
    def compliant(self) -> bool:
        """True when the indenter hangs on a spring (finite drive_stiffness) or the load is
        controlled (drive_stiffness = 0)."""
        return self.drive_stiffness != math.inf

    @property
    def load_control(self) -> bool:
        """True under load control (drive_stiffness = 0): the protocol moves the load."""
        return self.drive_stiffness == 0.0

    @property
    def segments(self) -> tuple:
        """The protocol's segments after the start (:mod:`~hpcgfmd.model.loading`): the
        case's own, or the paper's single retraction at the case's speed."""
        return self.protocol or paper_protocol(self.indenter_speed)

    @property
    def starts_out_of_contact(self) -> bool:
        """True when the protocol starts with an approach (no preload; u_z = 2 dmax)."""
        return bool(self.protocol) and self.protocol[0].kind == "approach"

    @property
    def prony(self) -> bool:
        """True for a generalized Maxwell (Prony series) substrate, False for the SLS."""
        return bool(self.relaxation_moduli)

    def material(self):
        """The substrate's material in internal units (E0 = tau_r = 1): a
        :class:`~hpcgfmd.model.prony.GeneralizedMaxwell` for a Prony series, else the
        :class:`~hpcgfmd.model.material.StandardLinearSolid` of k."""
        if self.prony:
            return GeneralizedMaxwell(1.0, self.relaxation_moduli, self.relaxation_times)
        return GeneralizedMaxwell.standard_linear(1.0, 1.0 / self.k, 1.0)

    def _check_scales(self):
        """The derived scales the numerics divide by, finite and > 0: extreme groups (1e308,
        1e-300) pass one by one but over- or underflow in combination."""
        where = (f"[case] {', '.join(f'{key} = {getattr(self, key):g}' for key in CASE_KEYS)}"
                 if self.form == "case" else "[physical] values")
        _finite_scales(where, {"lambda_inf = lambda0 k^(2/3)": lambda: self.lambda_inf,
                               "beta = alpha^(1/3)": lambda: self.beta,
                               "sigma_a = lambda0 beta": lambda: self.sigma_a,
                               "dmax = alpha / sigma_a": lambda: self.dmax,
                               "chi_ve = V_z lambda0^2": lambda: self.chi_ve,
                               "v_z = V_z beta^2": lambda: self.indenter_speed,
                               "w = pi beta / (4 lambda0^2)": lambda: self.zone_width})

    # --- construction -------------------------------------------------------------------
    @classmethod
    def from_toml(cls, source) -> "Case":
        """The case of a case file (a path: a ``pathlib.Path`` or a one-line string) or of its
        text (a string of more than one line).

        Raises :class:`~hpcgfmd.errors.CaseError`, also for an unreadable file.
        """
        if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
            try:
                return load_case(source)
            except CaseError as err:
                raise CaseError(f"{os.fspath(source)}: {err}") from None
        if not isinstance(source, str):
            raise CaseError(f"case = {shown(source)}: expected a Case, a case file's path"
                            " (str or os.PathLike) or its TOML text")
        return parse_case(source)

    def cell_key(self) -> str:
        """The case file's name for the cell length ([case] cell or [physical] cell_length)."""
        return "[case] cell" if self.form == "case" else "[physical] cell_length"

    # --- the groups under the paper's symbols, and derived quantities (internal units) --
    @property
    def lambda0(self) -> float:
        """Relaxed Maugis parameter lambda0 (docs/model.md, (M20))."""
        return self.maugis

    @property
    def k(self) -> float:
        """Modulus ratio k = E0 / Einf."""
        return self.modulus_ratio

    @property
    def Vz(self) -> float:
        """Dimensionless retraction velocity V_z = v_z tau R / beta^2."""
        return self.velocity

    @property
    def alpha(self) -> float:
        """alpha = dgamma0 / (E0 R) = (beta / R)^3."""
        return self.adhesion

    @property
    def beta(self) -> float:
        """Length scale (R^2 dgamma0 / E0)^(1/3) = alpha^(1/3)."""
        return self.alpha ** (1.0 / 3.0)

    @property
    def load_scale(self) -> float:
        """Load scale (R dgamma0^2 E0)^(1/3) = alpha^(2/3)."""
        return self.alpha ** (2.0 / 3.0)

    @property
    def sigma_a(self) -> float:
        """Adhesive traction sigma_a = lambda0 (E0^2 dgamma0 / R)^(1/3)."""
        return self.lambda0 * self.alpha ** (1.0 / 3.0)

    @property
    def dmax(self) -> float:
        """Interaction range dgamma0 / sigma_a."""
        return self.alpha / self.sigma_a

    @property
    def indenter_speed(self) -> float:
        """Retraction velocity v_z = V_z beta^2 / (R tau)."""
        return self.Vz * self.beta**2

    @property
    def lambda_inf(self) -> float:
        """Instantaneous Maugis parameter lambda0 k^(2/3)."""
        return self.lambda0 * self.k ** (2.0 / 3.0)

    @property
    def chi_ve(self) -> float:
        """chi_ve = V_z lambda0^2 (paper Eq. 22)."""
        return theory.chi_ve(self.Vz, self.lambda0)

    @property
    def zone_width(self) -> float:
        """Relaxed cohesive-zone width w = pi E0 dmax / (4 sigma_a) = beta pi / (4 lambda0^2)."""
        return self.beta * theory.cohesive_width(self.lambda0)

    @property
    def dx(self) -> float:
        """Grid spacing L / nx."""
        return self.cell / self.numerics.nx

    def identity(self) -> str:
        """Hash of everything that determines the series (groups, units, numerics).

        A checkpoint stores it; a restart with a case of another identity is refused
        (:meth:`owns_identity` also knows the identities of earlier versions). The
        ``[output]`` settings are left out: they change what is written, not the solution.
        So is ``max_iterations``: the cap only ends a solve that has not converged, which
        stops the run (NonConvergenceError), so every step written is the same under any
        cap, and a run stopped by its cap continues with a higher one, as the error advises.
        """
        return self._identity(None)

    def owns_identity(self, identity: str) -> bool:
        """True when a stored identity is this case's: :meth:`identity`, or the identity
        of the versions that hashed the iteration cap too, under this case's cap or under
        their defaults (``DEFAULT_MAX_ITERATIONS``, and from commit 56eb886 on that plus the
        contact's nodes): a run of theirs stopped at its default cap continues under a
        higher one; one with a cap of its own continues under that cap."""
        if identity == self.identity():
            return True
        nx = self.numerics.nx
        caps = (self.numerics.max_iterations, DEFAULT_MAX_ITERATIONS,
                DEFAULT_MAX_ITERATIONS + contact_nodes(self, nx))
        return identity in {self._identity(cap) for cap in caps}

    def _identity(self, max_iterations) -> str:
        """The identity hash; with the iteration cap among the numerics when it is given
        (the identity of earlier versions)."""
        n = self.numerics
        numerics = [n.nx, n.dt, n.tolerance, n.max_iterations, n.solver, n.step_control,
                    n.dt_min, n.dt_max, n.edge_fraction, n.load_tolerance, n.time_tolerance,
                    n.equilibration_steps, n.accuracy]
        if max_iterations is None:
            del numerics[3]
        else:
            numerics[3] = max_iterations
        content = {"groups": [self.lambda0, self.k, self.Vz, self.depth, self.cell, self.alpha],
                   "units": [self.units.length, self.units.stress, self.units.time],
                   "numerics": numerics}
        if self.prony:  # (absent for the SLS: its identities predate Prony series)
            content["prony"] = [list(self.relaxation_moduli), list(self.relaxation_times)]
        if self.compliant:  # (likewise absent under displacement control)
            content["drive_stiffness"] = self.drive_stiffness
        if self.protocol:  # (and without a protocol)
            content["protocol"] = [[s.kind, s.target, s.rate] for s in self.protocol]
        return hashlib.sha256(json.dumps(content).encode()).hexdigest()[:16]

    def groups(self) -> dict:
        """Every derived dimensionless group, as printed at start and stored in the output."""
        groups = {"lambda0": self.lambda0, "lambda_inf": self.lambda_inf, "k": self.k,
                  "Vz": self.Vz, "chi_ve": self.chi_ve, "alpha": self.alpha,
                  "depth": self.depth, "cell": self.cell,
                  "zone_points": self.zone_width / self.dx}
        if self.prony:  # E_i / E0 and tau_i / tau_r; V_z and chi_ve are formed with tau_r
            groups.update(relaxation_moduli=list(self.relaxation_moduli),
                          relaxation_times=list(self.relaxation_times))
        if self.compliant:  # k_s / E0
            groups.update(drive_stiffness=self.drive_stiffness)
        return groups


def _finite_scales(where, scales):
    """CaseError unless each derived scale (name -> function) is finite and > 0."""
    for name, scale in scales.items():
        try:
            value = scale()
        except (OverflowError, ZeroDivisionError):  # ** overflowed; a divisor underflowed
            value = math.inf
        if not 0.0 < value < math.inf:
            raise CaseError(f"{where}: {name} = {value:g} is out of the floating-point range;"
                            " expected values whose derived scales are finite and > 0")


def _positive_list(value, section, key):
    """A tuple of finite numbers > 0 from a non-empty list (CaseError naming the key)."""
    if value is None:
        raise CaseError(f"[{section}] {key} is missing: a Prony series needs"
                        " relaxation_moduli and relaxation_times")
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) == 0 \
            or any(isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real)
                   or not 0.0 < as_float(v) < math.inf for v in value):
        raise CaseError(f"[{section}] {key} = {shown(value)}: expected a non-empty list of"
                        " finite numbers > 0")
    return tuple(float(v) for v in value)


def _prony_series(moduli, times, section):
    """(moduli, times) of a Prony series: two lists of numbers > 0 of one length."""
    moduli = _positive_list(moduli, section, "relaxation_moduli")
    times = _positive_list(times, section, "relaxation_times")
    if len(moduli) != len(times):
        raise CaseError(f"[{section}] relaxation_times = {shown(list(times))}: expected as"
                        f" many times as relaxation_moduli ({len(moduli)})")
    return moduli, times


def _stiffness(table, section):
    """drive_stiffness: a finite number > 0, or 0 (load control)."""
    value = table["drive_stiffness"]
    if isinstance(value, (int, float)) and not isinstance(value, bool) and value == 0:
        return 0.0
    try:
        return number(table, section, "drive_stiffness")
    except CaseError:
        raise CaseError(f"[{section}] drive_stiffness = {shown(value)}: expected a finite"
                        " number > 0 (a spring) or 0 (load control)") from None


def _python_numbers(value):
    """``value`` with every numpy scalar in it (in dicts, lists and tuples too) replaced by
    the Python number, bool or str it holds, and numpy arrays by lists."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):  # a list of numbers (relaxation_moduli, snapshot_times)
        return value.tolist()
    if isinstance(value, dict):
        return {key: _python_numbers(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_python_numbers(item) for item in value)
    return value


def _plain(value):
    """A value as TOML writes it (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value


def _resolve_output(out: dict, units: Units) -> Output:
    """``[output]`` keys (case units) -> :class:`Output` (internal units), defaults."""
    unknown_keys(out, "output", OUTPUT_KEYS)
    zero_load = out.get("snapshot_zero_load", False)
    if not isinstance(zero_load, bool):
        raise CaseError(f"[output] snapshot_zero_load = {shown(zero_load)}: expected true or false")
    return Output(
        snapshot_times=numbers_list(out, "output", "snapshot_times", units.time),
        snapshot_contact_widths=tuple(reversed(numbers_list(
            out, "output", "snapshot_contact_widths", units.length))),
        snapshot_zero_load=zero_load,
        progress_interval=(number(out, "output", "progress_interval")
                           if "progress_interval" in out else Output.progress_interval),
        checkpoint_interval=(number(out, "output", "checkpoint_interval")
                             if "checkpoint_interval" in out else Output.checkpoint_interval),
        checkpoint_steps=(integer(out, "output", "checkpoint_steps", 0)
                          if "checkpoint_steps" in out else 0))


def _groups_from_physical(t):
    """``[physical]`` SI values -> (the dimensionless groups, the units).

    A Prony series (relaxation_moduli in Pa, relaxation_times in s) stands in for
    modulus_instantaneous and relaxation_time: Einf = E0 + sum E_i and the reference time
    tau_r = sum E_i tau_i / sum E_i (docs/model.md, (M41)) is the case's unit of time.
    """
    prony = {}
    if any(key in t for key in PRONY_KEYS):
        for key in ("modulus_instantaneous", "relaxation_time"):
            if key in t:
                raise CaseError(f"[physical] {key}: a Prony series (relaxation_moduli,"
                                " relaxation_times) sets the moduli and the times; leave"
                                f" {key} out")
        moduli, times = _prony_series(t.get("relaxation_moduli"), t.get("relaxation_times"),
                                      "physical")
        t = dict(t)
        t["modulus_instantaneous"] = number(t, "physical", "modulus_relaxed") + math.fsum(moduli)
        t["relaxation_time"] = math.fsum(m * x for m, x in zip(moduli, times)) / math.fsum(moduli)
        e0, tau = t["modulus_relaxed"], t["relaxation_time"]
        prony = {"relaxation_moduli": tuple(m / e0 for m in moduli),
                 "relaxation_times": tuple(x / tau for x in times)}
    radius, e0, einf, tau, work, dmax, velocity, depth, cell = (
        number(t, "physical", key) for key in PHYSICAL_KEYS)
    if einf < e0:
        raise CaseError(f"[physical] modulus_instantaneous = {einf}: must be >= modulus_relaxed"
                        f" = {e0} (k = E0/Einf in (0, 1])")
    # extreme values over- or underflow in the groups: checked one by one
    formulas = {"maugis": lambda: (work**2 * radius / (e0**2 * dmax**3)) ** (1.0 / 3.0),
                "modulus_ratio": lambda: e0 / einf,
                "velocity": lambda: velocity * tau * radius
                / ((radius**2 * work / e0) ** (1.0 / 3.0))**2,
                "depth": lambda: depth / radius, "cell": lambda: cell / radius,
                "adhesion": lambda: work / (e0 * radius)}
    values = (radius, e0, einf, tau, work, dmax, velocity, depth, cell)
    _finite_scales("[physical] " + ", ".join(f"{key} = {value:g}" for key, value
                                             in zip(PHYSICAL_KEYS, values)), formulas)
    groups = {key: formula() for key, formula in formulas.items()}
    if prony:  # k from the series itself
        groups.update(prony, modulus_ratio=None)
    if "drive_stiffness" in t:  # Pa (N/m per m of cylinder and m of travel) -> E0
        groups["drive_stiffness"] = _stiffness(t, "physical") / e0
    return groups, Units(length=radius, stress=e0, time=tau)


def case_file_text(case: dict, numerics: dict | None = None, protocol=None) -> str:
    """A case file's text (docs/case-file.md) from its ``[case]`` groups, its ``[numerics]``
    keys and its ``[[protocol]]`` segments (a list of dicts), written by ``tomli_w``; numpy
    scalars are written as the numbers they hold, tuples as lists."""
    def plain(value):
        if isinstance(value, np.generic):
            return value.item()
        return [plain(v) for v in value] if isinstance(value, (list, tuple)) else value
    doc = {"case": {key: plain(value) for key, value in case.items()}}
    if numerics:
        doc["numerics"] = {key: plain(value) for key, value in numerics.items()}
    if protocol:
        doc["protocol"] = [dict(segment) for segment in protocol]
    return tomli_w.dumps(doc)


def parse_case(text: str) -> Case:
    """Validate a case file's text and build the :class:`Case` (raises :class:`CaseError`)."""
    try:
        doc = tomllib.loads(text)
    except RecursionError:
        raise CaseError("not valid TOML: arrays or inline tables nested too deeply") from None
    except ValueError as err:  # TOMLDecodeError, or int()'s limit of 4300 digits
        raise CaseError(f"not valid TOML: {err}") from None
    for name, value in doc.items():
        if name == "protocol":  # [[protocol]]: checked with the case (model/loading.py)
            continue
        if name not in SECTIONS:
            raise CaseError(f"[{quoted_key(name)}]: unknown section; accepted: [case] or"
                            " [physical], [numerics], [output], [[protocol]]")
        if not isinstance(value, dict):
            raise CaseError(f"{name} = {shown(value)}: expected a section [{name}]")
    if ("case" in doc) == ("physical" in doc):
        raise CaseError("exactly one of [case] (dimensionless groups) or [physical] (SI values)"
                        " is required")
    form = "case" if "case" in doc else "physical"
    unknown_keys(doc[form], form, SECTIONS[form])
    if form == "case":
        table = doc["case"]
        prony = any(key in table for key in PRONY_KEYS)
        groups = {key: number(table, "case", key) for key in CASE_KEYS
                  if not (prony and key == "modulus_ratio")}
        if prony:
            groups.update(modulus_ratio=table.get("modulus_ratio"),
                          relaxation_moduli=table.get("relaxation_moduli"),
                          relaxation_times=table.get("relaxation_times"))
        if "drive_stiffness" in table:
            groups["drive_stiffness"] = _stiffness(table, "case")
        units = Units()
    else:
        groups, units = _groups_from_physical(doc["physical"])
    protocol = doc.get("protocol", ())
    if not isinstance(protocol, list) or not protocol:
        if "protocol" in doc:
            raise CaseError(f"protocol = {shown(protocol)}: expected [[protocol]] tables"
                            " (approach, dwell or retract)")
    return Case(**groups, numerics=doc.get("numerics", {}), output=doc.get("output", {}),
                units=units, text=text, form=form, protocol=protocol)


def load_case(path) -> Case:
    """Read and validate a case file (raises :class:`CaseError`, also for unreadable files)."""
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
    except OSError as err:
        raise CaseError(f"cannot read case file: {err.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise CaseError("case file is not UTF-8 text") from None
    return parse_case(text)
