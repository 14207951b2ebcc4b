"""Calibration of xrough's statistical error bars on real measurements: halves and quarters.

``benchmarks/calibration_errors.py`` checks the stated errors (``<name>_std``) over
random seeds of synthetic maps, where the truth is known. On a real measurement there is
no truth and no second seed, but there is a second measurement of the same surface: the
other part of the same map. Each 2D map of the measurement folder (``instruments/`` and
``uncd/``; profiles are skipped) is cut into

* its two halves along x (``x0``, ``x1``: left, right),
* its two halves along y (``y0``, ``y1``),
* its four quarters (``q00``, ``q01``, ``q10``, ``q11``: ``q<y half><x half>``),

and the whole map and every part goes, on its own, through the chain that
``xrough report`` runs by default (:mod:`xrough.cli.report`): the file as
:func:`xrough.open_topography` reads it (the UNCD AFM map with the height scale and tip of
its container's ``meta.yml``, which the reader finds itself), the plane removed by the
report's own ``detrend_as_asked(topo, "auto")`` (split first, then each part detrended), and::

    G = topo.rough.acf()                                   # default options
    fit = G.rough.fit()
    gbar = G.rough.gradient()
    contact = G.rough.persson(E_star="25 MPa", p0="0.1 MPa", gradient=gbar, fit=fit)
    energy = G.rough.energy(E_star="25 MPa")

(the calls of the report's ``_analysis``, each step on its own so that a step that
raises is recorded with its message and the others still run).

For every pair of parts (the two x halves, the two y halves, and all 6 pairs of
quarters, adjacent and diagonal) and each quantity::

    z = (a - b) / sqrt(std_a^2 + std_b^2)

is computed for

* ``gbar(1px)``, ``gbar(10px)``: the rms gradient in the bin of G nearest in log to the
  lag of 1 and 10 pixels (the smaller pixel spacing; each part's own bin, the same lag
  for both since the parts keep the pixel size), error: its coordinate ``gbar_std``;
* ``v_el``: the elastic energy, ``v_el_std``;
* ``a_r``: Persson's contact area at the smallest lag where both parts have a finite
  ``a_r`` (the report's ``finest``, taken at a lag common to the pair), ``a_r_std``;
* ``sigma_h``, ``H``: the fit's ``sigma_h`` and ``hurst``, ``sigma_h_std``,
  ``hurst_std``.

If the stated errors are the scatter between two maps of the size of a part, ``z`` is
about normal: ``|z| <= 3`` in 99.7 % of the pairs. The parts of one map are not
independent draws (they share the same large-scale features, and the plane removed from
each is its own), and a real surface need not be stationary, so larger ``|z|`` is
expected where a result says it is unsure. A comparison is rated by the worse of the
two parts' quality for that quantity's result (``fit`` for sigma_h and H, ``gradient``
for gbar, ``energy`` for v_el, ``persson`` for a_r) and of the two parts' G; a part whose
step raised counts as failed, with the error as its reason.

Printed (Markdown, for ``docs/quality.md``): per quantity a table of the files with the
z of the x halves, of the y halves and the largest ``|z|`` over the 6 quarter pairs
(with how many of the 6 exceed 3); a summary per quantity and overall: the fraction of
the comparisons with a finite z that have ``|z| <= 3``, and the acceptance metric, the
fraction of all comparisons that have ``|z| <= 3`` or are rated questionable/failed or
are NaN with a reason (target >= 95 %). A comparison where either value (or z) is NaN
counts as ``nan``; it is "rated" when one of its results is marked or raised (or the
fit's ``sigma_h`` is infinite: it found no plateau, ``lambda_r`` unresolved), otherwise
it is an unexplained NaN. Then the comparisons rated good with ``|z| > 3`` (the error
bars' misses), the quality notes of the files (shortened) and the time per file (all
its 9 chains). QualityWarnings are suppressed and counted.

Usage::

    python benchmarks/calibration_real.py                      # 14 maps, ~1 min CPU
    python benchmarks/calibration_real.py --files di-1 uncd     # names or parts of names
    python benchmarks/calibration_real.py --json calibration_real.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np

import xrough
from xrough.cli._common import finest
from xrough.cli._files import detrend_as_asked
from xrough.quality import QualityWarning, notes_of, worst

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
from _data import data_root  # noqa: E402  (where the measurement files are)

DATA = data_root()
E_STAR, P0 = "25 MPa", "0.1 MPa"
#: Options the files need to be read (the text files state no unit); every other file
#: of instruments/ and uncd/ is opened as it is.
OPEN = {
    "instruments/xyz-1.txt": {"unit": "nm"},
    "instruments/xy-1.txt": {"unit": "um", "resample": True},
    "instruments/nonuniform.asc": {"unit": "nm", "resample": True},
    "uncd/80_Scale10.472_FIXEDv2p1_D7eHXiT.asc": {"unit": "nm", "resample": True},
    "uncd/uncd_stylus_300um_5mar_3_k0HpKJt.txt": {"unit": "mm"},
}
NOT_TOPOGRAPHIES = ("README.md", "meta.yml", "LICENSE-ccby-4.0.txt")

PARTS = ("whole", "x0", "x1", "y0", "y1", "q00", "q01", "q10", "q11")
QUARTERS = ("q00", "q01", "q10", "q11")
#: The comparisons: kind -> pairs of parts.
PAIRS = {"halves x": [("x0", "x1")], "halves y": [("y0", "y1")],
         "quarters": list(itertools.combinations(QUARTERS, 2))}
#: Quantity -> the result that gives it (its quality rates the comparison).
QUANTITIES = {"gbar(1px)": "gradient", "gbar(10px)": "gradient", "v_el": "energy",
              "a_r": "persson", "sigma_h": "fit", "H": "fit"}
STEPS = ("G", "fit", "gradient", "energy", "persson")
Z_MAX = 3.0


# ---------------------------------------------------------------------------------------
# the maps and their parts
# ---------------------------------------------------------------------------------------
def candidates() -> list[str]:
    """The files of instruments/ and uncd/, as paths relative to the data folder."""
    return sorted(str(p.relative_to(DATA)) for sub in ("instruments", "uncd")
                  for p in (DATA / sub).glob("*")
                  if p.is_file() and p.name not in NOT_TOPOGRAPHIES)


def split(topo) -> dict:
    """The whole map and its halves and quarters (before any detrending)."""
    ny, nx = topo.sizes["y"], topo.sizes["x"]
    ys = (slice(0, ny // 2), slice(ny // 2, ny))
    xs = (slice(0, nx // 2), slice(nx // 2, nx))
    parts = {"whole": topo}
    for k in (0, 1):
        parts[f"x{k}"] = topo.isel(x=xs[k])
        parts[f"y{k}"] = topo.isel(y=ys[k])
    for i, j in itertools.product((0, 1), (0, 1)):
        parts[f"q{i}{j}"] = topo.isel(y=ys[i], x=xs[j])
    return parts


def pixel(topo) -> float:
    """The smaller of the two pixel spacings, in the lateral unit of G."""
    return float(min(abs(np.diff(topo[d].values[:2])[0]) for d in ("y", "x")))


# ---------------------------------------------------------------------------------------
# one part through the chain
# ---------------------------------------------------------------------------------------
def _short(text: str, n: int = 90) -> str:
    """A note or error on one line, cut to ``n`` characters at its first colon."""
    text = " ".join(str(text).split())
    head = text.split(": ")[0] if len(text.split(": ")[0]) >= 20 else text
    return head if len(head) <= n else head[: n - 3] + "..."


def _num(x) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _at(arr: np.ndarray, k: int | None) -> float:
    return math.nan if k is None or arr is None else float(arr[k])


def chain(topo) -> dict:
    """Detrend ``topo`` as the report does and run its analysis; one record of numbers.

    Each step in its own ``try``: ``errors[step]`` holds the message of a step that
    raised (a later step that needs it is then not run, and says so).
    """
    out: dict = {"shape": list(topo.shape), "quality": {}, "notes": {}, "errors": {}}
    res: dict = {}

    def step(name, func):
        try:
            res[name] = func()
        except Exception as err:  # noqa: BLE001 - recorded, the run goes on
            out["errors"][name] = f"{type(err).__name__}: {_short(err, 160)}"
            return
        out["quality"][name] = worst(res[name])
        out["notes"][name] = [" ".join(n.split()) for n in notes_of(res[name])]

    def G():
        clean, _ = detrend_as_asked(topo, "auto")
        return clean.rough.acf()

    step("G", G)
    if "G" in res:
        G_ = res["G"]
        step("fit", lambda: G_.rough.fit())
        step("gradient", lambda: G_.rough.gradient())
        step("energy", lambda: G_.rough.energy(E_star=E_STAR))
        if "fit" in res and "gradient" in res:
            step("persson", lambda: G_.rough.persson(
                E_star=E_STAR, p0=P0, gradient=res["gradient"], fit=res["fit"]))
    for name in STEPS:
        if name not in res and name not in out["errors"]:
            missing = [s for s in ("G", "fit", "gradient") if s in out["errors"]]
            out["errors"][name] = f"not run: {', '.join(missing)} raised"

    px = pixel(topo)
    out["pixel"] = px
    if "G" in res:
        dr = res["G"].dr.values
        out["dr"] = dr.tolist()
        for label, lag in (("1px", px), ("10px", 10 * px)):
            k = int(np.argmin(np.abs(np.log(dr / lag))))
            out[f"dr({label})"] = float(dr[k])
            if "gradient" in res:
                gbar = res["gradient"]
                out[f"gbar({label})"] = float(gbar.values[k])
                out[f"gbar({label})_std"] = (float(gbar.coords["gbar_std"].values[k])
                                            if "gbar_std" in gbar.coords else math.nan)
    if "fit" in res:
        fit = res["fit"]
        for name, var in (("sigma_h", "sigma_h"), ("H", "hurst")):
            out[name] = _num(fit[var])
            out[f"{name}_std"] = _num(fit.get(f"{var}_std"))
    if "energy" in res:
        out["v_el"] = _num(res["energy"].v_el)
        out["v_el_std"] = _num(res["energy"].get("v_el_std"))
    if "persson" in res:
        contact = res["persson"]
        out["a_r(dr)"] = contact.a_r.values.tolist()
        out["a_r_std(dr)"] = (contact.a_r_std.values.tolist() if "a_r_std" in contact
                              else [math.nan] * contact.sizes["dr"])
        out["persson_dr"] = contact.dr.values.tolist()
        at = finest(contact)  # the report's lag: the finest where a_r is determined
        out["a_r(finest)"] = {"dr": float(at.dr), "a_r": _num(at.a_r),
                              "a_r_std": _num(at.get("a_r_std"))}
    return out


def measure(rel: str) -> dict:
    """Open one file; if it is a map, run the whole map and its 8 parts."""
    t0, c0 = time.perf_counter(), time.process_time()
    record: dict = {"file": rel}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            topo = xrough.open_topography(DATA / rel, **OPEN.get(rel, {}))
        except Exception as err:  # noqa: BLE001
            record["skipped"] = f"does not open: {type(err).__name__}: {_short(err)}"
            return record
        if tuple(topo.dims) != ("y", "x"):
            record["skipped"] = f"not a map (dims {tuple(topo.dims)})"
            return record
        topo = topo.load()
        record["shape"] = list(topo.shape)
        record["unit"] = topo.x.attrs.get("units", "")
        record["parts"] = {name: chain(part) for name, part in split(topo).items()}
    record["seconds"] = time.perf_counter() - t0
    record["cpu_seconds"] = time.process_time() - c0
    record["quality_warnings"] = sum(issubclass(w.category, QualityWarning) for w in caught)
    record["other_warnings"] = len(caught) - record["quality_warnings"]
    return record


# ---------------------------------------------------------------------------------------
# comparisons
# ---------------------------------------------------------------------------------------
def _value(part: dict, quantity: str, lag: float | None = None) -> tuple[float, float]:
    """(value, std) of a quantity of a part; for a_r at the persson lag ``lag``."""
    if quantity == "a_r":
        if lag is None or "persson_dr" not in part:
            return math.nan, math.nan
        k = int(np.argmin(np.abs(np.log(np.asarray(part["persson_dr"]) / lag))))
        return float(part["a_r(dr)"][k]), float(part["a_r_std(dr)"][k])
    return part.get(quantity, math.nan), part.get(f"{quantity}_std", math.nan)


def _common_finest(a: dict, b: dict) -> float | None:
    """The smallest lag where both parts have a finite a_r (bins matched within 2 %)."""
    if "persson_dr" not in a or "persson_dr" not in b:
        return None
    da, db = np.asarray(a["persson_dr"]), np.asarray(b["persson_dr"])
    fa = np.isfinite(np.asarray(a["a_r(dr)"], float))
    fb = np.isfinite(np.asarray(b["a_r(dr)"], float))
    for k in np.flatnonzero(fa):
        j = int(np.argmin(np.abs(np.log(db / da[k]))))
        if abs(math.log(db[j] / da[k])) < 0.02 and fb[j]:
            return float(da[k])
    return None


def compare(a: dict, b: dict, quantity: str) -> dict:
    """z of one quantity between two parts, with its rating and reasons."""
    result = QUANTITIES[quantity]
    lag = _common_finest(a, b) if quantity == "a_r" else None
    (va, sa), (vb, sb) = _value(a, quantity, lag), _value(b, quantity, lag)
    levels, reasons = [], []
    for part in (a, b):
        for s in ("G", result):
            if s in part["errors"]:
                levels.append("failed")
                reasons.append(f"{s} raised: {part['errors'][s]}")
            else:
                levels.append(part["quality"][s])
                reasons += [f"{s}: {n}" for n in part["notes"][s]]
    level = worst(*levels)
    z = (va - vb) / math.sqrt(sa**2 + sb**2) if sa**2 + sb**2 > 0 else math.nan
    out = {"a": va, "b": vb, "std_a": sa, "std_b": sb, "z": z, "quality": level,
           "reasons": list(dict.fromkeys(reasons)) if level != "good" else []}
    if lag is not None:
        out["dr"] = lag
    if not math.isfinite(z):
        out["why_nan"] = ("no lag where both have a finite a_r" if quantity == "a_r"
                          and lag is None else
                          "value NaN/inf" if not (math.isfinite(va) and math.isfinite(vb))
                          else "std NaN or 0")
        if quantity == "sigma_h" and math.inf in (va, vb):
            # the fit's statement "no plateau" (lambda_r not resolved): a reason
            out["reason_nan"] = "sigma_h infinite: no plateau, lambda_r not resolved"
    return out


def status(c: dict) -> str:
    """``ok`` (|z| <= 3), ``rated`` (|z| > 3, marked), ``miss`` (|z| > 3, good),
    ``nan rated`` (a result marked or raised, or sigma_h infinite: the fit found no
    plateau) or ``nan unexplained``."""
    marked = c["quality"] != "good"
    if not math.isfinite(c["z"]):
        marked = marked or "reason_nan" in c
        return "nan rated" if marked else "nan unexplained"
    if abs(c["z"]) <= Z_MAX:
        return "ok"
    return "rated" if marked else "miss"


def comparisons(record: dict) -> dict:
    """``{quantity: {kind: [comparison, ...]}}`` of one map."""
    parts = record["parts"]
    out: dict = {}
    for q in QUANTITIES:
        out[q] = {}
        for kind, pairs in PAIRS.items():
            out[q][kind] = []
            for pa, pb in pairs:
                c = compare(parts[pa], parts[pb], q)
                c["pair"] = f"{pa}-{pb}"
                c["status"] = status(c)
                out[q][kind].append(c)
    return out


# ---------------------------------------------------------------------------------------
# printing
# ---------------------------------------------------------------------------------------
MARK = {"good": "", "questionable": " ?", "failed": " F"}


def cell(c: dict) -> str:
    if not math.isfinite(c["z"]):
        return "nan" + MARK[c["quality"]]
    return f"{c['z']:+.1f}{MARK[c['quality']]}"


def quarters_cell(cs: list[dict]) -> str:
    finite = [c for c in cs if math.isfinite(c["z"])]
    nans = len(cs) - len(finite)
    if not finite:
        return f"nan{MARK[worst(*(c['quality'] for c in cs))]}"
    top = max(finite, key=lambda c: abs(c["z"]))
    over = sum(abs(c["z"]) > Z_MAX for c in finite)
    text = f"{abs(top['z']):.1f}{MARK[top['quality']]} ({over}/{len(cs)} > 3"
    return text + (f", {nans} nan)" if nans else ")")


def name_of(rel: str) -> str:
    return Path(rel).name


def print_tables(maps: list[dict], comps: dict) -> None:
    print("z = (a - b) / sqrt(std_a^2 + std_b^2) between the parts of each map. Cells: "
          "z (halves), max |z| over the 6 quarter pairs (how many exceed 3); "
          "`?` questionable, `F` failed (the worse of the two parts' result and G); "
          "nan: a value or its std is NaN.\n")
    for q in QUANTITIES:
        print(f"### {q}\n")
        print("| file | halves x | halves y | quarters: max abs z |")
        print("|---|---|---|---|")
        for m in maps:
            c = comps[m["file"]][q]
            print(f"| {name_of(m['file'])} | {cell(c['halves x'][0])} | "
                  f"{cell(c['halves y'][0])} | {quarters_cell(c['quarters'])} |")
        print()


def tally(cs: list[dict]) -> dict:
    n = len(cs)
    s = [c["status"] for c in cs]
    finite = sum(x in ("ok", "rated", "miss") for x in s)
    return {"n": n, "finite": finite, "ok": s.count("ok"), "rated": s.count("rated"),
            "miss": s.count("miss"), "nan rated": s.count("nan rated"),
            "nan unexplained": s.count("nan unexplained")}


def _pct(a: int, b: int) -> str:
    return f"{100 * a / b:.0f} %" if b else "-"


def _median_z(cs: list[dict], good_only: bool = False) -> str:
    zs = [abs(c["z"]) for c in cs if math.isfinite(c["z"])
          and (c["quality"] == "good" or not good_only)]
    return f"{np.median(zs):.2f}" if zs else "-"


def print_summary(maps: list[dict], comps: dict) -> None:
    print("### Summary\n")
    print("Comparisons: 1 pair of x halves + 1 of y halves + 6 quarter pairs per map and "
          "quantity. `|z|<=3`: of the comparisons with a finite z. accepted: "
          "`|z| <= 3`, or rated questionable/failed, or NaN with a reason, of all. "
          "Median |z| of the finite z, of those rated good and of all: 0.67 for "
          "calibrated errors, far below: errors too wide.\n")
    print("| quantity | comparisons | finite z | abs z <= 3 | abs z > 3 rated | "
          "abs z > 3 good (misses) | nan rated | nan unexplained | accepted | "
          "median abs z (good / all) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    every: list[dict] = []
    for q in list(QUANTITIES) + ["all"]:
        cs = ([c for m in maps for kind in PAIRS for c in comps[m["file"]][q][kind]]
              if q != "all" else every)
        if q != "all":
            every += cs
        t = tally(cs)
        accepted = t["ok"] + t["rated"] + t["nan rated"]
        label = "**all**" if q == "all" else q
        print(f"| {label} | {t['n']} | {t['finite']} | {t['ok']} "
              f"({_pct(t['ok'], t['finite'])}) | {t['rated']} | {t['miss']} | "
              f"{t['nan rated']} | {t['nan unexplained']} | {accepted} "
              f"({_pct(accepted, t['n'])}) | {_median_z(cs, True)} / {_median_z(cs)} |")
    t = tally(every)
    accepted = t["ok"] + t["rated"] + t["nan rated"]
    print(f"\nsummary: {t['ok']}/{t['finite']} = {_pct(t['ok'], t['finite'])} of the "
          f"finite comparisons have |z| <= 3; {accepted}/{t['n']} = "
          f"{_pct(accepted, t['n'])} have |z| <= 3 or are rated questionable/failed "
          f"(with a reason) (target >= 95 %); {t['nan rated'] + t['nan unexplained']} "
          f"nan ({t['nan unexplained']} unexplained)")
    good = [c for c in every if c["quality"] == "good" and math.isfinite(c["z"])]
    if good:
        gok = sum(abs(c["z"]) <= Z_MAX for c in good)
        print(f"among the comparisons rated good: {gok}/{len(good)} = "
              f"{_pct(gok, len(good))} have |z| <= 3")
    print()


def print_misses(maps: list[dict], comps: dict) -> None:
    rows = []
    for m in maps:
        for q in QUANTITIES:
            for kind in PAIRS:
                for c in comps[m["file"]][q][kind]:
                    if c["status"] in ("miss", "nan unexplained"):
                        rows.append((name_of(m["file"]), q, c))
    print("### Rated good but |z| > 3 (or NaN without a reason)\n")
    if not rows:
        print("none\n")
        return
    print("| file | quantity | pair | a +- std | b +- std | z |")
    print("|---|---|---|---|---|---|")
    for name, q, c in rows:
        at = f" (dr {c['dr']:.3g})" if "dr" in c else ""
        print(f"| {name} | {q}{at} | {c['pair']} | {c['a']:.4g} +- {c['std_a']:.2g} | "
              f"{c['b']:.4g} +- {c['std_b']:.2g} | {c['z']:+.2f} |")
    print()


def _pattern(note: str) -> str:
    """A note with its numbers as ``#``: the same cause on different parts is one line."""
    return re.sub(r"[-+]?\d+(\.\d+)?(e[-+]?\d+)?", "#", note)


def print_notes(maps: list[dict]) -> None:
    print("### Why results were rated questionable or failed (per file, shortened)\n")
    print("Each cause once (numbers as #), with the results that carry it (a result quotes "
          "the notes of those it used) and the parts.\n")
    for m in maps:
        seen: dict[str, tuple[set, set]] = {}
        for pname, part in m["parts"].items():
            for s, err in part["errors"].items():
                if not err.startswith("not run"):
                    key = f"raised: {_short(_pattern(err))}"
                    steps, where = seen.setdefault(key, (set(), set()))
                    steps.add(s)
                    where.add(pname)
            for s, notes in part["notes"].items():
                for n in notes:
                    steps, where = seen.setdefault(
                        f"{part['quality'][s]}: {_short(_pattern(n))}", (set(), set()))
                    steps.add(s)
                    where.add(pname)
        if not seen:
            continue
        print(f"- {name_of(m['file'])}:")
        for text, (steps, where) in seen.items():
            parts = "all parts" if len(where) == len(PARTS) else ", ".join(
                p for p in PARTS if p in where)
            print(f"  - {text} ({', '.join(s for s in STEPS if s in steps)}; {parts})")
    print()


def print_times(maps: list[dict], skipped: list[dict]) -> None:
    print("### Maps and time\n")
    print("| file | shape (y, x) | whole map: G, fit, gradient, energy, persson | "
          "QualityWarnings | time (9 chains): wall, CPU |")
    print("|---|---|---|---|---|")
    for m in maps:
        w = m["parts"]["whole"]
        levels = ", ".join(w["quality"].get(s, "raised") for s in STEPS)
        print(f"| {name_of(m['file'])} | {m['shape'][0]} x {m['shape'][1]} | {levels} | "
              f"{m['quality_warnings']} | {m['seconds']:.1f} s, {m['cpu_seconds']:.1f} s |")
    print(f"\ntotal {sum(m['seconds'] for m in maps):.1f} s wall, "
          f"{sum(m['cpu_seconds'] for m in maps):.1f} s CPU (one process)")
    for s in skipped:
        print(f"skipped {s['file']}: {s['skipped']}")
    print()


# ---------------------------------------------------------------------------------------
def _jsonable(obj):
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.generic):
        return _jsonable(obj.item())
    return obj


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", nargs="+", metavar="NAME",
                        help="only the files whose path contains one of these strings "
                        "(e.g. di-1 uncd)")
    parser.add_argument("--json", metavar="OUT", help="write every number to this file")
    args = parser.parse_args(argv)
    if not DATA.is_dir():
        print(f"measurement data not available ({DATA}): nothing to calibrate")
        return 0
    files = [f for f in candidates()
             if not args.files or any(s in f for s in args.files)]
    if not files:
        parser.error(f"no file matches {args.files}; known: {candidates()}")
    maps, skipped = [], []
    for rel in files:
        record = measure(rel)
        if "skipped" in record:
            skipped.append(record)
            continue
        maps.append(record)
        print(f"{rel}: {record['shape'][0]} x {record['shape'][1]}, "
              f"{record['seconds']:.1f} s ({record['cpu_seconds']:.1f} s CPU)",
              file=sys.stderr)
    comps = {m["file"]: comparisons(m) for m in maps}
    print(f"xrough {xrough.__version__}, E_star = {E_STAR}, p0 = {P0}, data {DATA}\n")
    print_tables(maps, comps)
    print_summary(maps, comps)
    print_misses(maps, comps)
    print_notes(maps)
    print_times(maps, skipped)
    if args.json:
        out = {"xrough_version": xrough.__version__, "E_star": E_STAR, "p0": P0,
               "z_max": Z_MAX, "data": str(DATA),
               "maps": [{**m, "comparisons": comps[m["file"]]} for m in maps],
               "skipped": skipped}
        Path(args.json).write_text(json.dumps(_jsonable(out), indent=1), encoding="utf-8")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
