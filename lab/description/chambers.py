"""Fluid chambers of a robot description: the dataclass and the ``[[chambers]]`` reader.

A chamber is a closed cavity of the body, driven by its gauge pressure (Pa) or by the fluid
volume pumped into it (m^3). In a cylinder or tapered body the description gives the cavity
as a cylinder parallel to the axis (angle, offset, radius, start, end) and the body is meshed
by gmsh with the cavity left out (:mod:`lab.description.chambered`); in a mesh body it names
the physical surface of the file that bounds it. :func:`parse_chambers` checks every field
and the geometry: the cavity inside the body with a wall of at least one element, no two
cavities overlapping, bounds plausible for their unit, a volume range that cannot collapse
the cavity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Chamber:
    """A fluid chamber: a closed cavity in the body driven by its gauge pressure or by the
    fluid volume pumped into it.

    Parameters
    ----------
    name : str
        Its name (unique among the cables and chambers).
    control : str
        ``"pressure"`` (the input is the gauge pressure, Pa) or ``"volume"`` (the fluid
        volume injected since rest, m^3).
    pressure_max_pa, pressure_min_pa : float or None
        A pressure chamber's input range, Pa (the minimum 0 unless vacuum is allowed).
    volume_max_m3, volume_min_m3 : float or None
        A volume chamber's input range, m^3 (the minimum 0 unless fluid may be drawn out).
    fluid_bulk_modulus_pa : float or None
        A volume chamber's fluid bulk modulus, Pa (water's by default).
    angle_deg, offset_m, radius_m, start_m, end_m : float or None
        A cylinder or tapered body's cavity: a cylinder parallel to the axis, its centre at
        ``angle_deg`` about +x and ``offset_m`` from the axis, from x = ``start_m`` to
        ``end_m`` (m).
    surface_group : str or None
        A mesh body's cavity: the physical surface of the file that bounds it.
    """

    name: str
    control: str = "pressure"
    pressure_max_pa: float | None = None
    pressure_min_pa: float | None = None
    volume_max_m3: float | None = None
    volume_min_m3: float | None = None
    fluid_bulk_modulus_pa: float | None = None
    angle_deg: float | None = None
    offset_m: float | None = None
    radius_m: float | None = None
    start_m: float | None = None
    end_m: float | None = None
    surface_group: str | None = None

    @property
    def unit(self) -> str:
        """The input's unit: ``"Pa"`` or ``"m^3"``."""
        return "Pa" if self.control == "pressure" else "m^3"

    @property
    def bounds(self) -> tuple[float, float]:
        """The input's range ``(low, high)`` in :attr:`unit`."""
        if self.control == "pressure":
            return float(self.pressure_min_pa or 0.0), float(self.pressure_max_pa)
        return float(self.volume_min_m3 or 0.0), float(self.volume_max_m3)


#: A gauge pressure bound outside this range (Pa) is taken for a unit error (kPa or bar
#: written as Pa, or MPa): soft fluidic actuators run between a few kPa and a few bar.
PRESSURE_PLAUSIBLE_PA = (100.0, 1e7)
#: Gauge pressure cannot go below vacuum, Pa.
VACUUM_PA = -101_325.0
#: A volume bound outside this range (m^3) is taken for a unit error (mL written as m^3).
VOLUME_PLAUSIBLE_M3 = (1e-12, 1e-2)
#: A fluid bulk modulus outside this range (Pa) is implausible (air near 1 bar to stiff oils).
BULK_PLAUSIBLE_PA = (1e5, 1e10)
#: Water's bulk modulus, Pa: a volume chamber's fluid by default.
WATER_BULK_MODULUS_PA = 2.2e9
_GEOMETRY = ("angle_deg", "offset_m", "radius_m", "start_m", "end_m")


def _fields():
    from lab.description.fields import ROBOT_FIELDS, check_fields, get, refuse_unused

    return ROBOT_FIELDS, check_fields, get, refuse_unused


def parse_chamber(entry: dict, i: int, body_kind: str) -> Chamber:
    """One ``[[chambers]]`` entry, its fields checked one by one (not yet against the body).

    Parameters
    ----------
    entry : dict
        The table.
    i : int
        Its index (for the errors' ``chambers[i]``).
    body_kind : str
        ``"cylinder"``, ``"tapered"`` or ``"mesh"``.

    Returns
    -------
    Chamber
    """
    from lab.description.robot import DescriptionError

    ROBOT_FIELDS, check_fields, get, refuse_unused = _fields()
    where = f"chambers[{i}]"
    check_fields(entry, ROBOT_FIELDS["chambers"], where)
    name = get(entry, "name", where, str)
    control = entry.get("control", "pressure")
    if control not in ("pressure", "volume"):
        raise DescriptionError(f'field \'{where}.control\' must be "pressure" or "volume", got {control!r}')
    values = {}
    if control == "pressure":
        refuse_unused(
            entry, ("volume_max_m3", "volume_min_m3", "fluid_bulk_modulus_pa"), where, 'by control = "pressure"'
        )
        high = get(entry, "pressure_max_pa", where, positive=True)
        _plausible(high, PRESSURE_PLAUSIBLE_PA, f"{where}.pressure_max_pa", "Pa", "a gauge pressure; is it in pascals?")
        low = get(entry, "pressure_min_pa", where) if "pressure_min_pa" in entry else 0.0
        if not VACUUM_PA <= low < high:
            raise DescriptionError(
                f"field '{where}.pressure_min_pa' must be at least vacuum ({VACUUM_PA:.0f} Pa gauge) and below "
                f"pressure_max_pa ({high} Pa), got {low}"
            )
        values = {"pressure_max_pa": high, "pressure_min_pa": low if "pressure_min_pa" in entry else None}
    else:
        refuse_unused(entry, ("pressure_max_pa", "pressure_min_pa"), where, 'by control = "volume"')
        high = get(entry, "volume_max_m3", where, positive=True)
        _plausible(
            high, VOLUME_PLAUSIBLE_M3, f"{where}.volume_max_m3", "m^3", "a chamber's fluid volume; is it in m^3?"
        )
        low = get(entry, "volume_min_m3", where) if "volume_min_m3" in entry else 0.0
        if not -VOLUME_PLAUSIBLE_M3[1] < low < high:
            raise DescriptionError(f"field '{where}.volume_min_m3' must be below volume_max_m3 ({high} m^3), got {low}")
        bulk = get(entry, "fluid_bulk_modulus_pa", where, positive=True) if "fluid_bulk_modulus_pa" in entry else None
        if bulk is not None:
            _plausible(bulk, BULK_PLAUSIBLE_PA, f"{where}.fluid_bulk_modulus_pa", "Pa", "a fluid's bulk modulus")
        values = {
            "volume_max_m3": high,
            "volume_min_m3": low if "volume_min_m3" in entry else None,
            "fluid_bulk_modulus_pa": bulk,
        }
    if body_kind == "mesh":
        refuse_unused(entry, _GEOMETRY, where, 'by body.shape = "mesh" (give surface_group, the cavity\'s surface)')
        return Chamber(name, control, surface_group=get(entry, "surface_group", where, str), **values)
    refuse_unused(entry, ("surface_group",), where, f'by body.shape = "{body_kind}" (it takes {", ".join(_GEOMETRY)})')
    geom = {k: get(entry, k, where) for k in _GEOMETRY}
    for k in ("radius_m", "start_m", "end_m"):
        if geom[k] <= 0:
            raise DescriptionError(f"field '{where}.{k}' must be positive, got {geom[k]}")
    if geom["offset_m"] < 0:
        raise DescriptionError(f"field '{where}.offset_m' must be >= 0, got {geom['offset_m']}")
    if geom["end_m"] <= geom["start_m"]:
        raise DescriptionError(
            f"field '{where}.end_m' ({geom['end_m']} m) must be beyond start_m ({geom['start_m']} m)"
        )
    return Chamber(name, control, **values, **geom)


def _plausible(value, bounds, field, unit, what):
    from lab.description.robot import DescriptionError

    if not bounds[0] <= value <= bounds[1]:
        raise DescriptionError(
            f"field '{field}' = {value} {unit} is implausible for {what} "
            f"(expected {bounds[0]:g} to {bounds[1]:g} {unit})"
        )


def check_chamber_geometry(chambers, length_m: float, radius_at, size_m: float) -> None:
    """Refuse a cavity that leaves the body, or overlaps another, or whose wall (to the
    body's surface, its base or tip, or another cavity) is thinner than one element.

    Parameters
    ----------
    chambers : sequence of Chamber
        A cylinder or tapered body's chambers.
    length_m : float
        The body's length, m.
    radius_at : callable
        x (m, array) -> the body's radius there (m), piecewise linear between ``stations_m``.
    size_m : float
        The mesh's element size, m: the thinnest wall allowed.
    """
    from lab.description.robot import DescriptionError

    for i, c in enumerate(chambers):
        where = f"chambers[{i}] ({c.name!r})"
        if c.start_m < size_m or c.end_m > length_m - size_m:
            raise DescriptionError(
                f"{where}: the cavity from x = {c.start_m} to {c.end_m} m must stay one element (mesh.size_m = "
                f"{size_m} m) inside the body's base (x = 0) and tip (x = {length_m} m), so its wall closes both ends"
            )
        xs = np.linspace(c.start_m, c.end_m, 65)
        wall = radius_at(xs) - (c.offset_m + c.radius_m)
        k = int(np.argmin(wall))
        if wall[k] < 0:
            raise DescriptionError(
                f"{where}: the cavity leaves the body at x = {xs[k]:.4g} m (offset_m + radius_m = "
                f"{c.offset_m + c.radius_m} m, the body's radius there {float(radius_at(xs[k])):.4g} m)"
            )
        if wall[k] < size_m:
            raise DescriptionError(
                f"{where}: its outer wall at x = {xs[k]:.4g} m is {wall[k] * 1e3:.3g} mm, thinner than one element "
                f"(mesh.size_m = {size_m * 1e3:.3g} mm); make the wall thicker or the elements smaller"
            )
    for i, a in enumerate(chambers):
        for j in range(i):
            b = chambers[j]
            if a.start_m >= b.end_m + size_m or b.start_m >= a.end_m + size_m:
                continue
            pa = a.offset_m * np.array([math.cos(math.radians(a.angle_deg)), math.sin(math.radians(a.angle_deg))])
            pb = b.offset_m * np.array([math.cos(math.radians(b.angle_deg)), math.sin(math.radians(b.angle_deg))])
            gap = float(np.linalg.norm(pa - pb)) - a.radius_m - b.radius_m
            axial = max(a.start_m - b.end_m, b.start_m - a.end_m)  # < size_m here
            if gap < 0 and axial < 0:
                raise DescriptionError(f"chambers[{i}] ({a.name!r}) overlaps chambers[{j}] ({b.name!r})")
            if gap < size_m:
                raise DescriptionError(
                    f"chambers[{i}] ({a.name!r}) and chambers[{j}] ({b.name!r}): the wall between them is thinner "
                    f"than one element (mesh.size_m = {size_m * 1e3:.3g} mm)"
                )


def rest_volume_m3(chamber: Chamber) -> float | None:
    """A geometric cavity's rest volume pi r^2 (end - start), m^3 (None for a mesh body's).

    Parameters
    ----------
    chamber : Chamber
        The chamber.

    Returns
    -------
    float or None
        Its volume at rest, m^3.
    """
    if chamber.radius_m is None:
        return None
    return math.pi * chamber.radius_m**2 * (chamber.end_m - chamber.start_m)
