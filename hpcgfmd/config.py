"""Case files: TOML text -> a validated, frozen :class:`Case`.

Two equivalent forms, exactly one per file (physics.md, "Scales and dimensionless groups"):

``[case]`` dimensionless groups in units R = E0 = tau = 1:
    maugis (lambda0), modulus_ratio (k = E0/Einf, in (0, 1]), velocity (V_z),
    depth (h0/R), cell (L/R), adhesion (alpha = dgamma0 / (E0 R)).
``[physical]`` SI values:
    radius, modulus_relaxed, modulus_instantaneous (plane-strain moduli E*), relaxation_time,
    work_of_adhesion, interaction_range, velocity, depth, cell_length.

``[numerics]`` (optional): nx, dt, tolerance, max_iterations; solver ("cg", the default, or
"paper": the paper's damped Verlet GFMD with equilibration_steps pseudo steps per step);
step_control ("adaptive", the default: error-controlled steps starting from dt, within
[dt_min, dt_max], with edge_fraction and load_tolerance, see ``hpcgfmd.stepping``; or
"fixed": every step dt).
``[output]`` (optional): snapshot_times, snapshot_contact_widths, snapshot_zero_load,
progress_interval, checkpoint_interval (wall seconds), checkpoint_steps. Times and lengths there are in the case's units (tau and R with ``[case]``,
seconds and metres with ``[physical]``).

Every problem is reported as a :class:`CaseError` naming the key, the value and what is
accepted; the command line turns it into one line and exit status 2.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from dataclasses import dataclass, field

from . import theory

# Cohesive-zone resolution w/dx (w: relaxed zone width pi E0 dmax / (4 sigma_a)). Measured
# (README, issue note): elastic lambda = 3.5 pull-off 2.3 % / 0.5 % / 0.1 % off at
# w/dx = 1.5 / 3 / 6; the paper's default case (lambda0 = 7, V_z = 0.45) 0.2 % off at 1.9.
MIN_ZONE_POINTS = 1.0      # below this nx is rejected
TARGET_ZONE_POINTS = 3.0   # the automatic nx is the smallest power of two reaching this
# The geometric contact width sqrt(2 R h0) bounds a_c; with L >= 6 sqrt(2 R h0) the periodic
# image correction pi^2 a^2 / (6 L^2) to the load stays below 5 %.
MIN_CELL_PER_CONTACT = 6.0
DEFAULT_STEP_PER_RANGE = 0.25  # default dt: the indenter moves this fraction of dmax per step
DEFAULT_TOLERANCE = 1e-6
DEFAULT_MAX_ITERATIONS = 5000
# Adaptive steps (hpcgfmd.stepping): contact-edge motion per step in relaxed cohesive-zone
# widths, load deviation from linear extrapolation in load scales, bounds of the step.
DEFAULT_EDGE_FRACTION = 0.5
DEFAULT_LOAD_TOLERANCE = 1e-2
DT_MIN_PER_DEFAULT = 1.0 / 64.0     # dt_min: this fraction of the default (or given) dt
FIRST_STEP_PER_DEFAULT = 1.0 / 16.0  # adaptive: the first step, doubling while errors allow
DT_MAX_DEPTH_FRACTION = 0.02        # dt_max: the indenter rises by this fraction of h0,
DT_MAX_RELAXATION = 0.25            # ... and at most this fraction of tau: the time error is
# first order in dt/tau where the edge creeps (slowest paper case, V_z = 0.045, 2^15:
# pull-off 1.2 % off with steps up to 33 tau, 0.6 % at fixed 0.79 tau, ~0.3 % at 0.25 tau)
PAPER_EQUILIBRATION_PER_ROOT_N = 1024  # the paper authors' code: 256 * 4 * sqrt(nx) steps
SOLVERS = ("cg", "paper")
STEP_CONTROLS = ("adaptive", "fixed")
MIN_TOLERANCE = 1e-13      # the residual's round-off floor (max norm relative to sigma_a)
BYTES_PER_POINT = 320      # about 40 float64 work arrays per grid point (measured layout)


class CaseError(ValueError):
    """A rejected case file: ``str(error)`` is the one-line message."""


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
class Numerics:
    """Discretisation: grid points, time steps (internal units of tau), solver and its tolerance.

    With ``step_control = "adaptive"`` ``dt`` is the first step; ``edge_fraction`` (of the
    relaxed cohesive-zone width) and ``load_tolerance`` (in load scales) are the error
    targets of :mod:`hpcgfmd.stepping`. ``equilibration_steps`` is the paper solver's fixed
    number of pseudo time steps per time step.
    """

    nx: int
    nx_automatic: bool
    dt: float
    tolerance: float
    max_iterations: int
    solver: str = "cg"
    step_control: str = "adaptive"
    dt_min: float = 0.0
    dt_max: float = math.inf
    edge_fraction: float = DEFAULT_EDGE_FRACTION
    load_tolerance: float = DEFAULT_LOAD_TOLERANCE
    equilibration_steps: int = 0


@dataclass(frozen=True)
class Output:
    """What is written besides the series (internal units R, tau)."""

    snapshot_times: tuple = ()
    snapshot_contact_widths: tuple = ()
    snapshot_zero_load: bool = False
    progress_interval: float = 10.0
    checkpoint_interval: float = 600.0  # wall-clock seconds between checkpoints
    checkpoint_steps: int = 0           # also every this many steps (0: only by wall time)


@dataclass(frozen=True)
class Case:
    """One retraction case in internal units R = E0 = tau = 1.

    Attributes
    ----------
    lambda0, k, Vz, depth, cell, alpha : float
        Maugis parameter, E0/Einf, V_z, h0/R, L/R, dgamma0/(E0 R) (all dimensionless).
    numerics, output : Numerics, Output
    units : Units
        Scales back to the case's own units for the output file.
    text : str
        The case file as given (stored in the output).
    """

    lambda0: float
    k: float
    Vz: float
    depth: float
    cell: float
    alpha: float
    numerics: Numerics
    output: Output = field(default_factory=Output)
    units: Units = field(default_factory=Units)
    text: str = ""
    form: str = "case"

    def cell_key(self) -> str:
        """The case file's name for the cell length ([case] cell or [physical] cell_length)."""
        return "[case] cell" if self.form == "case" else "[physical] cell_length"

    # Derived quantities (physics.md, Appendix C corrected), internal units.
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
    def velocity(self) -> float:
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
        return self.cell / self.numerics.nx

    def identity(self) -> str:
        """Hash of everything that determines the series (groups, units, numerics).

        A checkpoint stores it; a restart with a case of another identity is refused. The
        ``[output]`` settings are left out: they change what is written, not the solution.
        """
        content = {"groups": [self.lambda0, self.k, self.Vz, self.depth, self.cell, self.alpha],
                   "units": [self.units.length, self.units.stress, self.units.time],
                   "numerics": [self.numerics.nx, self.numerics.dt, self.numerics.tolerance,
                                self.numerics.max_iterations, self.numerics.solver,
                                self.numerics.step_control, self.numerics.dt_min,
                                self.numerics.dt_max, self.numerics.edge_fraction,
                                self.numerics.load_tolerance,
                                self.numerics.equilibration_steps]}
        return hashlib.sha256(json.dumps(content).encode()).hexdigest()[:16]

    def groups(self) -> dict:
        """Every derived dimensionless group, as printed at start and stored in the output."""
        return {"lambda0": self.lambda0, "lambda_inf": self.lambda_inf, "k": self.k,
                "Vz": self.Vz, "chi_ve": self.chi_ve, "alpha": self.alpha,
                "depth": self.depth, "cell": self.cell,
                "zone_points": self.zone_width / self.dx}


CASE_KEYS = ("maugis", "modulus_ratio", "velocity", "depth", "cell", "adhesion")
PHYSICAL_KEYS = ("radius", "modulus_relaxed", "modulus_instantaneous", "relaxation_time",
                 "work_of_adhesion", "interaction_range", "velocity", "depth", "cell_length")
NUMERICS_KEYS = ("nx", "dt", "tolerance", "max_iterations", "solver", "step_control", "dt_min",
                 "dt_max", "edge_fraction", "load_tolerance", "equilibration_steps")
OUTPUT_KEYS = ("snapshot_times", "snapshot_contact_widths", "snapshot_zero_load",
               "progress_interval", "checkpoint_interval", "checkpoint_steps")


def _fmt(value) -> str:
    return repr(value) if isinstance(value, str) else str(value).lower() if isinstance(
        value, bool) else str(value)


def _number(table, section, key, *, positive=True):
    if key not in table:
        raise CaseError(f"[{section}] {key} is missing: a number > 0 is required")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise CaseError(f"[{section}] {key} = {_fmt(value)}: expected a number")
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0.0):
        raise CaseError(f"[{section}] {key} = {_fmt(value)}: expected a finite number > 0")
    return value


def _unknown(table, section, allowed):
    for key in table:
        if key not in allowed:
            raise CaseError(f"[{section}] {key}: unknown key; accepted: {', '.join(allowed)}")


def _groups_from_physical(t):
    radius = _number(t, "physical", "radius")
    e0 = _number(t, "physical", "modulus_relaxed")
    einf = _number(t, "physical", "modulus_instantaneous")
    tau = _number(t, "physical", "relaxation_time")
    work = _number(t, "physical", "work_of_adhesion")
    dmax = _number(t, "physical", "interaction_range")
    velocity = _number(t, "physical", "velocity")
    depth = _number(t, "physical", "depth")
    cell = _number(t, "physical", "cell_length")
    if einf < e0:
        raise CaseError(f"[physical] modulus_instantaneous = {einf}: must be >= modulus_relaxed"
                        f" = {e0} (k = E0/Einf in (0, 1])")
    beta = (radius**2 * work / e0) ** (1.0 / 3.0)
    groups = {"lambda0": (work**2 * radius / (e0**2 * dmax**3)) ** (1.0 / 3.0),
              "k": e0 / einf, "Vz": velocity * tau * radius / beta**2,
              "depth": depth / radius, "cell": cell / radius,
              "alpha": work / (e0 * radius)}
    return groups, Units(length=radius, stress=e0, time=tau)


def _groups_from_case(t):
    k = _number(t, "case", "modulus_ratio")
    if k > 1.0:
        raise CaseError(f"[case] modulus_ratio = {k}: expected k = E0/Einf in (0, 1]"
                        " (1 is the elastic solid)")
    return {"lambda0": _number(t, "case", "maugis"), "k": k,
            "Vz": _number(t, "case", "velocity"), "depth": _number(t, "case", "depth"),
            "cell": _number(t, "case", "cell"), "alpha": _number(t, "case", "adhesion")}, Units()


def _numbers_list(table, section, key, units_scale):
    value = table.get(key, [])
    if not isinstance(value, list) or any(isinstance(v, bool) or not isinstance(v, (int, float))
                                          or not math.isfinite(v) or v < 0 for v in value):
        raise CaseError(f"[{section}] {key} = {_fmt(value)}: expected a list of numbers >= 0")
    return tuple(sorted(float(v) / units_scale for v in value))


def parse_case(text: str) -> Case:
    """Validate a case file's text and build the :class:`Case` (raises :class:`CaseError`)."""
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise CaseError(f"not valid TOML: {err}") from None
    sections = ("case", "physical", "numerics", "output")
    for name, value in doc.items():
        if name not in sections:
            raise CaseError(f"[{name}]: unknown section; accepted: [case] or [physical],"
                            " [numerics], [output]")
        if not isinstance(value, dict):
            raise CaseError(f"{name} = {_fmt(value)}: expected a section [{name}]")
    if ("case" in doc) == ("physical" in doc):
        raise CaseError("exactly one of [case] (dimensionless groups) or [physical] (SI values)"
                        " is required")
    if "case" in doc:
        _unknown(doc["case"], "case", CASE_KEYS)
        groups, units = _groups_from_case(doc["case"])
        form = "case"
    else:
        _unknown(doc["physical"], "physical", PHYSICAL_KEYS)
        groups, units = _groups_from_physical(doc["physical"])
        form = "physical"
    cell_key = "cell" if form == "case" else "cell_length"
    min_cell = MIN_CELL_PER_CONTACT * math.sqrt(2.0 * groups["depth"])
    if groups["cell"] < min_cell:
        raise CaseError(f"[{form}] {cell_key} = {doc[form][cell_key]}: too small for the contact;"
                        f" need L >= {MIN_CELL_PER_CONTACT:g} sqrt(2 R h0) ="
                        f" {min_cell * units.length:.4g}")

    num = doc.get("numerics", {})
    _unknown(num, "numerics", NUMERICS_KEYS)
    zone = groups["alpha"] ** (1.0 / 3.0) * theory.cohesive_width(groups["lambda0"])
    if "nx" in num:
        nx = num["nx"]
        if isinstance(nx, bool) or not isinstance(nx, int) or nx < 64 or nx % 2:
            raise CaseError(f"[numerics] nx = {_fmt(nx)}: expected an even integer >= 64")
        points = zone / (groups["cell"] / nx)
        if points < MIN_ZONE_POINTS:
            need = 2 ** math.ceil(math.log2(MIN_ZONE_POINTS * groups["cell"] / zone))
            raise CaseError(f"[numerics] nx = {nx}: resolves the cohesive zone with w/dx ="
                            f" {points:.3g} points; at least {MIN_ZONE_POINTS:g} is needed"
                            f" (nx >= {need}; w/dx >= {TARGET_ZONE_POINTS:g} for 1 % accuracy)")
        automatic = False
    else:
        nx = 2 ** max(6, math.ceil(math.log2(TARGET_ZONE_POINTS * groups["cell"] / zone)))
        automatic = True
    memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    if nx * BYTES_PER_POINT > memory:
        raise CaseError(f"[numerics] nx = {nx}{' (automatic)' if automatic else ''}: needs about"
                        f" {nx * BYTES_PER_POINT / 2**30:.1f} GiB, more than the"
                        f" {memory / 2**30:.1f} GiB of this machine")
    velocity = groups["Vz"] * groups["alpha"] ** (2.0 / 3.0)
    dmax = groups["alpha"] ** (2.0 / 3.0) / groups["lambda0"]
    solver = _choice(num, "numerics", "solver", SOLVERS)
    step_control = _choice(num, "numerics", "step_control", STEP_CONTROLS)
    # adaptive steps start short: the retraction starts with the steepest load change
    dt = (_number(num, "numerics", "dt") / units.time if "dt" in num
          else DEFAULT_STEP_PER_RANGE * dmax / velocity
          * (1.0 if step_control == "fixed" else FIRST_STEP_PER_DEFAULT))
    dt_min = (_number(num, "numerics", "dt_min") / units.time if "dt_min" in num
              else DT_MIN_PER_DEFAULT * min(dt, DEFAULT_STEP_PER_RANGE * dmax / velocity))
    dt_max = (_number(num, "numerics", "dt_max") / units.time if "dt_max" in num
              else max(min(DT_MAX_DEPTH_FRACTION * groups["depth"] / velocity,
                           DT_MAX_RELAXATION), dt))
    if dt_min > dt_max:
        raise CaseError(f"[numerics] dt_min = {dt_min * units.time:g}: must not exceed dt_max ="
                        f" {dt_max * units.time:g}")
    edge_fraction = (_number(num, "numerics", "edge_fraction") if "edge_fraction" in num
                     else DEFAULT_EDGE_FRACTION)
    load_tolerance = (_number(num, "numerics", "load_tolerance") if "load_tolerance" in num
                      else DEFAULT_LOAD_TOLERANCE)
    if "equilibration_steps" in num:
        equilibration = num["equilibration_steps"]
        if isinstance(equilibration, bool) or not isinstance(equilibration, int) or equilibration < 1:
            raise CaseError(f"[numerics] equilibration_steps = {_fmt(equilibration)}: expected"
                            " an integer >= 1")
    else:
        equilibration = round(PAPER_EQUILIBRATION_PER_ROOT_N * math.sqrt(nx))
    tolerance = _number(num, "numerics", "tolerance") if "tolerance" in num else DEFAULT_TOLERANCE
    if not MIN_TOLERANCE <= tolerance < 1e-2:
        raise CaseError(f"[numerics] tolerance = {tolerance}: expected a number in"
                        f" [{MIN_TOLERANCE:g}, 0.01)")
    max_it = num.get("max_iterations", DEFAULT_MAX_ITERATIONS)
    if isinstance(max_it, bool) or not isinstance(max_it, int) or max_it < 1:
        raise CaseError(f"[numerics] max_iterations = {_fmt(max_it)}: expected an integer >= 1")

    out = doc.get("output", {})
    _unknown(out, "output", OUTPUT_KEYS)
    zero_load = out.get("snapshot_zero_load", False)
    if not isinstance(zero_load, bool):
        raise CaseError(f"[output] snapshot_zero_load = {_fmt(zero_load)}: expected true or false")
    output = Output(
        snapshot_times=_numbers_list(out, "output", "snapshot_times", units.time),
        snapshot_contact_widths=tuple(reversed(_numbers_list(
            out, "output", "snapshot_contact_widths", units.length))),
        snapshot_zero_load=zero_load,
        progress_interval=(_number(out, "output", "progress_interval")
                           if "progress_interval" in out else 10.0),
        checkpoint_interval=(_number(out, "output", "checkpoint_interval")
                             if "checkpoint_interval" in out else Output.checkpoint_interval),
        checkpoint_steps=_count(out, "output", "checkpoint_steps"))
    return Case(numerics=Numerics(nx=nx, nx_automatic=automatic, dt=dt, tolerance=tolerance,
                                  max_iterations=max_it, solver=solver,
                                  step_control=step_control, dt_min=dt_min, dt_max=dt_max,
                                  edge_fraction=edge_fraction, load_tolerance=load_tolerance,
                                  equilibration_steps=equilibration),
                output=output, units=units, text=text, form=form, **groups)


def _choice(table, section, key, accepted):
    value = table.get(key, accepted[0])
    if value not in accepted:
        raise CaseError(f"[{section}] {key} = {_fmt(value)}: expected one of"
                        f" {', '.join(repr(a) for a in accepted)}")
    return value


def _count(table, section, key):
    value = table.get(key, 0)
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise CaseError(f"[{section}] {key} = {_fmt(value)}: expected an integer >= 0")
    return value


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
