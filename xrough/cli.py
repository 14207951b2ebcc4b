"""Command line: ``xrough demo | info | acf | report``.

``xrough demo`` generates a synthetic self-affine surface, computes its G(dr) with both
estimators, compares them with the exact G of the model spectrum (eq. 9), fits G, runs the
contact mechanics (elastic energy, real-space Persson theory, adhesive patch radius),
archives the results to NetCDF, draws a figure and prints a summary table.

``xrough info`` describes topography files, ``xrough acf`` archives their G(dr) and
``xrough report`` runs the contact mechanics on each and prints a table. Every printed
number carries its own unit (heights in the height unit, lags in the lateral unit, with a
readable prefix); ``--json`` prints the same as JSON (numbers in the units of the results,
with ``units`` fields). Exit status: 0 success, 1 bad input or data (one line on stderr
naming the file or argument), 2 usage error.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import json
import os
import re
import sys
import time
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from . import units as u
from ._version import __version__
from .io import BRIDGE, FORMATS, detect_format, list_channels, open_topography
from .io.archive import remove_stale_temporaries, safe_name, save_analysis, temporary_name
from .io.netcdf import write as write_netcdf
from .plot import display_unit, pyplot
from .preprocess import DETREND_MODES, detrend
from .quality import QualityWarning, notes_of, warn, worst
from .spectra import acf_from_spectrum, model_spectrum
from .synthetic import self_affine_surface

__all__ = ["main", "EXIT_OK", "EXIT_DATA", "EXIT_USAGE"]

#: Exit status of a successful run.
EXIT_OK = 0
#: Exit status for bad input or data: unreadable file, wrong unit, failed computation.
EXIT_DATA = 1
#: Exit status for a usage error (unknown option, missing argument); argparse's own.
EXIT_USAGE = 2

_EPILOG = """\
exit status:
  0  success
  1  bad input or data (missing or unreadable file, wrong unit or value, failed
     computation); one line on stderr names the file or argument
  2  usage error (unknown command or option, missing argument)

Every printed number carries its unit; --json prints machine-readable output instead
(numbers in the results' own units, each with a "units" field)."""

#: Demo grid limits: below 64 points the short cutoff (4 pixels) passes the roll-off.
_DEMO_N = (64, 8192)
#: Attributes ``xrough info`` shows without ``--all`` (provenance and instrument).
_INFO_KEYS = ("channel", "channel_index", "instrument", "instrument_manufacturer",
              "instrument_model", "date", "sampling", "detrend")
_PROVENANCE = ("source_file", "source_sha256", "format", "overrides")


class CLIError(ValueError):
    """A bad input or argument, reported as one line and exit status 1."""


# --------------------------------------------------------------------------- units


def _compact(value: float, unit: str):
    """``value unit`` as a pint Quantity with a readable prefix.

    Powers of one unit (``nm2``) get the prefix of their root (``0.3 um2``, not
    ``3e+05 nm2``), as pint's ``to_compact`` alone does not.
    """
    q = u.ureg.Quantity(value, u.parse_units(unit))
    if q.dimensionless and not str(q.units) == "dimensionless":
        q = q.to("dimensionless")
    if q.dimensionless or value == 0 or not np.isfinite(value):
        return q
    items = list(q.units._units.items())  # noqa: SLF001 - pint's documented container
    if len(items) == 1 and items[0][1] not in (1, 1.0) and float(items[0][1]).is_integer():
        n = int(items[0][1])
        root = u.ureg.Quantity(abs(value) ** (1 / n), u.ureg.Unit(items[0][0])).to_compact()
        return q.to(root.units**n)
    return q.to_compact()


def _text(value: float, unit: str, *, digits: int = 4, none: str = "inf") -> str:
    """Format a number with its unit and a readable prefix: ``12.3 nm``, ``0.906``.

    Parameters
    ----------
    value : float
        The number, in ``unit``.
    unit : str
        Its unit (CF string; ``"1"`` for dimensionless).
    digits : int
        Significant digits.
    none : str
        Text for a non-finite value.
    """
    if not np.isfinite(value):
        return none
    q = _compact(float(value), unit)
    if q.dimensionless:
        return f"{q.to('dimensionless').magnitude:.{digits}g}"
    return f"{q.magnitude:.{digits}g} {q.units:~P}"


def _units_of(da: xr.DataArray) -> str:
    return str(da.attrs.get("units", "1"))


def _show(da: xr.DataArray, *, none: str = "inf", digits: int = 4) -> str:
    """Format a 0-d result variable in its own unit."""
    return _text(float(da), _units_of(da), none=none, digits=digits)


def _finite(value: float) -> float | None:
    value = float(value)
    return value if np.isfinite(value) else None


def _number(da: xr.DataArray | float, unit: str | None = None) -> dict:
    """``{"value": ..., "units": ...}`` for JSON (``null`` for a non-finite value)."""
    if isinstance(da, xr.DataArray):
        return {"value": _finite(da), "units": unit or _units_of(da)}
    return {"value": _finite(da), "units": unit or "1"}


def _array(da: xr.DataArray) -> dict:
    return {"values": [_finite(v) for v in np.asarray(da.values, dtype=float).ravel()],
            "units": _units_of(da)}


def _in_units(G: xr.DataArray, dr_unit: str, g_unit: str) -> xr.DataArray:
    """G with its lags in ``dr_unit`` and its values (and errors) in ``g_unit``."""
    fd = u.conversion_factor(G.dr.attrs["units"], dr_unit)
    fg = u.conversion_factor(G.attrs["units"], g_unit)
    out = G.copy(data=np.asarray(G.values) * fg)
    out.attrs["units"] = g_unit
    for name, coord in G.coords.items():
        unit = coord.attrs.get("units")
        if not unit or name == "dr":
            continue
        if u.parse_units(unit).dimensionality == u.parse_units(g_unit).dimensionality:
            out = out.assign_coords({name: (coord.dims, np.asarray(coord.values) * fg,
                                            {**coord.attrs, "units": g_unit})})
    return out.assign_coords(dr=("dr", G.dr.values * fd, {**G.dr.attrs, "units": dr_unit}))


def _common_units(curves: list[xr.DataArray]) -> tuple[str, str]:
    """One lateral and one G unit for several G: readable for their typical size."""
    lags = [float(G.dr.max()) * u.conversion_factor(G.dr.attrs["units"], "m") for G in curves]
    heights = [np.sqrt(float(G.max()) * u.conversion_factor(G.attrs["units"], "m2"))
               for G in curves]

    def typical(values):
        values = [v for v in values if np.isfinite(v) and v > 0]
        middle = float(np.exp(np.mean(np.log(values)))) if values else 1.0
        return u.ureg.Quantity(middle, "m").to_compact().units

    return u.format_units(typical(lags)), u.format_units(typical(heights) ** 2)


# --------------------------------------------------------------------- files in, out


_API_HINTS = ((re.compile(r"open_topography\(path, resample=True\)|\bresample=True"),
               "--resample"),
              (re.compile(r"\b(unit|height_unit|size|channel|format|height_scale|direction)="),
               lambda m: "--" + m.group(1).replace("_", "-") + " "),
              (re.compile(r"(?<![-\w])points_per_decade\b"), "--points-per-decade"))


def _cli_words(text: str) -> str:
    """Say ``--unit 'nm'`` where a message of the API says ``unit='nm'``."""
    for pattern, replacement in _API_HINTS:
        text = pattern.sub(replacement, text)
    return re.sub(r"(?<=\S) {2,}", " ", text)


def _fail(where: str, err: BaseException | str) -> CLIError:
    """Return a :class:`CLIError` whose one-line message names ``where``."""
    text = str(err).strip().splitlines()[0] if str(err).strip() else ""
    if isinstance(err, BaseException):
        strerror = getattr(err, "strerror", None)
        if isinstance(err, OSError) and strerror and not text.startswith(where):
            text = strerror.lower()
        if not text or not isinstance(err, (ValueError, OSError)):
            text = f"{type(err).__name__}{': ' + text if text else ''}"
    text = _cli_words(text).removeprefix(": ")  # a reader naming a folder's empty name
    name = Path(where).name
    if where in text or (name and name in text):
        return CLIError(text)
    return CLIError(f"{where}: {text}")


def _format_module(name: str):
    if name == BRIDGE:
        return importlib.import_module(".io.bridge", __package__)
    return importlib.import_module(FORMATS[name].module)


def _reader_keywords(name: str) -> set[str] | None:
    """Keyword options the format's reader takes (``None``: any)."""
    try:
        params = inspect.signature(_format_module(name).read).parameters.values()
    except (ImportError, TypeError, ValueError):
        return None
    if any(p.kind == p.VAR_KEYWORD for p in params):
        return None
    return {p.name for p in params if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)}


def _channel_value(text: str) -> int | str:
    """``--channel`` as an index (``0``, ``-1``) or a name."""
    return int(text) if re.fullmatch(r"[+-]?\d+", text.strip()) else text


def _open(path: str, args: argparse.Namespace) -> xr.DataArray:
    """Read a topography with the command's options; errors name the file."""
    scale = args.height_scale
    if scale is not None and not (np.isfinite(scale) and scale != 0):
        raise CLIError(f"--height-scale {scale}: must be a finite, non-zero number")
    size = None
    if getattr(args, "size", None):
        parts = [p.strip() for p in args.size.split(",")]
        size = parts[0] if len(parts) == 1 else tuple(parts)
    name = getattr(args, "format", None) or detect_format(path)
    options = {}
    if getattr(args, "channel", None) is not None:
        options["channel"] = _channel_value(args.channel)
    if getattr(args, "resample", False):
        options["resample"] = True
    if options:
        accepted = _reader_keywords(name)
        for key in options:
            if accepted is not None and key not in accepted:
                flag = "--" + key
                raise CLIError(f"{path}: {flag} does not apply to the {name} format"
                               + (" (it has one channel)" if key == "channel" else ""))
    return open_topography(path, format=name, size=size, unit=args.unit,
                           height_unit=getattr(args, "height_unit", None),
                           height_scale=args.height_scale,
                           periodic=True if args.periodic else None, **options)


def _detrend(topo: xr.DataArray, mode: str) -> tuple[xr.DataArray, str]:
    """Detrend by ``mode`` (``auto``: a plane, which is a line for a profile).

    Returns the topography and what was removed: ``none``, ``mean``, ``plane``, ``line``
    (a plane of a profile), ``curvature`` or ``parabola`` (a curvature of a profile).
    """
    if mode == "none":
        return topo, "none"
    mode = "plane" if mode == "auto" else mode
    profile = "y" not in topo.dims
    label = {"plane": "line", "curvature": "parabola"}.get(mode, mode) if profile else mode
    return detrend(topo, mode=mode), label


def _output(text: str, option: str = "-o", *, folder: bool = False) -> Path:
    """Return an output path whose folder exists (created if needed), or fail clearly."""
    path = Path(text)
    if not folder and path.is_dir():
        raise CLIError(f"{option} {text}: is a folder; give a file name")
    parent = path if folder else path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        reason = (err.strerror or str(err)).lower()
        raise CLIError(f"{option} {text}: cannot create the folder {parent}: {reason}") from None
    if not parent.is_dir():
        raise CLIError(f"{option} {text}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CLIError(f"{option} {text}: the folder {parent} is not writable")
    return path


def _write_atomic(path: Path, write: Callable[[Path], object]) -> None:
    """Write through a temporary file in the same folder, renamed over ``path`` at the end.

    A failure leaves ``path`` as it was (absent or the previous file) and no debris.
    """
    tmp = temporary_name(path)
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    remove_stale_temporaries(path)  # what killed writes to ``path`` left behind


def _group_names(paths: list[str]) -> list[str]:
    """Return unique, NetCDF-safe group names for the measurements in ``paths``.

    The file stem; files with the same stem get their parent folder's name in front
    (``a_scan``, ``b_scan``); :func:`xrough.io.archive.safe_name` makes each name legal
    and distinct (and never the reserved ``_provenance``).
    """
    stems = [Path(p).stem for p in paths]
    names: list[str] = []
    for p, stem in zip(paths, stems):
        parent = Path(p).resolve().parent.name
        wanted = f"{parent}_{stem}" if stems.count(stem) > 1 and parent else stem
        names.append(safe_name(wanted, names))
    return names


#: numpy's floating-point warnings inside the computation: not news for the user.
_NUMERIC_NOISE = re.compile(r"encountered in|Mean of empty slice|Degrees of freedom <= 0")
#: An rms gradient above this (a slope of 84 degrees) means heights in the wrong unit.
_STEEPEST = 10.0


def _warn(where: str, caught) -> list[str]:
    """Print caught warnings as one line each on stderr; return their texts.

    Quality warnings are left out: the results carry them (``quality_notes``), and the
    report prints them under its table.
    """
    texts = []
    for w in caught:
        text = " ".join(str(w.message).split())
        if _NUMERIC_NOISE.search(text) or issubclass(w.category, QualityWarning):
            continue
        if text not in texts:
            texts.append(text)
            print(f"xrough: warning: {where}: {text}", file=sys.stderr)
    return texts


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """Show a warning outside a file's processing as one line on stderr."""
    text = " ".join(str(message).split())
    if not _NUMERIC_NOISE.search(text):
        print(f"xrough: warning: {text}", file=sys.stderr)


def _jsonable(obj):
    """Plain JSON values: numpy scalars and arrays as numbers and lists, NaN as null."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.ndarray, np.generic)):
        return _jsonable(obj.tolist())
    if isinstance(obj, float):
        return obj if np.isfinite(obj) else None
    if obj is None or isinstance(obj, (str, int, bool)):
        return obj
    return str(obj)


def _emit_json(obj: dict) -> None:
    print(json.dumps(_jsonable(obj), indent=2, allow_nan=False))


# -------------------------------------------------------------------------- commands


def _demo(args: argparse.Namespace) -> int:
    lo, hi = _DEMO_N
    if not lo <= args.n <= hi:
        raise CLIError(f"-n {args.n}: grid points per side must be {lo} to {hi}")
    if not 0 < args.hurst < 1:
        raise CLIError(f"--hurst {args.hurst}: the Hurst exponent must be between 0 and 1")
    if args.pairs < 1000:
        raise CLIError(f"--pairs {args.pairs}: the random-pair budget must be at least 1000")
    out = _output(args.output, folder=True)
    print(f"xrough {__version__} demo: synthetic self-affine surface, "
          f"{args.n}x{args.n} points, H = {args.hurst}")
    lambda_s = f"{4 * 16 / args.n!r} um"  # the short cutoff at four pixels
    topo = self_affine_surface(hurst=args.hurst, lambda_r="2 um", lambda_s=lambda_s,
                               size="16 um", n=args.n, rms_gradient=0.5,
                               seed=args.seed, unit="um")
    t0 = time.perf_counter()
    G = topo.rough.acf(points_per_decade=10)
    t_fft = time.perf_counter() - t0
    t0 = time.perf_counter()
    Gr = topo.rough.acf(estimator="random", n_pairs=args.pairs, seed=args.seed,
                        points_per_decade=10)
    t_rnd = time.perf_counter() - t0
    exact = acf_from_spectrum(model_spectrum(
        hurst=args.hurst, lambda_r="2 um", lambda_s=lambda_s, lambda_0="16 um",
        rms_gradient=0.5, unit="um"), dr=G.dr.values)
    fit = G.rough.fit()
    E_star, p0, gamma = "25 MPa", "0.1 MPa", "50 mJ/m^2"
    contact = G.rough.persson(E_star=E_star, p0=p0)
    energy = G.rough.energy(E_star=E_star)
    patch = G.rough.patch_radius(E_star=E_star, gamma=gamma)
    # the topography with checksums, as xrough.io.netcdf writes it (read back verified)
    _write_atomic(out / "topography.nc", lambda tmp: write_netcdf(topo, tmp))
    for name, obj in (("G_fft.nc", G), ("G_random.nc", Gr), ("persson.nc", contact)):
        _write_atomic(out / name, obj.to_netcdf)
    plt = pyplot("Agg")  # figures go to files
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.5), layout="constrained")  # titles fit
    topo.rough.plot(ax=axes[0])
    G.rough.plot(ax=axes[1], label="all pairs (FFT)")
    Gr.rough.plot(ax=axes[1], label=f"random pairs ({args.pairs:,} pairs)", linestyle="--")
    axes[1].plot(exact.dr, exact, "k:", label="model spectrum, eq. 9")
    axes[1].legend()
    axes[2].semilogx(contact.dr, contact.a_r)
    axes[2].set_xlabel(f"resolution dr ({display_unit(G.dr.attrs['units'])})")
    axes[2].set_ylabel("relative contact area a_r")
    axes[0].set_title(f"synthetic surface, H = {args.hurst}, rms gradient 0.5")
    axes[1].set_title("height-difference ACF G(dr)")
    axes[2].set_title(f"Persson theory, E* = {E_star}, p0 = {p0}")
    _write_atomic(out / "demo.png", lambda p: fig.savefig(p, dpi=120, format="png"))
    plt.close(fig)
    rel = np.abs(G.values / exact.values - 1)
    print(f"\n{'dr (um)':>10} {'G fft (um2)':>12} {'G rnd (um2)':>12} {'G eq.9 (um2)':>12} "
          f"{'std err (um2)':>13}")
    for k in range(0, G.sizes["dr"], max(1, G.sizes["dr"] // 8)):
        print(f"{G.dr.values[k]:10.4g} {G.values[k]:12.4g} {Gr.values[k]:12.4g} "
              f"{exact.values[k]:12.4g} {G.standard_error.values[k]:13.2g}")
    print(f"\nrms height {_text(float(topo.std()), topo.attrs['units'])} (model "
          f"{_text(topo.attrs['rms_height'], topo.attrs['units'])}); FFT estimator "
          f"{t_fft:.2f} s, random pairs {t_rnd:.2f} s; median |G/G_model - 1| "
          f"= {np.median(rel):.2%}")
    finest = _finest(contact)
    rows = [
        ("Hurst exponent H (fit)", f"{float(fit.hurst):.3f} +- {float(fit.hurst_std):.3f}",
         f"{args.hurst}"),
        ("rms height sigma_h (fit)", _show(fit.sigma_h, none="no plateau"),
         _text(topo.attrs["rms_height"], topo.attrs["units"])),
        ("roll-off wavelength lambda_r (fit)", _show(fit.lambda_r, none="no roll-off"),
         _text(2, "um")),
        ("elastic energy of full contact", _show(energy.v_el), ""),
        (f"contact area at dr = {_show(finest.dr)}", _show(finest.a_r), ""),
        (f"contact stress at dr = {_show(finest.dr)}", _show(finest.sigma_c), ""),
        (f"adhesive patch radius (gamma = {gamma})", _show(patch.a_c), ""),
    ]
    print(f"\n{'quantity':<40} {'from G':>20} {'model':>10}")
    for name, value, model in rows:
        print(f"{name:<40} {value:>20} {model:>10}")
    print(f"\nwrote {out / 'topography.nc'}, {out / 'G_fft.nc'}, {out / 'G_random.nc'}, "
          f"{out / 'persson.nc'}, {out / 'demo.png'}")
    return EXIT_OK


def _channels(topo: xr.DataArray, path: str) -> list[dict]:
    """List the file's channels, where its format has them (else an empty list)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            found = list_channels(path, format=topo.attrs.get("format"))
    except (ValueError, OSError):  # the listing is extra information only
        return []
    return [{k: (v if isinstance(v, (int, float, str, bool)) or v is None else str(v))
             for k, v in c.items()} for c in found]


def _channel_text(c: dict) -> str:
    if c.get("description"):
        return str(c["description"])
    unit = c.get("unit") or "no unit"
    return f"{c.get('index')}: {c.get('name')} ({unit}{', height' if c.get('is_height') else ''})"


def _describe(path: str, topo: xr.DataArray, everything: bool) -> tuple[list[str], dict]:
    """Lines of ``xrough info`` and the same as a JSON-ready dict."""
    dims = [d for d in ("y", "x") if d in topo.dims]
    lateral = topo["x"].attrs["units"]
    height = topo.attrs["units"]
    nonuniform = topo.attrs.get("sampling") == "non-uniform"
    steps, extents = {}, {}
    for d in dims:
        c = np.asarray(topo[d].values, dtype=float)
        step = (c[-1] - c[0]) / (c.size - 1) if c.size > 1 else np.nan
        steps[d] = step
        extents[d] = (c[-1] - c[0]) + (0 if nonuniform else step) if c.size > 1 else np.nan
    values = np.asarray(topo.values, dtype=float)
    valid = np.isfinite(values)
    n_valid = int(valid.sum())
    rms = float(np.std(values[valid])) if n_valid else float("nan")
    channels = _channels(topo, path)
    fmt = topo.attrs.get("format", "?")
    description = FORMATS[fmt].description if fmt in FORMATS else "read by SurfaceTopography"
    kind = "map" if len(dims) == 2 else "profile"
    lines = [path,
             f"  format        {fmt} ({description})",
             f"  points        {' x '.join(str(topo.sizes[d]) for d in dims)} "
             f"({', '.join(dims)}), {kind}"
             + (f"; extra dims {[d for d in topo.dims if d not in dims]}"
                if topo.ndim > len(dims) else ""),
             f"  size          {' x '.join(_text(extents[d], lateral) for d in dims)}",
             f"  pixel size    {' x '.join(_text(steps[d], lateral) for d in dims)}"
             + (" (mean; non-uniform sampling)" if nonuniform else ""),
             f"  units         lateral {lateral}, height {height}",
             f"  rms height    {_text(rms, height, none='no valid point')}",
             f"  valid points  {n_valid / max(values.size, 1):.2%} ({n_valid} of "
             f"{values.size})",
             f"  periodic      {'yes' if topo.attrs.get('periodic') else 'no'}"]
    if channels:
        lines.append(f"  channels      {'; '.join(_channel_text(c) for c in channels)}")
    for key in _INFO_KEYS:
        if key in topo.attrs:
            lines.append(f"  {key:<13} {topo.attrs[key]}")
    for key in _PROVENANCE:
        if key in topo.attrs and key != "format":
            lines.append(f"  {key:<13} {topo.attrs[key]}")
    shown = {"units", "long_name", "periodic", "source", *_INFO_KEYS, *_PROVENANCE}
    rest = {k: v for k, v in topo.attrs.items() if k not in shown}
    if everything:
        lines.append("  attributes:")
        lines += [f"    {k}: {' '.join(str(v).split())}" for k, v in rest.items()]
    elif rest:
        lines.append(f"  ({len(rest)} more attributes: xrough info --all)")
    info = {
        "file": path, "format": fmt, "kind": kind, "dims": dims,
        "shape": {d: int(topo.sizes[d]) for d in dims},
        "size": {d: _number(extents[d], lateral) for d in dims},
        "pixel_size": {d: _number(steps[d], lateral) for d in dims},
        "lateral_units": lateral, "height_units": height,
        "rms_height": _number(rms, height),
        "valid_fraction": n_valid / max(values.size, 1),
        "periodic": bool(topo.attrs.get("periodic")),
        "channels": channels,
        "provenance": {k: topo.attrs[k] for k in _PROVENANCE if k in topo.attrs},
        **{k: topo.attrs[k] for k in _INFO_KEYS if k in topo.attrs},
    }
    if everything:
        info["attrs"] = {k: v.tolist() if isinstance(v, np.ndarray) else v
                         for k, v in rest.items()}
    return lines, info


def _info(args: argparse.Namespace) -> int:
    records = []
    for path in args.files:
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                topo = _open(path, args)
            lines, info = _describe(path, topo, args.all)
        except CLIError:
            raise
        except Exception as err:  # noqa: BLE001 - one line naming the file
            raise _fail(path, err) from err
        info["warnings"] = _warn(path, caught)
        records.append(info)
        if not args.json:
            print("\n".join(lines))
    if args.json:
        _emit_json({"xrough_version": __version__, "files": records})
    return EXIT_OK


def _measure(path: str, name: str, args: argparse.Namespace,
             analyse: Callable[[xr.DataArray], dict] | None = None) -> dict:
    """Open, detrend and compute G (and ``analyse(G)``) for one file; errors name it."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            topo = _open(path, args)
            topo, how = _detrend(topo, args.detrend)
            G = topo.rough.acf(direction=args.direction,
                               points_per_decade=args.points_per_decade)
            G.attrs.update(measurement=name, source_path=str(path))
            result = {"G": G}
            if analyse is not None:
                result.update(analyse(G))
    except CLIError:
        raise
    except Exception as err:  # noqa: BLE001 - one line naming the file
        raise _fail(path, err) from err
    return {"file": str(path), "name": name, "detrend": how, "topography": topo,
            "results": result, "warnings": _warn(path, caught)}


def _measure_all(args: argparse.Namespace, analyse=None) -> list[dict]:
    names = _group_names(args.files)
    return [_measure(path, name, args, analyse)
            for path, name in tqdm(list(zip(args.files, names)), desc="G(dr)",
                                   disable=None, leave=False)]


def _save(out: Path, analysis: dict, history: str) -> None:
    if out.suffix.lower() == ".zarr":  # a Zarr store, which save_analysis replaces atomically
        save_analysis(out, analysis, history=history)
        return
    _write_atomic(out, lambda tmp: save_analysis(tmp, analysis, history=history))


def _acf(args: argparse.Namespace) -> int:
    out = _output(args.output)
    measured = _measure_all(args)
    _save(out, {m["name"]: {"G": m["results"]["G"]} for m in measured},
          "xrough acf " + " ".join(args.files))
    if args.json:
        _emit_json({"xrough_version": __version__, "output": str(out), "measurements": [
            {"name": m["name"], "file": m["file"], "detrend": m["detrend"],
             "warnings": m["warnings"], "dr": _array(m["results"]["G"].dr),
             "G": _array(m["results"]["G"]),
             "standard_error": _array(m["results"]["G"].standard_error),
             "pair_count": [int(v) for v in m["results"]["G"].pair_count.values.ravel()]}
            for m in measured]})
        return EXIT_OK
    for m in measured:
        G = m["results"]["G"]
        dr_unit = G.dr.attrs["units"]
        print(f"{m['name']}: {m['file']}, detrend before G: {m['detrend']}, {G.sizes['dr']} bins, "
              f"dr {_text(float(G.dr.min()), dr_unit)} to {_text(float(G.dr.max()), dr_unit)}, "
              f"G {_text(float(G.min()), G.attrs['units'])} to "
              f"{_text(float(G.max()), G.attrs['units'])}")
    print(f"wrote {out}")
    return EXIT_OK


def _finest(contact: xr.Dataset) -> xr.Dataset:
    """Return Persson theory at the smallest lag where it is determined.

    Below that lag it is NaN: the Laplacian of G is not determined there, or the lag
    lies outside a reliable window.
    """
    determined = np.flatnonzero(np.isfinite(contact.a_r.values)
                                & np.isfinite(contact.sigma_c.values))
    return contact.isel(dr=int(determined[0]) if determined.size else 0)


_COLUMNS = ("measurement", "sigma_h (fit)", "H", "lambda_r", "rms grad", "v_el", "a_r",
            "sigma_c", "at dr", "patch radius")


#: The results of a report row whose quality is shown, by their key in the results.
_RATED = {"fit": "fit", "gradient": "rms gradient", "persson": "Persson theory",
          "energy": "elastic energy", "patch": "patch radius"}


def _quality(results: dict) -> dict:
    """``{key: (level, notes)}`` of the rated results (see :mod:`xrough.quality`)."""
    return {key: (worst(results[key]), notes_of(results[key]))
            for key in _RATED if key in results}


def _rated(text: str, level: str) -> str:
    """Format a cell: the number if good, marked ``?`` if questionable, else ``failed``."""
    return {"good": text, "questionable": f"{text} ?"}.get(level, "failed")


def _row(m: dict, gamma: bool) -> tuple[tuple[str, ...], dict]:
    """Return a row of the report table and its JSON record."""
    r = m["results"]
    fit, gbar, contact, energy = r["fit"], r["gradient"], r["persson"], r["energy"]
    levels = {key: level for key, (level, _) in _quality(r).items()}
    finest = _finest(contact)
    gbar_there = gbar.sel(dr=float(finest.dr), method="nearest")
    patch, patch_json = "-", None
    if gamma:
        a_c = r["patch"].a_c
        patch = _rated(_show(a_c, none="none: sticks everywhere"), levels["patch"])
        patch_json = _number(a_c)
    lf, lg, lp = levels["fit"], levels["gradient"], levels["persson"]
    row = (m["name"], _rated(_show(fit.sigma_h, none="no plateau"), lf),
           _rated(f"{float(fit.hurst):.3f}+-{float(fit.hurst_std):.3f}", lf),
           _rated(_show(fit.lambda_r, none="no roll-off"), lf),
           _rated(_show(gbar_there, digits=3), lg),
           _rated(_show(energy.v_el, digits=3), levels["energy"]),
           _rated(_show(finest.a_r, digits=3), lp),
           _rated(_show(finest.sigma_c, digits=3), lp), _show(finest.dr), patch)
    record = {
        "name": m["name"], "file": m["file"], "detrend": m["detrend"],
        "warnings": m["warnings"],
        "quality": {key: {"level": level, "notes": notes}
                    for key, (level, notes) in _quality(r).items()},
        "sigma_h": {**_number(fit.sigma_h), "std": _finite(fit.sigma_h_std)},
        "hurst": {**_number(fit.hurst), "std": _finite(fit.hurst_std)},
        "lambda_r": {**_number(fit.lambda_r), "std": _finite(fit.lambda_r_std)},
        "rms_gradient": _number(gbar_there),
        "v_el": _number(energy.v_el),
        "a_r": _number(finest.a_r),
        "sigma_c": _number(finest.sigma_c),
        "at_dr": _number(finest.dr),
        "patch_radius": patch_json,
    }
    return row, record


def _report_figure(measured: list[dict], p0_text: str):
    """G of every file and the contact area, each axis in one unit for all files."""
    curves = [m["results"]["G"] for m in measured]
    dr_unit, g_unit = _common_units(curves)
    plt = pyplot("Agg")  # figures go to files
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5))
    for m, G in zip(measured, curves):
        G.name = G.name or "G"
        _in_units(G, dr_unit, g_unit).rough.plot(ax=ax0, label=m["name"])
        contact = m["results"]["persson"]
        factor = u.conversion_factor(contact.dr.attrs["units"], dr_unit)
        ax1.semilogx(contact.dr.values * factor, contact.a_r.values, label=m["name"])
    ax1.set_xlabel(f"resolution dr ({display_unit(dr_unit)})")
    ax1.set_ylabel(f"relative contact area at p0 = {p0_text}")
    ax1.legend()
    fig.tight_layout()
    return fig


#: The physical options of ``report``: dimension and an example with its unit.
_QUANTITIES = {"--E-star": ("[pressure]", "25MPa"), "--p0": ("[pressure]", "0.1MPa"),
               "--gamma": ("[mass] / [time] ** 2", "50mJ/m2")}


def _quantity(args: argparse.Namespace, option: str) -> float | None:
    """Read a physical ``option`` of ``report`` in SI: positive, with its unit.

    A plain number is refused: on a command line a bare ``25`` would be 25 Pa, silently.
    """
    text = getattr(args, option.lstrip("-").replace("-", "_"))
    if text is None:
        return None
    dimension, example = _QUANTITIES[option]
    try:
        float(text)
    except ValueError:
        return u.positive_si(text, dimension, what=option)
    raise ValueError(f"{option} {text}: the value has no unit; write it with one, e.g. "
                     f"{option} {example}")


def _negative_values_attached(argv: list[str]) -> list[str]:
    """``--E-star -25MPa`` as ``--E-star=-25MPa``: argparse takes ``-25MPa`` for an option."""
    out: list[str] = []
    k = 0
    while k < len(argv):
        if argv[k] in _QUANTITIES and k + 1 < len(argv) and re.match(r"-[\d.]", argv[k + 1]):
            out.append(f"{argv[k]}={argv[k + 1]}")
            k += 2
        else:
            out.append(argv[k])
            k += 1
    return out


def _report(args: argparse.Namespace) -> int:
    E_star, p0, gamma = (_quantity(args, option) for option in _QUANTITIES)
    out = _output(args.output)
    png = out.with_suffix(".png")

    def analyse(G):
        fit = G.rough.fit()
        gbar = G.rough.gradient()
        found = {"fit": fit, "gradient": gbar,
                 "persson": G.rough.persson(E_star=E_star, p0=p0, gradient=gbar, fit=fit),
                 "energy": G.rough.energy(E_star=E_star)}
        if gamma is not None:
            found["patch"] = G.rough.patch_radius(E_star=E_star, gamma=gamma)
        steepest = float(gbar.max())
        if steepest > _STEEPEST:
            warn(f"rms gradient {steepest:.3g}: steeper than any measured surface "
                 "(a slope of 84 degrees is 10); are the heights in the unit the file "
                 "states? (--height-unit, --height-scale)", UserWarning)
        return found

    measured = _measure_all(args, analyse)
    rows, records = zip(*(_row(m, gamma is not None) for m in measured))
    parameters = f"E_star={args.E_star}, p0={args.p0}, gamma={args.gamma}"
    _save(out, {m["name"]: m["results"] for m in measured},
          f"xrough report {' '.join(args.files)} ({parameters})")
    fig = _report_figure(measured, args.p0)
    try:
        _write_atomic(png, lambda p: fig.savefig(p, dpi=120, format="png"))
    finally:
        pyplot().close(fig)
    if args.json:
        _emit_json({"xrough_version": __version__, "output": str(out), "figure": str(png),
                    "parameters": {"E_star": _number(E_star, "Pa"), "p0": _number(p0, "Pa"),
                                   "gamma": None if gamma is None else
                                   _number(gamma, "J m-2")},
                    "measurements": list(records)})
        return EXIT_OK
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(_COLUMNS)]
    print("  ".join(h.ljust(w) for h, w in zip(_COLUMNS, widths)).rstrip())
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    modes = sorted({m["detrend"] for m in measured})
    if len(modes) > 1:  # say which file got which
        modes = [f"{m['name']} {m['detrend']}" for m in measured]
    notes = [f"  {m['name']}: {_RATED[key]} {level}: {'; '.join(text)}"
             for m in measured for key, (level, text) in _quality(m["results"]).items()
             if level != "good"]
    if notes:
        print("quality (a number marked ? is questionable; failed: it means nothing):")
        print("\n".join(notes))
    print(f"detrend before G: {', '.join(modes)} (--detrend to change); sigma_h from the "
          "fit of G (info gives the rms height of the heights); rms grad, a_r and sigma_c "
          "at the finest resolution where Persson theory is determined (column 'at dr'); "
          f"{parameters}")
    print(f"wrote {out} and {png}")
    return EXIT_OK


# ---------------------------------------------------------------------------- parser


def _parser() -> argparse.ArgumentParser:
    formatter = argparse.RawDescriptionHelpFormatter
    parser = argparse.ArgumentParser(
        prog="xrough", description="Contact mechanics of rough surfaces from the "
        "height-difference autocorrelation function G(dr).", epilog=_EPILOG,
        formatter_class=formatter)
    parser.add_argument("--version", action="version", version=f"xrough {__version__}")
    parser.add_argument("--traceback", action="store_true",
                        help="on an error, show the full traceback (for bug reports)")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the main job on built-in synthetic data",
                          epilog=_EPILOG, formatter_class=formatter)
    demo.add_argument("-o", "--output", default="xrough-demo",
                      help="output folder (created if missing)")
    demo.add_argument("-n", type=int, default=1024,
                      help=f"grid points per side ({_DEMO_N[0]} to {_DEMO_N[1]})")
    demo.add_argument("--hurst", type=float, default=0.8, help="Hurst exponent, 0 < H < 1")
    demo.add_argument("--pairs", type=int, default=400_000, help="random-pair budget")
    demo.add_argument("--seed", type=int, default=1, help="random seed of the surface")
    demo.set_defaults(func=_demo)

    def file_options(p, detrend=True):
        p.add_argument("files", nargs="+", help="topography files (any supported format)")
        p.add_argument("--format", choices=[*FORMATS, BRIDGE],
                       help="file format (default: detected from the content)")
        p.add_argument("--size", help="physical size replacing the file's, e.g. '100 nm' or "
                       "'10 um,20 um' (y, x)")
        p.add_argument("--unit", help="lateral unit replacing the file's, and the height "
                       "unit too unless --height-unit is given (relabels, does not convert)")
        p.add_argument("--height-unit", dest="height_unit",
                       help="height unit replacing the file's (relabels)")
        p.add_argument("--height-scale", type=float, help="factor applied to the heights")
        p.add_argument("--periodic", action="store_true", help="the maps are periodic")
        p.add_argument("--channel", help="channel of multi-channel files (Nanoscope, "
                       "Gwyddion, Igor, ...): a name or an index (0, 1, ...)")
        p.add_argument("--resample", action="store_true",
                       help="resample non-uniformly sampled profiles onto a uniform grid")
        p.add_argument("--json", action="store_true",
                       help="print JSON (numbers in the results' units, with units fields)")
        if detrend:
            p.add_argument("--detrend", default="auto", choices=["auto", "none",
                                                                 *DETREND_MODES],
                           help="trend removed before G: auto (default) is a plane for "
                           "maps and a line for profiles; none keeps the heights")

    info = sub.add_parser("info", help="what is in a topography file", epilog=_EPILOG,
                          formatter_class=formatter)
    file_options(info, detrend=False)
    info.add_argument("--all", action="store_true",
                      help="print every attribute (the file's whole header)")
    info.set_defaults(func=_info)
    for name, func, helptext in (("acf", _acf, "G(dr) of files, archived to NetCDF"),
                                 ("report", _report, "contact mechanics report of files")):
        p = sub.add_parser(name, help=helptext, epilog=_EPILOG, formatter_class=formatter)
        file_options(p)
        p.add_argument("-o", "--output", default=f"xrough-{name}.nc",
                       help="NetCDF output, or a Zarr store if it ends in .zarr (its "
                            "folder is created if missing)")
        p.add_argument("--direction", default="radial", choices=["radial", "x", "y"],
                       help="lags in all directions (default) or along x or y only")
        p.add_argument("--points-per-decade", type=float, default=10,
                       help="log-spaced bins of G per decade of lag (default 10)")
        if name == "report":
            p.add_argument("--E-star", required=True, dest="E_star",
                           help="contact modulus with its unit, e.g. 25MPa")
            p.add_argument("--p0", required=True,
                           help="mean pressure with its unit, e.g. 0.1MPa")
            p.add_argument("--gamma",
                           help="work of adhesion with its unit, e.g. 50mJ/m2; adds the "
                           "adhesive patch radius")
        p.set_defaults(func=func)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``xrough`` command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default: ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 success, 1 bad input or data (after one line on stderr naming the
        file or argument). Usage errors exit with status 2 (``SystemExit``, argparse's).
    """
    args = _parser().parse_args(_negative_values_attached(
        sys.argv[1:] if argv is None else list(argv)))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")  # shown once each, as one line
            warnings.showwarning = _show_warning
            return args.func(args)
    except KeyboardInterrupt:
        print("xrough: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. ``xrough info --all scan.spm | head``: stop quietly
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):
            pass
        return EXIT_DATA
    except Exception as err:  # noqa: BLE001 - every error is one line, exit status 1
        if args.traceback:
            traceback.print_exc()
        message = str(err).strip().splitlines()[0] if str(err).strip() else ""
        if not isinstance(err, (CLIError, ValueError, OSError)):
            message = f"{type(err).__name__}: {message}" if message else type(err).__name__
        print(f"xrough: error: {message}", file=sys.stderr)
        return EXIT_DATA


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
