"""A case: the dimensionless groups of one retraction, its protocol, numerics and output,
validated on construction.

Two equivalent forms of input, exactly one per case (docs/model.md, "Scales and dimensionless
groups"; docs/case-file.md lists every key with its default): ``[case]``, the groups in units
R = E0 = tau = 1 (maugis, modulus_ratio, velocity, depth, cell, adhesion; a Prony series'
relaxation_moduli and relaxation_times in place of modulus_ratio), or ``[physical]``, SI
values (:mod:`.units`). ``[[protocol]]`` (optional) lists the loading segments; ``[numerics]``
and ``[output]`` are optional, their times and lengths in the case's units.

From Python, ``Case(maugis=7.0, modulus_ratio=0.1, velocity=0.45, depth=0.1, cell=10.0,
adhesion=5e-5, numerics={"nx": 4096})`` validates exactly as the case file would (the checks
are :mod:`.groups`, :mod:`.numerics`, :mod:`.output` and :mod:`.protocol`); every problem is
a :class:`~hpcgfmd.errors.CaseError` naming the key, the value and what is accepted.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

from ..errors import CaseError
from ..model.loading import Segment, paper_protocol
from .files import case_arguments, read_case_file
from .groups import (
    DRIVE_KEYS,
    GEOMETRY_KEYS,
    GROUP_KEYS,
    PRONY_KEYS,
    Groups,
    checked_groups,
    python_numbers,
)
from .identity import case_identity
from .keys import shown
from .numerics import Numerics, resolve_numerics
from .output import Output, resolve_output
from .protocol import parse_protocol
from .text import case_file_text
from .units import Units


@dataclass(frozen=True, init=False)
class Case(Groups):
    """One retraction case, validated: its groups (:class:`~.groups.Groups`, under their
    case-file names), protocol, numerics and output, in internal units.

    Parameters
    ----------
    maugis, modulus_ratio, velocity, depth, cell, adhesion : float
        lambda0, k = E0/Einf in (0, 1], V_z, h0/R, L/R and alpha = dgamma0/(E0 R), all
        dimensionless (docs/model.md, "Scales and dimensionless groups"). With a Prony series
        ``modulus_ratio`` may be None: it is 1 / (1 + sum of relaxation_moduli).
    numerics, output : dict or Numerics / Output, optional
        The ``[numerics]`` and ``[output]`` keys (in the case's units), or resolved objects;
        left out, every default applies.
    units : Units
        The case's units (``[physical]`` input); the internal units are R = E0 = tau = 1.
    text : str
        The case file (stored in the output); made from the keys when not given.
    form : {"case", "physical"}
        Which section the case came from (error messages name its keys).
    relaxation_moduli, relaxation_times : sequence of float, optional
        A generalized Maxwell (Prony) substrate (docs/model.md, (M38)-(M41)): E_i / E0 and
        tau_i / tau_r of each branch (the times' modulus-weighted mean is 1).
    drive_stiffness : float, optional
        k_s / E0 >= 0 of the spring between the drive and the indenter (docs/model.md,
        "Protocol"): inf (the default) is displacement control, 0 load control.
    geometry : {"cylinder", "sphere"}, optional
        The indenter: the paper's cylinder on a line (the default) or a sphere on a square
        surface, whose groups are the sphere's (docs/model.md, "The sphere").
    protocol : list of dict or tuple of Segment, optional
        The ``[[protocol]]`` tables (case units) or resolved segments; empty: the paper's
        preload and retraction.

    Raises
    ------
    CaseError
        A value out of range, a cell too small for the contact, an unresolved grid.
    """

    numerics: Numerics
    output: Output
    protocol: tuple
    text: str

    def __init__(
        self,
        maugis: float,
        modulus_ratio: float | None,
        velocity: float,
        depth: float,
        cell: float,
        adhesion: float,
        numerics: Numerics | Mapping | None = None,
        output: Output | Mapping | None = None,
        units: Units | None = None,
        text: str = "",
        form: str = "case",
        relaxation_moduli: Sequence[float] = (),
        relaxation_times: Sequence[float] = (),
        drive_stiffness: float = math.inf,
        protocol: Sequence = (),
        geometry: str = "cylinder",
    ) -> None:
        raw = python_numbers(
            {
                "maugis": maugis,
                "modulus_ratio": modulus_ratio,
                "velocity": velocity,
                "depth": depth,
                "cell": cell,
                "adhesion": adhesion,
                "relaxation_moduli": relaxation_moduli,
                "relaxation_times": relaxation_times,
                "drive_stiffness": drive_stiffness,
                "geometry": geometry,
            }
        )
        numerics, output, protocol = (python_numbers(v) for v in (numerics, output, protocol))
        for name, value, resolved in (("numerics", numerics, Numerics), ("output", output, Output)):
            if not (value is None or isinstance(value, (Mapping, resolved))):
                raise CaseError(
                    f"{name} = {shown(value)}: expected a dict of the [{name}]"
                    " keys (or None for the defaults)"
                )
        units = Units() if units is None else units
        groups = checked_groups(raw, units, form)
        resolved = {
            **{key: getattr(groups, key) for key in Groups.__dataclass_fields__},
            "protocol": _segments(groups, protocol),
            "numerics": (
                numerics
                if isinstance(numerics, Numerics)
                else resolve_numerics(groups, numerics or {})
            ),
            "output": (
                output
                if isinstance(output, Output)
                else resolve_output(output or {}, units.time, units.length)
            ),
            "text": text or _keyword_text(groups, numerics, output, protocol),
        }
        for name, value in resolved.items():  # the frozen dataclass's construction
            object.__setattr__(self, name, value)

    @classmethod
    def from_toml(cls, source) -> Case:
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
            raise CaseError(
                f"case = {shown(source)}: expected a Case, a case file's path"
                " (str or os.PathLike) or its TOML text"
            )
        return parse_case(source)

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
    def dx(self) -> float:
        """Grid spacing L / nx."""
        return self.cell / self.numerics.nx

    @property
    def load_unit(self) -> float:
        """The case's unit of the load: E0 R per unit length of a cylinder, E0 R^2 (a force)
        for a sphere (the units of :class:`~.units.Units`)."""
        return self.units.force if self.sphere else self.units.load

    def identity(self) -> str:
        """The hash of everything that determines the series (:mod:`.identity`)."""
        return case_identity(self)

    def groups(self) -> dict:
        """Every derived dimensionless group under the paper's symbols, as printed at start
        and stored in the output file."""
        groups = {
            "lambda0": self.maugis,
            "lambda_inf": self.lambda_inf,
            "k": self.modulus_ratio,
            "Vz": self.velocity,
            "chi_ve": self.chi_ve,
            "alpha": self.adhesion,
            "depth": self.depth,
            "cell": self.cell,
            "zone_points": self.zone_width / self.dx,
        }
        if self.relaxation_moduli:  # E_i / E0 and tau_i / tau_r; V_z, chi_ve with tau_r
            groups.update(
                relaxation_moduli=list(self.relaxation_moduli),
                relaxation_times=list(self.relaxation_times),
            )
        if self.compliant:  # k_s / E0
            groups.update(drive_stiffness=self.drive_stiffness)
        return groups


def _segments(groups: Groups, protocol) -> tuple:
    """``[[protocol]]`` tables (case units) -> segments (internal units), checked."""
    if groups.load_control and not protocol:
        raise CaseError(
            f"[{groups.form}] drive_stiffness = 0: load control needs a"
            " [[protocol]] whose segments give a load_rate"
        )
    if not protocol or all(isinstance(s, Segment) for s in protocol):
        return tuple(protocol or ())
    units = groups.units
    if groups.form != "case":
        scale = units.time / units.length  # m/s
    elif groups.sphere:
        scale = groups.depth_scale  # V_z units: the depth scale per tau (M49)
    else:
        scale = groups.adhesion ** (2.0 / 3.0)  # V_z units: beta^2 (M19)
    return parse_protocol(
        list(protocol),
        length=units.length,
        time=units.time,
        load=units.load,
        speed=groups.indenter_speed,
        speed_scale=scale,
        load_control=groups.load_control,
    )


def _keyword_text(groups: Groups, numerics, output, protocol) -> str:
    """The case file that gives a case built from keywords."""
    keys = (
        GROUP_KEYS
        if not groups.relaxation_moduli
        else tuple(key for key in GROUP_KEYS if key != "modulus_ratio") + PRONY_KEYS
    )
    if groups.compliant:
        keys += DRIVE_KEYS
    if groups.sphere:
        keys = GEOMETRY_KEYS + keys
    return case_file_text(
        {key: getattr(groups, key) for key in keys},
        numerics if isinstance(numerics, Mapping) else None,
        protocol if isinstance(protocol, list) else None,
        output if isinstance(output, Mapping) else None,
    )


def parse_case(text: str) -> Case:
    """Validate a case file's text and build the :class:`Case` (raises :class:`CaseError`)."""
    return Case(**case_arguments(text))


def load_case(path) -> Case:
    """Read and validate a case file (raises :class:`CaseError`, also for unreadable files)."""
    return parse_case(read_case_file(path))
