"""Persson's contact area against the boundary-element solver, over the surfaces users measure.

Builds the table ``xrough/data/persson_area_error.csv`` from which :func:`xrough.persson`
takes the model error of ``a_r``, ``a_ri`` and ``sigma_c`` (the expected exact value and
its interval), and checks that model on surfaces it was not built from.

Each surface is a periodic random-phase map (eq. 35, rms gradient 0.1) of ``N^2`` pixels,
``N = (L / lambda_r) (lambda_r / lambda_s) lambda_s``, in two sets:

- ``build``: Hurst exponents 0.1, 0.4, 0.5, 0.8 and 0.95; roll-off sharp and smooth
  (Sec. 2.7 of the paper); short cutoff sharp, smooth (``C`` times
  ``[1 + (q / q_s)^2]^-2`` on a map cut at 2 px) or Gaussian (``C`` times
  ``exp(-(q / q_s)^2)``: an instrument's transfer); ``lambda_s`` 2 to 16 px (16: a map
  sampled finer than it resolves, G ~ dr^2 at its first lags), bandwidths
  ``lambda_r / lambda_s`` 4 to 256 and ``L / lambda_r`` 1 to 8; and open maps (a window
  of a larger periodic surface, plane-detrended, solved with the open Green's function)
  of every shape at two geometries; three seeds.
- ``heldout``: never used to build the model: H 0.3 with a smooth roll-off and a Gaussian
  cutoff (bandwidth 32); H 0.65 smooth (bandwidth 8); H 0.65 sharp at ``lambda_s = 2 px``;
  H 0.3 sharp (bandwidth 8); H 0.2 and 0.7 open maps; three seeds.

Every surface is pressed at reduced pressures ``p* = p0 / (E* gbar)`` from 1e-4 to 0.5,
``gbar`` the rms gradient that :func:`xrough.persson` takes from the map's G at its finest
lag. Persson's ``a_r`` (eq. 29) and ``a_ri`` (eq. 50) there are compared with the solver's
share of pixels in contact; loads where fewer than 100 pixels touch are kept in the table
but not used (the solver's area then measures the grid, not the surface). Each run is
cached as NetCDF in ``<out>/runs`` (an interrupted study resumes). About 40 minutes of
solving for both sets, 20 on two cores (``--jobs 2``).

Usage::

    python benchmarks/model_error_study.py --out model-error-study --jobs 2
    python benchmarks/model_error_study.py --out model-error-study --write-table  # ship it
    python benchmarks/model_error_study.py --set heldout --seeds 1 --out /tmp/held  # smaller
"""

from __future__ import annotations

import argparse
import gzip
import itertools
import time
import warnings
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import NamedTuple
from unittest import mock

import numpy as np
import xarray as xr

import xrough
from xrough._kernels import model_error

E_STAR = 1e6  # Pa
GBAR = 0.1  # rms gradient of every surface
LOADS = (1e-4, 3e-4, 1e-3, 3e-3, 0.01, 0.03, 0.1, 0.2, 0.5)  # reduced pressures p*
MIN_PIXELS = 100  # contact pixels below which a load is not used
TABLE = Path(__file__).resolve().parents[1] / "xrough" / "data" / "persson_area_error.csv"
STRESS_TABLE = TABLE.with_name("persson_stress_error.csv.gz")


class Case(NamedTuple):
    hurst: float
    rolloff: str  # sharp | smooth
    cutoff: str  # sharp | smooth | gaussian
    lambda_s_px: float
    bandwidth: float  # lambda_r / lambda_s
    ratio_l: float  # L / lambda_r
    seed: int
    open: bool = False

    @property
    def n(self) -> int:
        return int(round(self.ratio_l * self.bandwidth * self.lambda_s_px))

    @property
    def name(self) -> str:
        return (f"H{self.hurst:g}_{self.rolloff}_{self.cutoff}_ls{self.lambda_s_px:g}_"
                f"bw{self.bandwidth:g}_L{self.ratio_l:g}_{'open' if self.open else 'per'}"
                f"_seed{self.seed}")


#: (lambda_s px, bandwidth, L / lambda_r) of the build set
GEOMETRIES = ((2, 32, 4), (8, 8, 4), (4, 4, 8), (2, 128, 2), (2, 256, 1), (16, 4, 4))
#: (roll-off, short cutoff, open) of the build set: periodic and open maps (plane-detrended
#: windows) of every shape, the open ones in the geometries of OPEN_GEOMETRIES
SHAPES = tuple(itertools.product(("sharp", "smooth"), ("sharp", "smooth", "gaussian"),
                                 (False, True)))
OPEN_GEOMETRIES = ((2, 32, 4), (8, 8, 4))


def cases(which: str, seeds: int) -> list[Case]:
    """The surfaces of the ``build`` or ``heldout`` set."""
    if which == "build":
        # seed by seed: a study cut short has every surface of the first seeds
        return [Case(h, ro, co, ls, bw, rl, s, op)
                for s, h, (ro, co, op), (ls, bw, rl) in itertools.product(
                    range(seeds), (0.1, 0.4, 0.5, 0.8, 0.95), SHAPES, GEOMETRIES)
                if not op or (ls, bw, rl) in OPEN_GEOMETRIES]
    held = [(0.3, "smooth", "gaussian", 4, 32, 2, False), (0.65, "smooth", "sharp", 8, 8, 4, False),
            (0.65, "sharp", "sharp", 2, 64, 2, False), (0.3, "sharp", "sharp", 4, 8, 4, False),
            (0.2, "sharp", "sharp", 2, 32, 4, True), (0.7, "smooth", "gaussian", 4, 16, 4, True)]
    return [Case(h, ro, co, ls, bw, rl, 100 + s, op)
            for (h, ro, co, ls, bw, rl, op), s in itertools.product(held, range(seeds))]


def surface(case: Case) -> xr.DataArray:
    """The map of ``case`` (nm), periodic or an open, plane-detrended window."""
    n = case.n
    grow = 2 if case.open else 1  # an open map: the middle of a surface twice as large
    base = case.lambda_s_px if case.cutoff == "sharp" else 2.0
    topo = xrough.self_affine_surface(
        hurst=case.hurst, lambda_r=n / case.ratio_l, lambda_s=base, size=grow * n,
        n=grow * n, rms_gradient=GBAR, seed=case.seed, unit="nm", rolloff=case.rolloff)
    h = topo.values
    if case.cutoff != "sharp":
        q = 2 * np.pi * np.fft.fftfreq(grow * n)
        qq = np.sqrt(q[:, None] ** 2 + q[None, :] ** 2) * case.lambda_s_px / (2 * np.pi)
        gain = np.exp(-qq**2) if case.cutoff == "gaussian" else (1 + qq**2) ** -2.0
        h = np.fft.ifft2(np.fft.fft2(h) * np.sqrt(gain)).real
    if case.open:
        h = h[n // 2:n // 2 + n, n // 2:n // 2 + n]
        y, x = np.mgrid[:n, :n]
        design = np.column_stack([np.ones(n * n), y.ravel(), x.ravel()])
        h = h - (design @ np.linalg.lstsq(design, h.ravel(), rcond=None)[0]).reshape(n, n)
    gy, gx = np.gradient(h) if case.open else (np.roll(h, -1, 0) - h, np.roll(h, -1, 1) - h)
    h = h * GBAR / np.sqrt(np.mean(gx**2 + gy**2))
    return xrough.topography(h, spacing=1.0, unit="nm", periodic=not case.open)


def theory(topo: xr.DataArray) -> xr.Dataset:
    """Persson's side of one surface: G, the loads and the theory at every lag.

    Recomputed from the surface (``--refresh-theory``) when the package changes; the
    solver's side of a cached run is kept.
    """
    # the theory as it is, without the correction this study builds (whose table it
    # writes: the first run has none to read)
    with warnings.catch_warnings(), mock.patch.object(xrough.contact, "_stress_model_errors",
                                                      lambda *args: {}):
        warnings.simplefilter("ignore")  # the study reads the numbers, not the verdicts
        G = topo.rough.acf()
        p_unit = xrough.persson(G, E_star=E_STAR, p0=1.0, variables=("p_star",)).p_star
        finest = int(np.flatnonzero(np.isfinite(p_unit.values))[0])
        p0 = np.asarray(LOADS) / float(p_unit[finest])  # p* at the finest lag = LOADS
        lagged = xrough.persson(G, E_star=E_STAR, p0=p0,
                                variables=("p_star", "a_r", "a_ri", "G_sigma"))
    at = lagged.isel(dr=finest)
    return xr.Dataset(
        {"p_star": ("load", at.p_star.values), "a_r": ("load", at.a_r.values),
         "a_ri": ("load", at.a_ri.values), "G": ("dr", G.values), "p0": ("load", p0),
         # the stress ACF of eq. 30/48 at every lag of G, and p* there
         "p_star_dr": (("load", "dr"), lagged.p_star.values),
         "G_sigma": (("load", "dr"), lagged.G_sigma.values)},
        coords={"dr": G["dr"].values}, attrs={"finest_lag": float(G["dr"][finest])})


def stress_acf_of(pressure: np.ndarray, *, periodic: bool) -> np.ndarray:
    """The solver's stress ACF ``<p(r) p(r + dr)>`` per load on G's lags (Pa^2).

    ``<p^2> - G_p(dr)``, ``G_p`` the height-difference ACF of the pressure field computed
    as G is (the same bins: the map has the same size).
    """
    out = []
    for field in pressure:
        as_map = xrough.topography(field, spacing=1.0, unit="nm", periodic=periodic)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out.append(np.mean(field**2) - as_map.rough.acf().values)
    return np.array(out)


def run(case: Case, out: Path, refresh: bool = False) -> xr.Dataset:
    """Persson's areas and stress ACF from the map's G against the solver at every load.

    Cached in ``out/runs``; ``refresh`` recomputes the theory's side of a cached run.
    """
    path = out / "runs" / f"{case.name}.nc"
    if path.exists():
        ds = xr.load_dataset(path)
        if refresh or "p0" not in ds:
            ds = ds.drop_vars([v for v in ("p_star", "a_r", "a_ri", "G", "p0", "p_star_dr",
                                           "G_sigma") if v in ds])
            ds = xr.merge([ds, theory(surface(case))], combine_attrs="override")
            ds.to_netcdf(path)
        return ds
    topo = surface(case)
    t0 = time.perf_counter()
    ds = theory(topo)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = xrough.solve_contact(topo, E_star=E_STAR, p0=ds.p0.values, progress=False)
    ds = ds.assign(
        contact_area=("load", sim.contact_area.values),
        contact_pixels=("load", np.round(sim.contact_area.values * case.n**2)),
        converged=("load", sim.converged.values.astype(np.int8)),
        G_sigma_exact=(("load", "dr"), stress_acf_of(sim.pressure.values,
                                                     periodic=not case.open)))
    ds.attrs.update({**case._asdict(), "open": int(case.open), "n": case.n,
                     "seconds": time.perf_counter() - t0})
    path.parent.mkdir(parents=True, exist_ok=True)
    ds.to_netcdf(path)
    return ds


COLUMNS = ("set", "hurst", "rolloff", "cutoff", "lambda_s_px", "bandwidth", "ratio_l",
           "open", "seed", "n", *model_error.FEATURES, "p_star", "a_r", "a_ri",
           "contact_area", "contact_pixels", "converged")


def rows(which: str, runs: list[xr.Dataset]) -> list[dict]:
    """One row per surface and load."""
    out = []
    for ds in runs:
        for i in range(ds.sizes["load"]):
            # G's features as the package reads them now (from the run's G)
            features = model_error.features_of(ds["dr"].values, ds["G"].values,
                                               ds.attrs["finest_lag"])
            row = {"set": which, **{k: ds.attrs[k] for k in COLUMNS[1:10]}, **features}
            row.update({k: ds[k].values[i].item() for k in COLUMNS[-6:]})
            out.append(row)
    return out


STRESS_COLUMNS = ("hurst", "rolloff", "cutoff", "lambda_s_px", "bandwidth", "ratio_l", "open",
                  "seed", "lag_px", *model_error.FEATURES, "p_star", "p_star_0", "decay",
                  "ln_ratio")


def stress_rows(runs: list[xr.Dataset]) -> list[dict]:
    """One row per surface, load and lag: Persson's stress ACF against the solver's.

    ``ln_ratio = ln(F / F_exact)`` of the fluctuating parts ``F = G_sigma - p0^2``;
    ``decay``, Persson's ``F`` over its value at the first lag where it has one. Loads
    with fewer than :data:`MIN_PIXELS` contact pixels or not converged, and lags where a
    value or G's shape is missing or either ``F`` is not positive, are left out.
    """
    out = []
    for ds in runs:
        dr = ds["dr"].values
        shape = model_error.features_on_lags(dr, ds["G"].values)
        for i in range(ds.sizes["load"]):
            if ds.contact_pixels.values[i] < MIN_PIXELS or not ds.converged.values[i]:
                continue
            p0sq = float(ds.p0.values[i]) ** 2
            theory = ds.G_sigma.values[i] - p0sq
            exact = ds.G_sigma_exact.values[i] - p0sq
            first = np.flatnonzero(np.isfinite(theory) & (dr > 0))
            if first.size == 0:
                continue
            decay = theory / theory[first[0]]
            with np.errstate(divide="ignore", invalid="ignore"):
                ln_ratio = np.log(theory / exact)
            ok = (np.isfinite(ln_ratio) & np.all(np.isfinite(shape), axis=0)
                  & np.isfinite(ds.p_star_dr.values[i]) & (dr > 0))
            for j in np.flatnonzero(ok):
                row = {k: ds.attrs[k] for k in STRESS_COLUMNS[:8]}
                row.update({"lag_px": float(dr[j]),
                            **dict(zip(model_error.FEATURES, map(float, shape[:, j]))),
                            "p_star": float(ds.p_star_dr.values[i, j]),
                            "p_star_0": float(ds.p_star.values[i]),
                            "decay": float(decay[j]), "ln_ratio": float(ln_ratio[j])})
                out.append(row)
    return out


def write_csv(path: Path, table: list[dict], header: str, columns=COLUMNS,
              digits: int = 6) -> None:
    """Write ``table`` as CSV with ``header`` as comments (gzip for a ``.gz`` path)."""
    lines = ["# " + line for line in header.splitlines()] + [",".join(columns)]
    for r in table:
        lines.append(",".join(f"{r[c]:.{digits}g}" if isinstance(r[c], float) else str(r[c])
                              for c in columns))
    text = "\n".join(lines) + "\n"
    if path.suffix == ".gz":  # no time stamp: the same table gives the same bytes
        path.write_bytes(gzip.compress(text.encode(), mtime=0))
    else:
        path.write_text(text)


HEADER = """\
Persson's contact area from G against the boundary-element solver (xrough.solve_contact).
Made by: python benchmarks/model_error_study.py --write-table (build set, 3 seeds).
Periodic random-phase maps (eq. 35, rms gradient 0.1, E* = 1 MPa, 1 nm pixels) with the
roll-off and short cutoff named in each row; the theory a_r = erf(sqrt(2) p*) (eq. 29,
kappa = sqrt(8/pi)) and a_ri (eq. 50) as xrough.persson gives them at the map's finest lag,
p* = p0 / (E* gbar) there; contact_area the solver's share of pixels in contact.
Features of G at that lag (xrough._kernels.model_error.features_of): h_local, half the
local slope of ln G over ln dr from the lag to twice it; h_wide, the same from the lag to
eight times it."""


STRESS_HEADER = """\
Persson's stress ACF G_sigma (eq. 30/48, W = a_r) from G against the solver's at every lag.
Made by: python benchmarks/model_error_study.py --write-table (build set, 3 seeds).
The surfaces and loads of persson_area_error.csv (loads with at least 100 contact pixels);
the solver's stress ACF <p(r) p(r + dr)> from its pressure field, binned as G. ln_ratio =
ln(F / F_exact) of the fluctuating parts F = G_sigma - p0^2; decay, Persson's F over its
value at the first lag where it has one; p_star_0, p* at the map's finest lag; p_star and
G's features (h_local, h_wide, range:
xrough._kernels.model_error.features_on_lags) at the lag (lag_px, in pixels)."""


def main(argv=None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="model-error-study", help="output directory")
    p.add_argument("--set", choices=("build", "heldout", "both"), default="both")
    p.add_argument("--seeds", type=int, default=3, help="seeds per surface")
    p.add_argument("--jobs", type=int, default=1, help="surfaces solved at once")
    p.add_argument("--write-table", action="store_true",
                   help=f"write the build set to {TABLE.relative_to(TABLE.parents[2])} "
                   f"and {STRESS_TABLE.name}")
    p.add_argument("--refresh-theory", action="store_true",
                   help="recompute Persson's side of cached runs (after the package changed)")
    args = p.parse_args(argv)
    out = Path(args.out)
    sets = ("build", "heldout") if args.set == "both" else (args.set,)
    tables = {}
    for which in sets:
        todo = cases(which, args.seeds)
        t0 = time.perf_counter()
        with ProcessPoolExecutor(args.jobs) as pool:
            runs = list(pool.map(run, todo, itertools.repeat(out),
                                 itertools.repeat(args.refresh_theory)))
        solved = sum(ds.attrs["seconds"] for ds in runs)
        print(f"{which}: {len(runs)} surfaces, {solved / 60:.1f} min of solving "
              f"({(time.perf_counter() - t0) / 60:.1f} min now)")
        tables[which] = rows(which, runs)
        write_csv(out / f"{which}.csv", tables[which], HEADER)
        tables[f"{which}_stress"] = stress_rows(runs)
        write_csv(out / f"{which}_stress.csv.gz", tables[f"{which}_stress"], STRESS_HEADER,
                  STRESS_COLUMNS, digits=4)
    if args.write_table:
        write_csv(TABLE, tables["build"], HEADER)
        write_csv(STRESS_TABLE, tables["build_stress"], STRESS_HEADER, STRESS_COLUMNS,
                  digits=4)
        print(f"wrote {TABLE} and {STRESS_TABLE.name}")
    return tables


if __name__ == "__main__":
    main()
