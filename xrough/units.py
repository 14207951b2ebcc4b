"""Units: parse, check and format physical units with pint.

xrough keeps units as CF/UDUNITS strings in the ``units`` attribute of every data variable
and dimension coordinate (``"m"``, ``"nm"``, ``"m2"``, ``"J m-2"``). pint does all parsing
and conversion; this module only translates between CF strings and pint, and checks
dimensionality with messages that name the offending quantity.

Physical parameters accept a plain number, a string (``"25 MPa"``), a pint Quantity (of any
registry) or a DataArray with a ``units`` attribute (0-d for one value), all read by
:func:`quantity`, the one unit boundary of the package. Plain numbers are SI
(``E_star=25e6`` is 25 MPa), except lengths tied to data or to a ``unit=`` argument, which
are in that unit (``dr_max=100`` on a map in nm is 100 nm). Type checkers see these
parameters as :data:`QuantityLike`.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.abc
import importlib.util
import re
import sys
import warnings
from collections.abc import Callable, Hashable, Mapping, Sequence
from typing import (
    TYPE_CHECKING,
    Any,
    Literal,
    Protocol,
    TypeAlias,
    TypeGuard,
    TypeVar,
    cast,
    overload,
)

import numpy as np
import xarray as xr

from ._kernels.deferred import Deferred, load, pint

if TYPE_CHECKING:
    from pint.facets.plain import PlainUnit

__all__ = [
    "QuantityLike",
    "ureg",
    "parse_units",
    "format_units",
    "units_of",
    "quantity",
    "to_si",
    "positive_si",
    "magnitude_in",
    "array_in",
    "as_length_unit",
    "is_length",
    "length_unit_word",
    "length_in",
    "conversion_factor",
    "multiply_units",
    "power_units",
    "is_quantified",
    "dequantify",
    "quantify",
    "sel",
    "accepts_quantified",
    "compact",
]

#: A number, then a unit: ``"25 MPa"``, ``"2 um4"``, ``"-3e-9 m"``.
_NUMBER_UNIT = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$")
#: A power glued to a symbol that is not ASCII (``"Å2"``, ``"μm2"``), which the registry's
#: CF rule (ASCII letters only) does not see.
_GLUED_NON_ASCII = re.compile(r"(?<=[Åµμ])(?=-?\d)")

#: The one unit registry: cf-xarray's, which reads CF/UDUNITS strings (``"m2"``,
#: ``"J m-2"``) and is pint's application registry once cf-xarray's units are imported,
#: so that pint-xarray's ``.pint.quantify()``, cf-xarray and xrough share it. Quantities
#: of another registry are converted through their string representation. It is
#: built at its first use (``xrough.units.ureg`` is the registry itself; inside, ``_ureg``
#: stands for it until then, :class:`xrough._kernels.deferred.Deferred`).
_ureg: pint.UnitRegistry = cast("pint.UnitRegistry", Deferred("cf_xarray.units", "units"))
if TYPE_CHECKING:
    ureg: pint.UnitRegistry


def __getattr__(name: str) -> Any:
    if name == "ureg":  # the registry itself, built now: an identity is that of cf-xarray's
        return load(_ureg)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


class _RegistryBeforePintXarray(importlib.abc.MetaPathFinder):
    """Build the registry when pint-xarray is imported, before it reads pint's default.

    pint-xarray takes pint's application registry at its import as the registry of
    ``.pint.quantify()``; cf-xarray's units make theirs that registry when imported. So
    that ``import xrough; import pint_xarray`` quantifies ``"nm2"`` without naming a
    registry, importing pint-xarray builds xrough's first.
    """

    def find_spec(self, fullname, path, target=None):
        if fullname == "pint_xarray":
            with contextlib.suppress(ValueError):
                sys.meta_path.remove(self)
            load(_ureg)
        return None


if "pint_xarray" not in sys.modules:
    sys.meta_path.insert(0, _RegistryBeforePintXarray())

#: What a physical parameter accepts, the forms :func:`quantity` reads: a plain number or a
#: numeric array (in SI, or in the data's unit for lengths tied to data), a string of a
#: number and a unit (``"25 MPa"``), a pint Quantity of any registry, a DataArray with a
#: ``units`` attribute, or a list or tuple of single values in these forms
#: (``["0.1 MPa", 2e5]``). The annotation of every physical parameter of the public API.
QuantityLike: TypeAlias = (
    "int | float | np.integer | np.floating | np.ndarray | str | pint.Quantity | xr.DataArray"
    " | Sequence[int | float | np.integer | np.floating | str | pint.Quantity | xr.DataArray]"
)


def _cf_to_pint(text: str) -> str:
    """Spell a unit for the registry: CF's middle dot and non-ASCII glued powers."""
    return _GLUED_NON_ASCII.sub("**", text.replace("·", " ").strip())


def _did_you_mean(text: str) -> str:
    """``" (did you mean 'MPa'?)"`` when a symbol of ``text`` is a unit in another case."""
    hints: list[tuple[int, str]] = []
    for word in re.findall(r"[A-Za-zµμ_]+", text):
        try:
            if word in load(_ureg):
                continue
        except ValueError:  # a number in words ("nan", "inf"): pint parses, then refuses
            return f" ({word!r} is a number, not a unit)"
        for prefix in ("", "n", "u", "µ", "m", "c", "k", "M", "G", "T", "p", "f"):
            for base in ("Pa", "N", "J", "W", "m", "g", "s", "K", "Hz", "V", "A", "rad"):
                if (prefix + base).lower() == word.lower() and prefix + base in load(_ureg):
                    hints.append((-sum(a == b for a, b in zip(word, prefix + base)),
                                  prefix + base))
    names = list(dict.fromkeys(h for _, h in sorted(hints)))
    return f" (did you mean {' or '.join(repr(h) for h in names)}?)" if names else ""



@functools.lru_cache(maxsize=512)
def _unit(text: str) -> pint.Unit:
    """Return ``ureg.Unit(text)``, parsed once per string.

    pint's parser is slow next to a small map's G; a Unit is immutable.
    """
    return _ureg.Unit(text)


def parse_units(units: str | PlainUnit, *, what: str = "units") -> pint.Unit:
    """Parse a CF/UDUNITS or pint unit string into a pint Unit.

    Parameters
    ----------
    units : str or pint.Unit
        For example ``"nm"``, ``"um"``, ``"m2"``, ``"J m-2"``, ``"mJ/m^2"``.
    what : str
        Name of the quantity, used in error messages.

    Raises
    ------
    ValueError
        If pint does not understand the string.

    Examples
    --------
    >>> parse_units("J m-2") == parse_units("J/m^2") == parse_units("joule / meter ** 2")
    True
    """
    if isinstance(units, pint.Unit):
        return _unit(str(units))
    if not isinstance(units, str):
        raise TypeError(f"{what}: expected a unit string, got {type(units).__name__}")
    try:
        return _unit(_cf_to_pint(units))
    except Exception as err:  # noqa: BLE001 - pint's parser also raises TokenError, ...
        try:  # allow scale prefixes written like "1e-6 m" via a full parse
            q: pint.Quantity = _ureg.Quantity(_cf_to_pint(units))
            if q.magnitude == 1:
                # pint types a Quantity's units as its plain facet's; they are this
                # registry's Unit
                return cast(pint.Unit, q.units)
        except Exception:  # noqa: BLE001 - fall through to the clear message below
            pass
        if isinstance(err, pint.errors.UndefinedUnitError) and err.unit_names:
            reason = f"{err.unit_names[0]!r} is not a unit"
        elif isinstance(err, (pint.errors.DefinitionSyntaxError, ValueError, AttributeError,
                              TypeError)):
            reason = str(err)
        else:  # the expression parser's own errors: TokenError, AssertionError...
            reason = f"not a unit expression ({type(err).__name__}: {err})"
        head = (f"{what}: " if reason == f"{units.strip()!r} is not a unit" else
                f"{what}: cannot understand the unit {units!r}: ")
        raise ValueError(f"{head}{reason}{_did_you_mean(units)}") from err


def format_units(unit: PlainUnit | str) -> str:
    """Format a unit as a CF/UDUNITS string: ``"m2"``, ``"J m-2"``, ``"Pa"``.

    Examples
    --------
    >>> format_units(parse_units("mJ/m^2"))
    'mJ m-2'
    >>> format_units(parse_units("nm") ** 2)
    'nm2'
    >>> format_units("Å2"), format_units("µm")
    ('angstrom2', 'um')
    """
    if isinstance(unit, str):
        unit = parse_units(unit)
    elif unit._REGISTRY is not load(_ureg):  # noqa: SLF001 - another registry's unit
        unit = parse_units(str(unit))
    parts = []
    for name, exp in _factors(unit):
        # symbols in ASCII, as UDUNITS spells them: micro "u", and "angstrom" (cf-xarray's
        # registry reads "angstrom2" but not "Å2")
        sym = _ureg.get_symbol(name).replace("µ", "u").replace("Å", "angstrom")
        e = int(exp) if float(exp).is_integer() else exp
        parts.append(sym if exp == 1 else f"{sym}{e}")
    # positive exponents first, as CF does ("J m-2", not "m-2 J"); else in product order
    parts.sort(key=lambda p: bool(re.search(r"-\d", p)))
    return " ".join(parts) if parts else "1"


def _factors(unit: PlainUnit) -> list[tuple[str, float]]:
    """``(name, exponent)`` of each factor of ``unit``, in product order.

    pint types the exponents as any number (complex too); those of a unit are real.
    """
    items = unit._units.items()  # noqa: SLF001 - pint's documented container
    return cast("list[tuple[str, float]]", list(items))


def units_of(obj: Any, *, what: str | None = None) -> pint.Unit:
    """Parse the ``units`` attribute of an xarray object into a pint Unit.

    Raises
    ------
    ValueError
        If the object has no ``units`` attribute.
    """
    name = what or getattr(obj, "name", None) or "data"
    units = getattr(obj, "attrs", {}).get("units")
    if units is None and is_quantified(obj):
        raise ValueError(
            f"{name!s} holds a pint Quantity (a quantified DataArray, e.g. from "
            "pint-xarray's .pint.quantify()); xrough keeps units in the 'units' attribute: "
            "pass xrough.units.dequantify(da) (or da.pint.dequantify())")
    if units is None:
        hint = (f"da.coords[{obj.name!r}].attrs['units'] = 'nm'" if str(name).startswith(
            "coordinate") else "da.attrs['units'] = 'nm'")
        raise ValueError(
            f"{name!s} has no 'units' attribute; set it, e.g. {hint} "
            "(xrough needs physical units on data and coordinates)"
        )
    return parse_units(units, what=str(name))


class _Labelled(Protocol):
    """What :func:`quantity` reads of a DataArray (an xarray Variable has it too)."""

    @property
    def attrs(self) -> dict[Any, Any]: ...

    @property
    def dims(self) -> tuple[Hashable, ...]: ...

    @property
    def values(self) -> np.ndarray: ...


class _Quantified(Protocol):
    """An object whose ``.data`` is a pint Quantity (a pint-xarray quantified one)."""

    @property
    def data(self) -> pint.Quantity: ...


def _is_dataarray(value: object) -> TypeGuard[_Labelled]:
    return hasattr(value, "attrs") and hasattr(value, "dims") and hasattr(value, "values")


def quantity(value: QuantityLike, *, default_units: str | PlainUnit = "",
             what: str = "value") -> pint.Quantity:
    """Turn any accepted form of a physical value into a pint Quantity of this registry.

    This is xrough's one unit boundary: every public function reads its physical and length
    arguments through here, so each form means the same everywhere.

    Parameters
    ----------
    value : number, array, str, pint.Quantity, xarray.DataArray, or a list of these
        - numbers and numeric arrays get ``default_units`` (SI for physical parameters,
          the data's unit for lengths tied to data);
        - strings are a number and a unit (``"25 MPa"``, ``"50 mJ/m^2"``, ``"2 um4"``);
        - pint Quantities of any registry keep their unit;
        - DataArrays (0-d or not) use their ``units`` attribute, or ``default_units``
          when they have none;
        - lists and tuples are converted element by element (``["0.1 MPa", "1 MPa"]``).
    default_units : str or pint.Unit
        Unit of plain numbers.
    what : str
        Name of the argument, for error messages.

    Returns
    -------
    pint.Quantity

    Raises
    ------
    ValueError
        A string or ``units`` attribute that pint does not understand, or list elements
        with incompatible units.
    TypeError
        Any other type.

    Examples
    --------
    >>> import xarray as xr
    >>> quantity(xr.DataArray(0.2, attrs={"units": "um"}), what="a_c").to("nm")
    <Quantity(200.0, 'nanometer')>
    >>> quantity(["0.1 MPa", 2e5], default_units="Pa", what="p0").to("Pa").magnitude
    array([100000., 200000.])
    """
    if isinstance(value, pint.Quantity):
        if value._REGISTRY is not load(_ureg):  # noqa: SLF001
            return _ureg.Quantity(value.magnitude, str(value.units))
        return value
    if is_quantified(value) and hasattr(value, "dims"):  # before .values: no unit stripping
        return quantity(value.data, what=what)
    if _is_dataarray(value):
        units = value.attrs.get("units")
        magnitude = np.asarray(value.values)
        if magnitude.dtype.kind not in "iuf":
            raise TypeError(f"{what}: a DataArray of numbers is needed, got dtype "
                            f"{magnitude.dtype}")
        unit = (parse_units(units, what=f"{what} (its 'units' attribute)")
                if units is not None else default_units)
        return _ureg.Quantity(magnitude.astype(float), unit)
    if isinstance(value, str):
        match = _NUMBER_UNIT.match(value)
        try:
            if match:  # "2 um4", "25 MPa", "50 mJ m-2": number, then a CF or pint unit
                unit_text = match.group(2)
                if unit_text.strip():
                    unit = parse_units(unit_text, what=what)  # names the unit if it fails
                else:
                    unit = ""
                q = _ureg.Quantity(float(match.group(1)), unit)
            else:
                q = _ureg.Quantity(value)
        except ValueError as err:
            if str(err).startswith(f"{what}: "):  # parse_units said what is wrong
                raise ValueError(f"{err} in {value!r}") from None
            raise ValueError(f"{what}: cannot parse {value!r} as a quantity ({err})"
                             f"{_did_you_mean(value)}") from None
        except Exception as err:  # noqa: BLE001
            raise ValueError(f"{what}: cannot parse {value!r} as a quantity ({err})"
                             f"{_did_you_mean(value)}") from None
        if not isinstance(q, pint.Quantity):
            q = _ureg.Quantity(q)
        return q
    if isinstance(value, (int, float, np.integer, np.floating)) or (
        isinstance(value, np.ndarray) and value.dtype.kind in "iuf"
    ):
        return _ureg.Quantity(value, default_units)
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and
                                            value.dtype.kind in "OU"):
        parts = [quantity(v, default_units=default_units, what=what) for v in value]
        if not parts:
            return _ureg.Quantity(np.zeros(0), default_units)
        unit = parts[0].units
        try:
            mags = [float(p.to(unit).magnitude) if p.units != unit else p.magnitude
                    for p in parts]
        except pint.errors.DimensionalityError:
            raise ValueError(f"{what}: the values {value!r} have incompatible units") from None
        return _ureg.Quantity(np.asarray(mags, dtype=float), unit)
    raise TypeError(f"{what}: expected a number, a string like '25 MPa', a pint Quantity or "
                    f"a DataArray with a 'units' attribute, got {type(value).__name__}")


def magnitude_in(value: QuantityLike, unit: str | PlainUnit, *, what: str) -> np.ndarray:
    """Magnitude of ``value`` (any form :func:`quantity` accepts) in ``unit``, as floats.

    Plain numbers are taken to be in ``unit`` already. The dimensions must agree.

    Examples
    --------
    >>> float(magnitude_in("0.2 um", "nm", what="a_c"))
    200.0
    """
    target = parse_units(unit, what=what) if isinstance(unit, str) else unit
    q = quantity(value, default_units=target, what=what)
    if q.dimensionality != _ureg.Quantity(1, target).dimensionality:
        want = {"[length]": "a length", "[mass] / [length] / [time] ** 2": "a pressure",
                "[mass] / [time] ** 2": "an energy per area"}.get(
                    str(_ureg.Quantity(1, target).dimensionality), f"in {format_units(target)}")
        raise ValueError(f"{what}: {_show(value)} is not {want} (it has dimensions "
                         f"{q.dimensionality})")
    mag = np.asarray(q.magnitude, dtype=float)
    if q.units != target:
        mag = mag * conversion_factor(q.units, target)
    return mag


def _show(value: object) -> str:
    if _is_dataarray(value):
        return f"a DataArray in {value.attrs.get('units', 'no unit')!r}"
    return repr(value)


def to_si(value: QuantityLike, dimension: str, *, what: str) -> float | np.ndarray:
    """Convert a parameter to an SI magnitude after checking its dimensionality.

    Parameters
    ----------
    value : float, str, pint.Quantity or xarray.DataArray
        Any form :func:`quantity` accepts; plain numbers are taken as SI.
    dimension : str
        A pint dimensionality such as ``"[length]"`` or ``"[pressure]"``.
    what : str
        Parameter name for error messages.

    Examples
    --------
    >>> to_si("25 MPa", "[pressure]", what="E_star")
    25000000.0
    >>> to_si(2.0, "[length]", what="dx")
    2.0
    """
    si_unit = _SI_UNITS.get(dimension)
    if si_unit is None:
        raise KeyError(f"no SI unit known for dimension {dimension!r}")
    mag = magnitude_in(value, si_unit, what=what)
    return float(mag) if np.ndim(mag) == 0 else mag


@overload
def positive_si(value: QuantityLike, dimension: str, *, what: str,
                many: Literal[False] = False) -> float: ...
@overload
def positive_si(value: QuantityLike, dimension: str, *, what: str,
                many: bool) -> float | np.ndarray: ...
def positive_si(value: QuantityLike, dimension: str, *, what: str,
                many: bool = False) -> float | np.ndarray:
    """SI magnitude of a positive, finite physical parameter (plain numbers are SI).

    Parameters
    ----------
    value : float, str, pint.Quantity, xarray.DataArray or a list of these
        See :func:`quantity`.
    dimension : str
        ``"[pressure]"``, ``"[length]"`` or ``"[mass] / [time] ** 2"`` (energy per area).
    what : str
        Parameter name for error messages.
    many : bool
        Allow several values: a 1-D array is returned when ``value`` holds more than a
        scalar, a float otherwise.

    Raises
    ------
    ValueError
        Wrong dimensions, several values where one is expected, or a value that is not
        positive and finite.

    Examples
    --------
    >>> positive_si(["0.1 MPa", "1 MPa"], "[pressure]", what="p0", many=True)
    array([ 100000., 1000000.])
    """
    mag = to_si(value, dimension, what=what)
    arr = np.atleast_1d(np.asarray(mag, dtype=float))
    if arr.ndim != 1 or (np.ndim(mag) > 0 and not many):
        raise ValueError(f"{what} must be a single value, got {_show(value)}")
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{what} must be positive and finite, got {_show(value)}")
    if np.any(arr > _LARGEST) or np.any(arr < 1 / _LARGEST):
        raise ValueError(f"{what} = {_show(value)} is outside 1e-100 to 1e100 in SI units: "
                         "no physical value is, and its square (e.g. Pa^2 of a stress ACF) "
                         "would not fit in a float")
    return arr if np.ndim(mag) > 0 else float(arr[0])


#: Largest SI magnitude of a physical parameter whose square still fits in a float.
_LARGEST = 1e100

_SI_UNITS = {
    "[length]": "m",
    "[pressure]": "Pa",
    "[mass] / [time] ** 2": "J/m**2",  # energy per area (surface energy)
    "[]": "",
}


def length_in(value: QuantityLike, unit: str | PlainUnit, *, what: str,
              positive: bool = True) -> float:
    """One length in ``unit`` (any form :func:`quantity` accepts; numbers are in ``unit``).

    Lengths tied to data follow the data's unit: ``dr_max=100`` on a map in nm means
    100 nm, ``lambda_r=2000`` with ``unit="nm"`` means 2000 nm. Strings, pint Quantities
    and DataArrays with a ``units`` attribute carry their own unit.

    Examples
    --------
    >>> length_in("2 um", "nm", what="lambda_r")
    2000.0
    >>> length_in(5, "nm", what="dr_max")
    5.0
    """
    mag = magnitude_in(value, unit, what=what)
    if np.ndim(mag) != 0 and np.size(mag) != 1:
        raise ValueError(f"{what} must be a single length, got {_show(value)}")
    length = float(np.reshape(mag, -1)[0])
    if not np.isfinite(length) or (positive and not length > 0):
        raise ValueError(f"{what} must be a {'positive' if positive else 'finite'} length, "
                         f"got {_show(value)}")
    return length


def array_in(value: QuantityLike, unit: str | PlainUnit, *, what: str, noun: str = "values",
             positive: bool = False) -> np.ndarray:
    """1-D array of finite values ``>= 0`` (``> 0`` with ``positive``) in ``unit``.

    ``value`` may be numbers (already in ``unit``), strings, a pint Quantity, a list of
    these, or a DataArray whose ``units`` attribute (if any) is converted.

    Examples
    --------
    >>> from xrough.units import ureg
    >>> array_in(ureg.Quantity([1.0, 2.0], "um"), "nm", what="dr")
    array([1000., 2000.])
    """
    values = np.atleast_1d(magnitude_in(value, unit, what=what))
    bad = np.any(values <= 0) if positive else np.any(values < 0)
    if values.ndim != 1 or not np.all(np.isfinite(values)) or bad:
        raise ValueError(f"{what} must be a 1-D array of finite {noun} "
                         f"{'> 0' if positive else '>= 0'}")
    return values


def as_length_unit(units: str | PlainUnit, *, what: str) -> PlainUnit:
    """Parse ``units`` and check that it is a length.

    Raises
    ------
    ValueError
        Naming ``what`` when the unit is not a length.
    """
    unit = parse_units(units, what=what) if not isinstance(units, pint.Unit) else units
    if unit.dimensionality != _ureg.meter.dimensionality:
        raise ValueError(f"{what} must be a length, but its units are {format_units(unit)!r} "
                         f"(dimensions {unit.dimensionality})")
    return unit


def is_length(units: str | PlainUnit) -> bool:
    """Whether ``units`` is a length unit (``False`` also for one that does not parse).

    Examples
    --------
    >>> is_length("nm"), is_length("V"), is_length("no such unit")
    (True, False, False)
    """
    try:
        as_length_unit(units, what="unit")
    except (ValueError, TypeError):
        return False
    return True


#: Length units as files spell them in headers and column titles, to CF strings: symbols
#: (case-sensitive; ``"um"`` once readers have spelled the micro sign ``u``) ...
_LENGTH_SYMBOLS = {"m": "m", "cm": "cm", "mm": "mm", "um": "um", "nm": "nm", "pm": "pm",
                   "Å": "angstrom"}
#: ... and names (lower case; singular and plural, -meter and -metre).
_LENGTH_NAMES = {
    **{f"{prefix}{base}{plural}": cf
       for prefix, cf in (("", "m"), ("centi", "cm"), ("milli", "mm"), ("micro", "um"),
                          ("nano", "nm"), ("pico", "pm"))
       for base in ("meter", "metre") for plural in ("", "s")},
    "micron": "um", "microns": "um",
    "angstrom": "angstrom", "angstroms": "angstrom", "ångström": "angstrom",
}


def length_unit_word(word: str) -> str | None:
    """CF string of a length unit written as one word in a file, or None if it is none.

    A symbol (``nm``; upper case too, ``NM``, but for ``M``) or a name (``Micrometre``,
    ``microns``, ``Ångström``). The micro sign must already be spelled ``u``
    (:func:`xrough.io._common.micro_as_u`).

    Examples
    --------
    >>> [length_unit_word(w) for w in ("um", "NM", "Micrometers", "microns", "M", "V")]
    ['um', 'nm', 'um', 'um', None, None]
    """
    word = word.strip().strip(".:,;")
    if word in _LENGTH_SYMBOLS:
        return _LENGTH_SYMBOLS[word]
    if word.isupper() and word.lower() in _LENGTH_SYMBOLS and word.lower() != "m":
        return _LENGTH_SYMBOLS[word.lower()]
    return _LENGTH_NAMES.get(word.lower())


def conversion_factor(from_units: str | PlainUnit, to_units: str | PlainUnit) -> float:
    """Multiplicative factor from one unit to another (``1 from = f to``).

    Examples
    --------
    >>> conversion_factor("um", "nm")
    1000.0
    """
    f = parse_units(from_units) if isinstance(from_units, str) else from_units
    t = parse_units(to_units) if isinstance(to_units, str) else to_units
    # pint multiplies prefixes in floating point (um -> nm gives 999.9999999999999);
    # unit factors are exact decimals, so round away the last-digit noise.
    return float(f"{_ureg.Quantity(1, f).to(t).magnitude:.14g}")


def multiply_units(*units: str | PlainUnit) -> str:
    """CF string of a product of units. ``multiply_units("nm", "nm") == "nm2"``."""
    out = _ureg.dimensionless
    for u in units:
        out = out * (parse_units(u) if isinstance(u, str) else u)
    return format_units(out)


def power_units(units: str | PlainUnit, exponent: float) -> str:
    """CF string of a unit raised to a power. ``power_units("nm", 2) == "nm2"``."""
    u = parse_units(units) if isinstance(units, str) else units
    return format_units(u**exponent)


def is_quantified(obj: object) -> TypeGuard[_Quantified]:
    """Whether an xarray object (or any object with ``.data``) holds a pint Quantity.

    Examples
    --------
    >>> import xarray as xr
    >>> from xrough.units import ureg
    >>> is_quantified(xr.DataArray(ureg.Quantity([1.0, 2.0], "nm"), dims="x"))
    True
    >>> is_quantified(xr.DataArray([1.0, 2.0], dims="x", attrs={"units": "nm"}))
    False
    """
    return isinstance(getattr(obj, "data", None), pint.Quantity)


def _dequantify_variable(var: Any) -> Any:
    if not isinstance(var.data, pint.Quantity):
        return var
    q = var.data
    out = var.copy(deep=False, data=q.magnitude)
    out.attrs = {**var.attrs, "units": format_units(q.units)}
    return out


def dequantify(obj: Any) -> Any:
    """Move pint Quantities out of the data into CF ``units`` attributes.

    The inverse of pint-xarray's ``.pint.quantify()`` for xrough's purposes, without
    needing pint-xarray: a DataArray, Dataset or DataTree whose data variables or
    coordinates hold pint Quantities (of any registry) comes back with plain (numpy or
    dask) data and a ``units`` attribute on each of them, as every xrough function
    expects. Objects without Quantities are returned unchanged.

    Parameters
    ----------
    obj : xarray.DataArray, xarray.Dataset or xarray.DataTree

    Returns
    -------
    The same kind of object.

    Examples
    --------
    >>> import xarray as xr
    >>> from xrough.units import ureg
    >>> da = xr.DataArray(ureg.Quantity([1.0, 2.0], "um**2"), dims="dr",
    ...                   coords={"dr": ("dr", [1.0, 2.0], {"units": "um"})})
    >>> plain = dequantify(da)
    >>> plain.attrs["units"], type(plain.data).__name__
    ('um2', 'ndarray')
    """
    if isinstance(obj, xr.DataTree):
        return obj.map_over_datasets(dequantify)
    if isinstance(obj, xr.Dataset):
        if not any(isinstance(v.data, pint.Quantity) for v in obj.variables.values()):
            return obj
        # indexed coordinates hold plain values (pint-xarray keeps their units in the
        # index); rebuild from the variables so that no pint data survives
        variables = {k: _dequantify_variable(v) for k, v in obj.variables.items()}
        coords = {k: variables[k] for k in obj.coords}
        data_vars = {k: variables[k] for k in obj.data_vars}
        return xr.Dataset(data_vars, coords=coords, attrs=obj.attrs)
    if isinstance(obj, xr.DataArray):
        if not is_quantified(obj) and not any(is_quantified(c) for c in obj.coords.values()):
            return obj
        name = obj.name if obj.name is not None else "__xrough_data__"
        ds = dequantify(obj.to_dataset(name=name))
        out = ds[name]
        out.name = obj.name
        return out
    raise TypeError(f"dequantify: expected an xarray object, got {type(obj).__name__}")


_XARRAY = (xr.DataArray, xr.Dataset, xr.DataTree)


_F = TypeVar("_F", bound=Callable[..., Any])


def accepts_quantified(func: _F) -> _F:
    """Let a public function take pint-quantified data (pint-xarray's ``.pint.quantify()``).

    The first argument (a DataArray, Dataset or DataTree, or a mapping of them) is passed
    through :func:`dequantify`, so that its Quantities become CF ``units`` attributes
    before the function reads them; everything else is unchanged (physical parameters
    read Quantities through :func:`quantity`). The wrapped function keeps its name,
    docstring and signature.

    Examples
    --------
    >>> import xarray as xr
    >>> @accepts_quantified
    ... def unit_of(da):
    ...     return da.attrs["units"]
    >>> from xrough.units import ureg
    >>> unit_of(xr.DataArray(ureg.Quantity([1.0], "nm"), dims="x"))
    'nm'
    """

    @functools.wraps(func)
    def wrapper(data: Any, /, *args: Any, **kwargs: Any) -> Any:
        registry = _registry_of(data)
        if isinstance(data, _XARRAY):
            data = dequantify(data)
        elif isinstance(data, Mapping):  # measurements by name (stitching)
            plain = {k: dequantify(v) if isinstance(v, _XARRAY) else v
                     for k, v in data.items()}
            if any(plain[k] is not v for k, v in data.items()):  # dequantify: same if plain
                data = plain
        result = func(data, *args, **kwargs)
        return result if registry is None else quantify(result, registry)

    return cast(_F, wrapper)  # same signature: the first argument is only dequantified


def _registry_of(data: Any) -> Any:
    """Return the pint registry of the first Quantity in ``data``, or None without one.

    ``data`` is an xarray object or a mapping of them (measurements by name).
    """
    items = data.values() if isinstance(data, Mapping) else [data]
    for item in items:
        if isinstance(item, xr.DataTree):
            item = item.to_dataset() if not item.children else next(
                (n.to_dataset() for n in item.subtree if n.has_data), item.to_dataset())
        if isinstance(item, xr.DataArray):
            item = item.to_dataset(name="__data__") if item.name is None else item.to_dataset()
        if isinstance(item, xr.Dataset):
            for var in item.variables.values():
                if isinstance(var.data, pint.Quantity):
                    return var.data._REGISTRY
    return None


def quantify(result: Any, registry: Any = None) -> Any:
    """Give a result its units as pint Quantities (pint-xarray), as its input had them.

    What :func:`accepts_quantified` does with the result of a function that got quantified
    data: pint in, pint out. Data variables and coordinates with a ``units`` attribute
    become Quantities of ``registry`` (default: xrough's, :data:`ureg`), through
    pint-xarray's ``.pint.quantify``; tuples are quantified item by item; anything else
    (a figure, a number) is returned as is. Without pint-xarray installed the result
    stays plain, with a warning.

    Examples
    --------
    >>> import xarray as xr
    >>> da = xr.DataArray([1.0, 2.0], dims="dr", attrs={"units": "nm2"})
    >>> str(quantify(da).data.units)
    'nanometer ** 2'
    """
    if isinstance(result, tuple):
        return tuple(quantify(r, registry) for r in result)
    if not isinstance(result, (xr.DataArray, xr.Dataset, xr.DataTree)):
        return result
    if importlib.util.find_spec("pint_xarray") is None:
        warnings.warn("the input was quantified but pint-xarray is not installed: the "
                      "result keeps its units as CF attributes", stacklevel=3)
        return result
    import pint_xarray  # noqa: F401  (registers the .pint accessor)

    registry = load(_ureg) if registry is None else registry
    if isinstance(result, xr.DataTree):
        return result.map_over_datasets(lambda ds: ds.pint.quantify(unit_registry=registry))
    return result.pint.quantify(unit_registry=registry)


#: SI prefixes by power of ten, for :func:`compact`.
_SI_PREFIXES = {-18: "a", -15: "f", -12: "p", -9: "n", -6: "u", -3: "m", 0: "", 3: "k",
                6: "M", 9: "G", 12: "T", 15: "P"}


def compact(q: pint.Quantity) -> pint.Quantity:
    """One value with the SI prefix that puts it between 1 and 1000 (pint's ``to_compact``).

    The prefix goes on the first unit of the numerator, by its root for a power
    (``3e6 nm2`` is ``3 um2``: its root is 1.7 um). pint's own ``to_compact`` leaves
    array magnitudes alone, and this registry (cf-xarray's, ``force_ndarray_like``) makes
    every magnitude one.

    Examples
    --------
    >>> from xrough.units import ureg
    >>> f"{compact(ureg.Quantity(1200.0, 'nm')):~}"
    '1.2 µm'
    >>> f"{compact(ureg.Quantity(0.05, 'J/m**2')):~}"
    '50.0 mJ / m ** 2'
    >>> f"{compact(ureg.Quantity(3e6, 'nm**2')):.3g~}"
    '3 µm ** 2'
    """
    if np.size(q.magnitude) != 1:
        raise ValueError(f"compact: one value is needed, got {np.size(q.magnitude)}")
    items = _factors(q.units)
    value = float(np.reshape(q.magnitude, -1)[0])
    if not items or value == 0 or not np.isfinite(value):
        return q
    name, power = next(((n, e) for n, e in items if e > 0), items[0])
    prefixed = _ureg.Unit(name) ** power
    base = _ureg.Unit(_ureg.parse_unit_name(name)[0][1]) ** power
    in_base = abs(value * conversion_factor(prefixed, base))
    exp = int(np.clip(np.floor(np.log10(in_base) / power / 3) * 3, -18, 15))
    new = _ureg.Unit(_SI_PREFIXES[exp] + _ureg.parse_unit_name(name)[0][1]) ** power
    return q.to(q.units / prefixed * new)


def _in_coord_units(obj: Any, dim: Hashable, value: Any) -> Any:
    """Convert ``value`` to the unit of ``obj[dim]`` (plain numbers are in it already).

    ``value``: a quantity string, Quantity, number, DataArray, slice or list of them.
    """
    if isinstance(value, slice):
        start, stop = (None if v is None else _in_coord_units(obj, dim, v)
                       for v in (value.start, value.stop))
        return slice(start, stop, value.step)
    if dim not in obj.coords or "units" not in obj[dim].attrs:
        return value
    unit = obj[dim].attrs["units"]
    if isinstance(value, (list, tuple)):
        return [_in_coord_units(obj, dim, v) for v in value]
    if isinstance(value, (str, pint.Quantity, xr.DataArray)):
        mag = magnitude_in(value, unit, what=str(dim))
        return mag.item() if mag.ndim == 0 else mag
    return value


def sel(obj: Any, indexers: Mapping | None = None, *, method: str | None = None,
        tolerance: Any = None, drop: bool = False, **indexers_kwargs: Any) -> Any:
    """Select by label, with values in any unit: ``sel(con, p0="0.1 MPa", dr="1 um")``.

    xarray's :meth:`~xarray.DataArray.sel` with each value converted to the unit of its
    coordinate first: quantity strings, pint Quantities and DataArrays with units in any
    unit of the right dimension, plain numbers in the coordinate's own unit; slices and
    lists of them too. A coordinate without units takes values as they are.

    Parameters
    ----------
    obj : xarray.DataArray or xarray.Dataset
        Any xrough object (``p0`` in Pa, ``dr`` in the length unit, ``q`` in its inverse).
    indexers, method, drop, **indexers_kwargs
        As :meth:`xarray.DataArray.sel`.
    tolerance : number, str or Quantity, optional
        As :meth:`xarray.DataArray.sel`; a quantity in the unit of the one dim selected.

    Returns
    -------
    The selection, as :meth:`xarray.DataArray.sel` returns it.

    Raises
    ------
    ValueError
        A value of the wrong dimension (``p0="1 nm"``), or a unit-bearing tolerance with
        more than one dim selected.

    Examples
    --------
    >>> import numpy as np, xrough
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.5, unit="nm")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="100 um")
    >>> con = G.rough.persson(E_star="25 MPa", p0=["0.1 MPa", "1 MPa"])
    >>> float(con.rough.sel(p0="100 kPa").p0)
    100000.0
    >>> float(G.rough.sel(dr="0.1 um", method="nearest").dr) > 0
    True
    """
    indexers = {**(indexers or {}), **indexers_kwargs}
    converted = {dim: _in_coord_units(obj, dim, value) for dim, value in indexers.items()}
    if tolerance is not None and isinstance(tolerance, (str, pint.Quantity)):
        if len(converted) != 1:
            raise ValueError("sel: a tolerance with units needs one dim to select, got "
                             f"{list(converted)}")
        tolerance = _in_coord_units(obj, next(iter(converted)), tolerance)
    return obj.sel(converted, method=method, tolerance=tolerance, drop=drop)
