"""``xrough report``: the contact mechanics of topography files, as a table.

Each file's G is fitted and run through the elastic energy, Persson theory (reported at
the smallest lag where it is determined, inside the lag range the instrument resolves:
``reliable_dr_min/max``, from a tip or stylus radius the file states), the mean gap at
``--p0`` (:func:`xrough.mean_gap`, with the 90 % interval of the exact gap) and, with
``--gamma``, the adhesive patch radius; the results are archived and drawn. A file whose
window holds no lag (a tip too blunt for the scan) gets no scale-dependent number: its
rms gradient, Persson theory, energy and patch radius are failed, and the reason is said.
"""

from __future__ import annotations

import argparse
import csv
import functools
import re
import warnings

import numpy as np
import xarray as xr

from .. import units as u
from .._version import __version__
from ..io.archive import save_analysis
from ..plot import plot_loglog, pyplot
from ..preprocess import LagWindow, lag_window
from ..quality import QualityWarning, mark, notes_of, warn, worst
from ..toolbox.cleaning import CHOICES, cleaning_sensitivity
from ._common import (
    EXIT_OK,
    CLIError,
    emit_json,
    exact_of,
    finest,
    finite,
    number,
    output,
    show,
    show_errors,
    text,
    write_atomic,
)
from ._files import (
    add_acf_options,
    add_file_options,
    detrend_as_asked,
    measure_all,
    open_file,
)

#: The physical options: dimension and an example with its unit.
QUANTITIES = {"--E-star": ("[pressure]", "25MPa"), "--p0": ("[pressure]", "0.1MPa"),
              "--gamma": ("[mass] / [time] ** 2", "50mJ/m2")}
#: An rms gradient above this (a slope of 84 degrees) means heights in the wrong unit.
_STEEPEST = 10.0
_COLUMNS = ("measurement", "sigma_h (fit)", "H", "lambda_r", "rms grad", "v_el", "a_r",
            "sigma_c", "at dr", "mean gap", "patch radius")
#: The results of a row whose quality is shown, by their key in the results.
_RATED = {"G": "G", "fit": "fit", "gradient": "rms gradient", "persson": "Persson theory",
          "energy": "elastic energy", "gap": "mean gap", "patch": "patch radius"}



def add_parser(sub, **common) -> None:
    """Add ``report`` to the commands ``sub``."""
    p = sub.add_parser("report", help="contact mechanics report of files", **common)
    add_file_options(p)
    add_acf_options(p, "report")
    p.add_argument("--E-star", required=True, dest="E_star",
                   help="contact modulus with its unit, e.g. 25MPa")
    p.add_argument("--p0", required=True, help="mean pressure with its unit, e.g. 0.1MPa")
    p.add_argument("--gamma", help="work of adhesion with its unit, e.g. 50mJ/m2; adds "
                   "the adhesive patch radius")
    p.add_argument("--compare-cleaning", action="store_true", dest="compare_cleaning",
                   help="for each map, run the chain again with the heights levelled line "
                   "by line and with the outliers masked; a result that one of them moves "
                   "beyond its errors is marked ? with both values (three times the cost)")
    p.set_defaults(func=run)


def negative_values_attached(argv: list[str]) -> list[str]:
    """``--E-star -25MPa`` as ``--E-star=-25MPa``: argparse takes ``-25MPa`` for an option."""
    out: list[str] = []
    k = 0
    while k < len(argv):
        if argv[k] in QUANTITIES and k + 1 < len(argv) and re.match(r"-[\d.]", argv[k + 1]):
            out.append(f"{argv[k]}={argv[k + 1]}")
            k += 2
        else:
            out.append(argv[k])
            k += 1
    return out


def _quantity(args: argparse.Namespace, option: str) -> float | None:
    """Read a physical ``option`` in SI: positive, with its unit.

    A plain number is refused: on a command line a bare ``25`` would be 25 Pa, silently.
    """
    given = getattr(args, option.lstrip("-").replace("-", "_"))
    if given is None:
        return None
    dimension, example = QUANTITIES[option]
    try:
        float(given)
    except ValueError:
        return u.positive_si(given, dimension, what=option)
    raise ValueError(f"{option} {given}: the value has no unit; write it with one, e.g. "
                     f"{option} {example}")


def _analysis(E_star: float, p0: float, gamma: float | None):
    """Return what the report computes from each G, as a function of G.

    Picklable: the files may be measured in worker processes (``--jobs``).
    """
    return functools.partial(_analyse, E_star=E_star, p0=p0, gamma=gamma)


def _analyse(G: xr.DataArray, *, E_star: float, p0: float, gamma: float | None) -> dict:
    fit = G.rough.fit()
    gbar = G.rough.gradient()
    found = {"fit": fit, "gradient": gbar,
             "persson": G.rough.persson(E_star=E_star, p0=p0, gradient=gbar, fit=fit),
             "energy": G.rough.energy(E_star=E_star),
             "gap": G.rough.mean_gap(E_star=E_star, p0=p0, gradient=gbar)}
    if gamma is not None:
        found["patch"] = G.rough.patch_radius(E_star=E_star, gamma=gamma)
    finite_gbar = gbar.values[np.isfinite(gbar.values)]
    steepest = float(finite_gbar.max()) if finite_gbar.size else 0.0
    if steepest > _STEEPEST:
        warn(f"rms gradient {steepest:.3g}: steeper than any measured surface "
             "(a slope of 84 degrees is 10); are the heights in the unit the file "
             "states? (--height-unit, --height-scale)", UserWarning)
    return found


# ------------------------------------------------------------------------ a row


def _quality(results: dict) -> dict:
    """``{key: (level, notes)}`` of the rated results (see :mod:`xrough.quality`)."""
    return {key: (worst(results[key]), notes_of(results[key]))
            for key in _RATED if key in results}


def _rated(cell: str, level: str) -> str:
    """Format a cell: the number if good, marked ``?`` if questionable, else ``failed``."""
    return {"good": cell, "questionable": f"{cell} ?"}.get(level, "failed")


def _sticks(patch: xr.Dataset) -> str:
    """Why there is no patch radius: gamma above the elastic energy of full contact."""
    v_el, gamma = float(patch.v_el), float(patch.attrs["gamma"])
    return f"none: sticks everywhere (v_el {v_el:.3g} < gamma {gamma:.3g} J/m2)"


def _cells(m: dict, at: xr.Dataset | None, gbar_there: xr.DataArray | None,
           window: LagWindow) -> tuple[str, ...]:
    """Return a row of the table: each number in its unit, rated by its quality.

    ``at``: Persson theory at the smallest lag inside the window where it is determined
    (None: no such lag, and no scale-dependent number is printed).
    """
    r = m["results"]
    fit, energy = r["fit"], r["energy"]
    levels = {key: level for key, (level, _) in _quality(r).items()}
    lf, lp = levels["fit"], levels["persson"]
    patch = ("-" if "patch" not in r else _rated(
        show_errors(r["patch"].a_c, r["patch"].get("a_c_std"))
        if np.isfinite(float(r["patch"].a_c)) else show(r["patch"].a_c,
                                                        none=_sticks(r["patch"])),
        levels["patch"]))
    if at is None or gbar_there is None:
        none = "none: no lag in the window" if window.empty is not None else "none"
        grad = _rated("none", levels["gradient"])
        area = stress = _rated("none", lp)
        where = none
    else:
        grad = _rated(show_errors(gbar_there, _coord(gbar_there, "gbar_std")),
                      levels["gradient"])
        area = _rated(show_errors(at.a_r, at.get("a_r_std"), exact_of(at, "a_r")), lp)
        stress = _rated(show_errors(at.sigma_c, at.get("sigma_c_std"), exact_of(at, "sigma_c")),
                        lp)
        where = show(at.dr)
    return (m["name"], _rated(show(fit.sigma_h, none="no plateau"), lf),
            _rated(f"{float(fit.hurst):.3f}+-{float(fit.hurst_std):.3f}", lf),
            _rated(show(fit.lambda_r, none="no roll-off"), lf), grad,
            _rated(show_errors(energy.v_el, energy.get("v_el_std")), levels["energy"]),
            area, stress, where, _rated(show_errors(r["gap"].mean_gap, r["gap"].mean_gap_std,
                                                    exact_of(r["gap"], "mean_gap"),
                                                    level="90 %"), levels["gap"]), patch)


def _exact_record(at: xr.Dataset, name: str) -> dict:
    """Give the same for JSON: the theory's model error and the expected exact value."""
    return {"model_error": _finite_of(at.get(f"{name}_model_error")),
            "exact": {"value": _finite_of(at.get(f"{name}_exact")),
                      "lower": _finite_of(at.get(f"{name}_exact_lower")),
                      "upper": _finite_of(at.get(f"{name}_exact_upper"))}}


def _record(m: dict, at: xr.Dataset | None, gbar_there: xr.DataArray | None,
            window: LagWindow) -> dict:
    """Return the same row for JSON, numbers with their units (null where none)."""
    r = m["results"]
    fit = r["fit"]
    nothing = {"value": None, "units": None}
    return {
        "name": m["name"], "file": m["file"], "detrend": m["detrend"],
        "warnings": m["warnings"],
        "quality": {key: {"level": level, "notes": notes}
                    for key, (level, notes) in _quality(r).items()},
        "window": _window_record(r["G"], window),
        "sigma_h": {**number(fit.sigma_h), "std": finite(fit.sigma_h_std)},
        "hurst": {**number(fit.hurst), "std": finite(fit.hurst_std)},
        "lambda_r": {**number(fit.lambda_r), "std": finite(fit.lambda_r_std)},
        "rms_gradient": nothing if gbar_there is None else {
            **number(gbar_there), "std": _finite_of(_coord(gbar_there, "gbar_std"))},
        "v_el": {**number(r["energy"].v_el), "std": _finite_of(r["energy"].get("v_el_std")),
                 "below_window": _finite_of(r["energy"].get("v_el_below_window"))},
        "a_r": nothing if at is None else {
            **number(at.a_r), "std": _finite_of(at.get("a_r_std")),
            **_exact_record(at, "a_r")},
        "sigma_c": nothing if at is None else {
            **number(at.sigma_c), "std": _finite_of(at.get("sigma_c_std")),
            **_exact_record(at, "sigma_c")},
        "at_dr": nothing if at is None else number(at.dr),
        "mean_gap": {**number(r["gap"].mean_gap), "std": _finite_of(r["gap"].mean_gap_std),
                     **_exact_record(r["gap"], "mean_gap")},
        "patch_radius": {**number(r["patch"].a_c),
                         "std": _finite_of(r["patch"].get("a_c_std"))} if "patch" in r else None,
        "cleaning": _cleaning_record(m),
    }


def _window_record(G: xr.DataArray, window: LagWindow) -> dict:
    """Give the instrument's window for JSON: its limits, its rule, why it holds no lag."""
    unit = G["dr"].attrs.get("units")
    return {"dr_min": None if window.lo is None else number(window.lo, unit),
            "dr_max": None if window.hi is None else number(window.hi, unit),
            "rule": G.attrs.get("reliable_rule"), "no_lag": window.empty}


def _coord(da: xr.DataArray, name: str) -> xr.DataArray | None:
    """Return a coordinate of ``da`` (None if it has none)."""
    return da.coords[name] if name in da.coords else None


def _finite_of(da: xr.DataArray | None) -> float | None:
    """Return a 0-d variable as a JSON number (None: absent or not finite)."""
    return None if da is None else finite(da)


def _at(m: dict) -> tuple[xr.Dataset | None, xr.DataArray | None, LagWindow]:
    """Persson theory and gbar at the finest determined lag inside the window (or None).

    Persson theory and the gradient are NaN outside the instrument's window, so its
    finest determined lag lies inside it; when no lag is determined (a window that holds
    no lag, a failed result) there is none, and no number is taken from the first lag.
    """
    r = m["results"]
    window = lag_window(r["G"])
    contact = r["persson"]
    determined = (np.isfinite(contact.a_r.values) & np.isfinite(contact.sigma_c.values)
                  & ~window.outside)
    if window.empty is not None or not determined.any():
        return None, None, window
    at = finest(contact)
    return at, r["gradient"].sel(dr=float(at.dr), method="nearest"), window


def _row(m: dict) -> tuple[tuple[str, ...], dict]:
    """Return a row of the report table and its JSON record, at the finest determined lag."""
    at, gbar_there, window = _at(m)
    return _cells(m, at, gbar_there, window), _record(m, at, gbar_there, window)


def _window_lines(measured: list[dict]) -> list[str]:
    """Say, per measurement with a recorded window, which lags its instrument resolves."""
    lines = []
    for m in measured:
        G = m["results"]["G"]
        window = lag_window(G)
        if not window.recorded:
            continue
        if window.empty is not None:
            lines.append(f"  {m['name']}: no lag: {window.empty}; so no rms gradient, "
                         "elastic energy, contact area or patch radius (failed)")
            continue
        unit = G["dr"].attrs.get("units", "")
        lo = "its first lag" if window.lo is None else text(window.lo, unit)
        hi = "its last lag" if window.hi is None else text(window.hi, unit)
        share = m["results"]["energy"].get("v_el_below_window")
        said = ("" if share is None or window.lo is None or not np.isfinite(float(share))
                else f"; {float(share):.0%} of v_el comes from lags below it")
        at = _at(m)[0]
        where = ("no lag inside it determines Persson theory" if at is None else
                 f"rms grad, a_r and sigma_c at {show(at.dr)}, the smallest lag inside it "
                 "where Persson theory is determined")
        lines.append(f"  {m['name']}: lags from {lo} to {hi} ({window.rule}): {where}{said}")
    return lines


# ---------------------------------------------------------------------- figure


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
        return u.compact(u.ureg.Quantity(middle, "m")).units

    return u.format_units(typical(lags)), u.format_units(typical(heights) ** 2)


def _figure(measured: list[dict], p0_text: str):
    """G of every file and the contact area, each axis in one unit for all files."""
    curves = [m["results"]["G"] for m in measured]
    dr_unit, g_unit = _common_units(curves)
    plt = pyplot("Agg")  # figures go to files
    # fixed margins (room for the tick labels, the axis labels and a title): a tight
    # layout would measure every label's text, and saving would lay it out again
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 4.5), gridspec_kw=_MARGINS)
    many = len(measured) > _LEGEND_LINES  # a legend of every file would cover the data
    style = dict(linewidth=0.8, alpha=0.6) if many else {}
    areas = []
    for m in measured:
        a_r = m["results"]["persson"].a_r
        a_r = a_r.assign_coords(dr=a_r.dr * u.conversion_factor(a_r.dr.attrs["units"],
                                                                dr_unit))
        a_r["dr"].attrs.update(units=dr_unit, long_name="resolution dr")
        areas.append(a_r.assign_attrs(long_name=f"contact area at p0 = {p0_text}"))
    names = [m["name"] for m in measured]
    for G in curves:
        G.name = G.name or "G"
    for k in _drawn(ax0, curves, names):
        _in_units(curves[k], dr_unit, g_unit).rough.plot(
            ax=ax0, label=None if many else names[k], error=not many, **style)
    for k in _drawn(ax1, areas, names):
        # questionable curves dashed, the expected exact area hatched, log where it spans
        # decades (the finest value is the one quoted)
        plot_loglog(areas[k], ax=ax1, label=None if many else names[k], error=not many,
                    short_range_linear=True, **style)
    for ax in (ax0, ax1):
        if many:
            ax.set_title(f"{len(measured)} measurements", fontsize="medium")
            if ax.get_legend() is not None:
                ax.get_legend().remove()
    return fig


def _drawn(ax, curves: list, names: list[str]) -> list[int]:
    """Return the files to draw on ``ax``: those with a finite value, the others named there.

    A file without one would draw an empty panel that says why (its reason over the
    others' lines, and a linear axis under them): with several files they are named in
    one note instead, and their reasons are in the report's table. One file alone, or
    all of them without, draws the first as a failed result.
    """
    empty = [k for k, c in enumerate(curves) if not np.isfinite(np.asarray(c.values)).any()]
    if len(curves) > 1 and empty:  # below the reason a failed first file prints mid-panel
        ax.text(0.5, 0.02, _empty_note(names, empty), transform=ax.transAxes, ha="center",
                va="bottom", fontsize="small", wrap=True)
    if len(empty) == len(curves):
        return [0]
    return [k for k in range(len(curves)) if k not in empty]


def _empty_note(names: list[str], empty: list[int], shown: int = 4) -> str:
    """``no finite values: a, b and 3 more`` (the files ``empty``)."""
    listed = ", ".join(names[k] for k in empty[:shown])
    more = len(empty) - shown
    return f"no finite values: {listed}" + (f" and {more} more" if more > 0 else "")


#: The report figure's margins and gap, in shares of its 12 x 4.5 inches.
_MARGINS = dict(left=0.085, right=0.985, bottom=0.12, top=0.93, wspace=0.22)


#: Up to this many files the report's figure labels each; beyond, it says how many.
_LEGEND_LINES = 10


# ---------------------------------------------------------------------- output


def _notes(m: dict) -> list[str]:
    """Say the quality of one measurement's results: their levels, then each cause once.

    A result that used another quotes its notes (Persson theory those of its gradient,
    the gradient those of the fit): each note is printed once, with the results it
    concerns.
    """
    levels = {key: level for key, (level, _) in _quality(m["results"]).items()
              if level != "good"}
    if not levels:
        return []
    by_level: dict[str, list[str]] = {}
    for key, level in levels.items():
        by_level.setdefault(level, []).append(_RATED[key])
    head = "; ".join(f"{', '.join(names)} {level}" for level, names in by_level.items())
    causes: dict[str, list[str]] = {}
    for key in levels:
        for note in notes_of(m["results"][key]):
            if _RATED[key] not in causes.setdefault(note, []):
                causes[note].append(_RATED[key])
    return [f"  {m['name']}: {head}",
            *(f"    - {note} ({', '.join(names)})" for note, names in causes.items())]


def _print_table(measured: list[dict], rows: list[tuple[str, ...]], parameters: str) -> None:
    """Print the table, the quality notes under it and what the numbers are."""
    widths = [max(len(h), *(len(r[k]) for r in rows)) for k, h in enumerate(_COLUMNS)]
    print("  ".join(h.ljust(w) for h, w in zip(_COLUMNS, widths)).rstrip())
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
    modes = sorted({m["detrend"] for m in measured})
    if len(modes) > 1:  # say which file got which
        modes = [f"{m['name']} {m['detrend']}" for m in measured]
    notes = [line for m in measured for line in _notes(m)]
    if notes:
        print("quality (a number marked ? is questionable; failed: it means nothing):")
        print("\n".join(notes))
    windows = _window_lines(measured)
    if windows:
        print("resolution (the lag range the instrument resolves; numbers from outside it "
              "are not findings; --all-lags ignores it):")
        print("\n".join(windows))
    print(f"detrend before G: {', '.join(modes)} (--detrend to change); sigma_h from the "
          "fit of G (info gives the rms height of the heights); rms grad, a_r and sigma_c "
          "at the finest resolution inside the instrument's window where Persson theory "
          "is determined (column 'at dr'; none: no such lag); "
          "+-: one standard deviation of a map of this size (stat); a_r and sigma_c are "
          "Persson theory's, which misses the exact contact: 'exact' is what a contact "
          "solver is expected to give on this map, [its one-sigma interval], from the "
          "theory's error in a solver study as a function of p* and of G's shape "
          "(none: outside the study); "
          f"{parameters}")


#: The result of a row that each quantity of :func:`cleaning_sensitivity` comes from.
_CLEANED = {"gbar": "gradient", "v_el": "energy", "a_r": "persson", "hurst": "fit"}


def _compare_cleaning(m: dict, args: argparse.Namespace, E_star: float, p0: float) -> None:
    """Run the chain of a map with the other cleanings; mark what they move (in place).

    The reference is the cleaning the report used (``--detrend``); the others are a line
    per scan line and the outliers masked (:data:`xrough.toolbox.cleaning.CHOICES`). A profile
    has no scan lines to compare: it is left as it is.
    """
    if m["ndim"] != 2:
        return
    raw = open_file(m["file"], args)
    used = m["detrend"]
    choices = {f"as reported ({used})": lambda t: detrend_as_asked(t, args.detrend)[0],
               **{name: clean for name, clean in CHOICES.items() if name != used}}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", QualityWarning)
        found = cleaning_sensitivity(raw, E_star=E_star, p0=p0, choices=choices)
    m["cleaning"] = found
    for q, key in _CLEANED.items():
        moved = [note for note in notes_of(found) if note.startswith(f"{q} depends")]
        if moved and key in m["results"]:
            m["results"][key] = mark(m["results"][key], moved[0], what=key, warn=False)


def _cleaning_record(m: dict) -> dict | None:
    """Return the comparison of cleanings for JSON (None when it was not asked for)."""
    found = m.get("cleaning")
    if found is None:
        return None
    return {"at_dr": number(found.dr), "choices": {
        str(c): {q: {"value": _finite_of(found[q].sel(choice=c)),
                     "std": _finite_of(found[f"{q}_std"].sel(choice=c)),
                     "z": _finite_of(found[f"z_{q}"].sel(choice=c))}
                 for q in _CLEANED} for c in found.choice.values}}


def _emit(out, png, E_star: float, p0: float, gamma: float | None, records) -> None:
    emit_json({"xrough_version": __version__, "output": str(out), "figure": str(png),
               "parameters": {"E_star": number(E_star, "Pa"), "p0": number(p0, "Pa"),
                              "gamma": None if gamma is None else number(gamma, "J m-2")},
               "measurements": list(records)})


def run(args: argparse.Namespace) -> int:
    """Compute, archive, draw and print the contact mechanics of each file."""
    E_star, p0, gamma = (_quantity(args, option) for option in QUANTITIES)
    assert E_star is not None and p0 is not None  # required options
    out = output(args.output)
    png = out.with_suffix(".png")
    # several files: one that fails is a row saying why, the others go on
    found = measure_all(args, _analysis(E_star, p0, gamma), keep_going=len(args.files) > 1)
    measured = [m for m in found if "error" not in m]
    failed = [m for m in found if "error" in m]
    if not measured:
        raise CLIError("no file could be analysed: " + "; ".join(m["error"] for m in failed))
    if getattr(args, "compare_cleaning", False):
        for m in measured:
            _compare_cleaning(m, args, E_star, p0)
    rows, records = (list(x) for x in zip(*(_row(m) for m in measured)))
    rows += [_failed_row(m) for m in failed]
    records += [{"name": m["name"], "file": m["file"], "error": m["error"]} for m in failed]
    parameters = f"E_star={args.E_star}, p0={args.p0}, gamma={args.gamma}"
    save_analysis(out, {m["name"]: m["results"] for m in measured},
                  history=f"xrough report {' '.join(args.files)} ({parameters})")
    table = out.with_suffix(".csv")
    write_atomic(table, lambda p: _write_csv(p, rows, failed))
    fig = _figure(measured, args.p0)
    try:
        write_atomic(png, lambda p: fig.savefig(p, dpi=120, format="png"))
    finally:
        pyplot().close(fig)
    if args.json:
        _emit(out, png, E_star, p0, gamma, records)
        return EXIT_OK
    _print_table(measured, rows, parameters)
    if failed:
        print(f"failed ({len(failed)} of {len(found)} files, left out of {out.name} and the "
              "figure):")
        print("\n".join(f"  {m['name']}: {m['error']}" for m in failed))
    print(f"wrote {out}, {table} and {png}")
    return EXIT_OK


def _failed_row(m: dict) -> tuple[str, ...]:
    """Return the row of a file that could not be analysed: its name, then why."""
    return (m["name"], "failed: see below", *("-" for _ in _COLUMNS[2:]))


def _write_csv(path, rows: list[tuple[str, ...]], failed: list[dict]) -> None:
    """Write the table as CSV, one row per file, with a column saying why a file failed."""
    why = {m["name"]: m["error"] for m in failed}
    with open(path, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow([*_COLUMNS, "error"])
        for row in rows:
            writer.writerow([*row, why.get(row[0], "")])
