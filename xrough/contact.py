"""Contact mechanics from G(dr): energy, stress ACF, Persson theory, patch radius.

Paper sections 2.3-2.6 and 3.4-3.6. Every function takes a height-difference ACF ``G``
(dim ``dr``, length^2; measured, stitched or from a model spectrum) and physical
parameters as numbers in SI, strings (``"25 MPa"``) or pint Quantities, and returns
DataArrays or Datasets in SI units (Pa, Pa^2, J m-2) with lengths in the unit of ``G``'s
``dr``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from scipy import optimize, special

from . import units as u
from .curves import check_acf, curves_si
from .gradient import rms_gradient

__all__ = ["elastic_energy", "stress_acf", "stress_acf_from_spectrum", "persson",
           "patch_radius", "KAPPA_PERSSON"]

#: Persson's small-pressure slope of the contact area, ``a_r ~ kappa p*`` (eq. 29).
KAPPA_PERSSON = float(np.sqrt(8 / np.pi))
THEORIES = ("persson", "modified")
_ENERGY = "[mass] / [time] ** 2"


def _positive(value: Any, dimension: str, what: str, *, allow_many: bool = False):
    """SI magnitude(s) of a positive physical parameter (numbers are SI)."""
    if isinstance(value, (list, tuple)) or (isinstance(value, np.ndarray) and
                                            value.dtype.kind in "OU"):
        mag = np.array([u.to_si(v, dimension, what=what) for v in value], dtype=float)
    else:
        mag = u.to_si(value, dimension, what=what)
    arr = np.atleast_1d(np.asarray(mag, dtype=float))
    if arr.ndim != 1 or (arr.size > 1 and not allow_many):
        raise ValueError(f"{what} must be a single value, got {value!r}")
    if not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ValueError(f"{what} must be positive and finite, got {value!r}")
    return arr if allow_many and np.ndim(mag) > 0 else float(arr[0])


def _apply_lines(G: xr.DataArray, func, out_dims: list[str], out_sizes: dict) -> np.ndarray:
    """Call ``func(curve)`` for every G line; stack results with the extra dims first."""
    _, curves, extra = curves_si(G)
    results = [func(c) for c in curves]
    return np.stack(results).reshape(extra + tuple(out_sizes[d] for d in out_dims))


def _extra_coords(G: xr.DataArray) -> dict:
    return {k: v for k, v in G.coords.items() if "dr" not in v.dims}


def _lag_coord(G: xr.DataArray, name: str = "dr", values=None, long_name="lag distance"):
    attrs = {"units": G["dr"].attrs["units"], "long_name": long_name}
    return (name, G["dr"].values if values is None else values, attrs)


# ---------------------------------------------------------------------------------------
# full contact: elastic energy (eq. 16, 44)
# ---------------------------------------------------------------------------------------
def elastic_energy(G: xr.DataArray, *, E_star: Any, a_c: Any = None) -> xr.Dataset:
    r"""Areal elastic energy of full contact (eq. 16) and of patches of radius a_c (eq. 44).

    .. math:: v_{el} = \frac{E^*}{4}\int_0^\infty d\Delta r\,\frac{G(\Delta r)}{\Delta r^2},
              \qquad v_{el}(a_c) = \frac{E^*}{4}\int_0^{a_c} d\Delta r\,
              \frac{G(\Delta r)}{\Delta r^2}

    Exact within linear elasticity for any (statistically isotropic) surface. Between the
    bins G is a power law; below the first bin it is continued ballistically
    (``G ~ r^2``), beyond the last bin flat; the shares of those continuations in
    ``v_el`` are reported.

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr`` (length^2), extra dims allowed.
    E_star : float, str or Quantity
        Contact modulus ``E*`` (Pa for numbers).
    a_c : array_like, str or Quantity, optional
        Patch radii for eq. 44 (numbers in the unit of ``dr``; default: the ``dr`` values).

    Returns
    -------
    xarray.Dataset
        ``v_el`` (J m-2), ``v_el_patch`` on ``a_c`` (J m-2), ``extrapolated_below`` and
        ``extrapolated_above`` (fractions of ``v_el`` from the continuations).

    Raises
    ------
    ValueError
        ``E_star <= 0``, or ``G`` not a height-difference ACF.

    Examples
    --------
    One sinusoid ``h0 cos(q x)`` has ``G = h0^2/2 (1 - J0(q dr))`` and
    ``v_el = q E* h0^2 / 8`` (eq. 12):

    >>> import numpy as np, xarray as xr
    >>> from scipy.special import j0
    >>> dr = np.geomspace(1e-4, 1e5, 4000)  # in um, q = 1 um-1, h0 = 1 um
    >>> G = xr.DataArray(0.5 * (1 - j0(dr)), dims="dr", attrs={"units": "um2"},
    ...                  coords={"dr": ("dr", dr, {"units": "um"})})
    >>> v = xrough.elastic_energy(G, E_star="1 MPa")
    >>> round(float(v.v_el) / (1e6 * 1e-6 / 8), 3)  # J m-2 against q E* h0^2 / 8
    1.0
    """
    E = _positive(E_star, "[pressure]", "E_star")
    lf, _ = check_acf(G)
    ac = G["dr"].values if a_c is None else np.atleast_1d(np.asarray(
        [u.length_in(a, G["dr"].attrs["units"], what="a_c") for a in np.atleast_1d(a_c)]
        if not isinstance(a_c, np.ndarray) else a_c, dtype=float))
    if np.any(ac <= 0):
        raise ValueError("a_c must be positive")

    def one(curve):
        cum, below, above = curve.cumulative_g_over_r2(ac * lf)
        total = curve.cumulative_g_over_r2(np.array([np.inf]))[0][0]
        return np.concatenate([[total, below / total, above / total], cum])

    res = _apply_lines(G, one, ["k"], {"k": ac.size + 3})
    extra = G.transpose(..., "dr").dims[:-1]
    quarter = E / 4
    ds = xr.Dataset(
        {
            "v_el": (extra, quarter * res[..., 0], {
                "units": "J m-2", "long_name": "areal elastic energy of full contact",
                "equation": "eq. 16: v_el = E*/4 int_0^inf G(r) / r^2 dr"}),
            "v_el_patch": (extra + ("a_c",), quarter * res[..., 3:], {
                "units": "J m-2", "long_name": "areal elastic energy to flatten patches "
                "of radius a_c", "equation": "eq. 44: v_el(a_c) = E*/4 int_0^a_c G/r^2 dr"}),
            "extrapolated_below": (extra, res[..., 1], {
                "units": "1", "long_name": "share of v_el from below the smallest dr "
                "(ballistic continuation)"}),
            "extrapolated_above": (extra, res[..., 2], {
                "units": "1", "long_name": "share of v_el from beyond the largest dr "
                "(flat continuation)"}),
        },
        coords={**_extra_coords(G), "a_c": ("a_c", ac, {
            "units": G["dr"].attrs["units"], "long_name": "patch radius"})},
        attrs={"E_star": E, "E_star_units": "Pa"},
    )
    return ds


# ---------------------------------------------------------------------------------------
# stress ACF and Persson theory (eq. 24, 29-30, 34, 39-42, 47-50)
# ---------------------------------------------------------------------------------------
def _contact_area(p_star, kappa):
    """Eq. 29 with slope ``kappa``: ``a_r = erf(sqrt(pi) kappa p* / 2)``."""
    return special.erf(0.5 * np.sqrt(np.pi) * kappa * p_star)


def _improved_area(p_star, a_r):
    """Eq. 50: ``a_ri = (1 - a_r^2) erf(sqrt(pi) p*) + a_r^3``."""
    return (1 - a_r**2) * special.erf(np.sqrt(np.pi) * p_star) + a_r**3


def _full_stress(G: xr.DataArray, E: float) -> np.ndarray:
    """Eq. 24 on every line of G, at G's own lags (Pa^2)."""
    dr, curves, extra = curves_si(G)
    lap = np.stack([c.laplacian(dr) for c in curves]).reshape(extra + (dr.size,))
    return (E / 2) ** 2 * lap


def _p0_values(p0):
    values = _positive(p0, "[pressure]", "p0", allow_many=True)
    return np.atleast_1d(values), np.ndim(values) > 0


def stress_acf(G: xr.DataArray, *, E_star: Any, p0: Any = None, theory: str = "persson",
               gradient: xr.DataArray | None = None, kappa: float = KAPPA_PERSSON,
               gradient_method: str = "auto") -> xr.DataArray:
    r"""Stress autocorrelation function in full (eq. 24) or partial contact (eq. 30/48).

    Full contact (exact within linear elasticity, the ``p0^2`` offset left out):

    .. math:: G_\sigma^{full}(\Delta r) = \left(\frac{E^*}{2}\right)^2 \nabla^2 G
              = \left(\frac{E^*}{2}\right)^2 \frac{1}{\Delta r}\frac{d}{d\Delta r}
              \left[\Delta r \frac{dG}{d\Delta r}\right]

    Partial contact: ``G_sigma = p0^2 + G_sigma_full W[a_r(p*(dr))]`` with
    ``p* = p0 / (E* gbar(dr))`` and ``W = a_r`` (``theory="persson"``, eq. 49) or
    ``W = a_r^2 / a_ri`` (``"modified"``, eq. 49-50).

    Differentiating a measured G twice would amplify its noise: the Laplacian is taken of a
    smoothing spline of ``ln G`` against ``ln dr``, weighted by the standard errors and
    smoothed by generalised cross-validation (``attrs["derivative"]``).

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers).
    p0 : float, str, Quantity or array, optional
        Mean pressure(s) (Pa); None for full contact. Several values give a ``p0`` dim.
    theory : {'persson', 'modified'}
        Weighting of eq. 49.
    gradient : xarray.DataArray, optional
        Precomputed ``gbar(dr)`` (e.g. from :func:`xrough.rms_gradient`), reused instead of
        computing it again.
    kappa : float
        Slope of ``a_r`` at small pressure (eq. 29; Persson: ``sqrt(8/pi)``).
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        How ``gbar`` is obtained when ``gradient`` is not given
        (see :func:`xrough.rms_gradient`).

    Returns
    -------
    xarray.DataArray
        ``G_sigma`` on ``dr`` (and ``p0``) in Pa^2.

    Raises
    ------
    ValueError
        ``E_star <= 0``, ``p0 <= 0``, unknown ``theory``, ``G`` not a height-difference ACF.

    Examples
    --------
    Ballistic G (``gbar = 0.1``): full-contact stress variance ``(E*/2)^2 gbar^2``.

    >>> import numpy as np, xarray as xr
    >>> dr = np.geomspace(1.0, 100.0, 30)
    >>> G = xr.DataArray(0.01 * dr**2 / 4, dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", dr, {"units": "nm"})})
    >>> S = xrough.stress_acf(G, E_star="1 MPa")
    >>> print(f"{float(S[0]):.4g} {S.attrs['units']}")
    2.5e+09 Pa2
    """
    if theory not in THEORIES:
        raise ValueError(f"theory must be one of {THEORIES}, got {theory!r}")
    E = _positive(E_star, "[pressure]", "E_star")
    if p0 is not None:
        ds = persson(G, E_star=E, p0=p0, theory=theory, gradient=gradient, kappa=kappa,
                     gradient_method=gradient_method, variables=("G_sigma",))
        return ds["G_sigma"]
    full = _full_stress(G, E)
    extra = G.transpose(..., "dr").dims[:-1]
    attrs = {"units": "Pa2", "long_name": "stress autocorrelation function",
             "derivative": "Laplacian of a GCV smoothing spline of ln G against ln dr, "
             "weighted by the standard error"}
    coords = {**_extra_coords(G), "dr": _lag_coord(G)}
    attrs["equation"] = "eq. 24 (full contact, p0^2 offset left out)"
    return xr.DataArray(full, dims=extra + ("dr",), coords=coords, name="G_sigma",
                        attrs=attrs)


def stress_acf_from_spectrum(C: xr.DataArray, dr: Any, *, E_star: Any) -> xr.DataArray:
    r"""Full-contact stress ACF of a model spectrum by the spectral route (eq. 22-24).

    .. math:: G_\sigma^{full}(\Delta r) = \left(\frac{E^*}{2}\right)^2 \frac{1}{2\pi}
              \int dq\, q^3 C(q) J_0(q\Delta r)
              = \left(\frac{E^*}{2}\right)^2 \left[\bar g^2 - G_{q^2C}(\Delta r)\right]

    where ``G_{q^2 C}`` is eq. 9 applied to the spectrum ``q^2 C(q)``: exact per power-law
    piece, so this is the reference that :func:`stress_acf` (a derivative of G) is tested
    against.

    Parameters
    ----------
    C : xarray.DataArray
        A model spectrum from :func:`xrough.model_spectrum`.
    dr : array_like
        Lags in the length unit of ``C``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers).

    Returns
    -------
    xarray.DataArray
        ``G_sigma`` on ``dr`` in Pa^2.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="1 um", lambda_s="10 nm",
    ...                           rms_gradient=0.1, unit="nm")
    >>> S = xrough.stress_acf_from_spectrum(C, [1e-3], E_star="1 MPa")
    >>> print(f"{float(S[0]):.4g}")  # (E*/2)^2 gbar^2 at dr -> 0
    2.5e+09
    """
    from ._kernels.hankel import acf_from_spectrum_kernel
    from .models import model_from_attrs

    E = _positive(E_star, "[pressure]", "E_star")
    model = model_from_attrs(C.attrs)
    if model is None:
        raise ValueError("stress_acf_from_spectrum needs a model spectrum "
                         "(xrough.model_spectrum)")
    lunit = u.format_units(u.parse_units(C["q"].attrs["units"]) ** -1)
    dr = np.atleast_1d(np.asarray(dr, dtype=float))
    knots = 0.0 if model.rolloff == "sharp" else 160.0
    g_q2 = acf_from_spectrum_kernel(dr, lambda q: q**2 * model(q), model.breakpoints,
                                    knots_per_decade=knots)
    values = (E / 2) ** 2 * (model.moment(2) - g_q2)
    return xr.DataArray(values, dims="dr", name="G_sigma",
                        coords={"dr": ("dr", dr, {"units": lunit,
                                                  "long_name": "lag distance"})},
                        attrs={"units": "Pa2", "long_name": "stress autocorrelation function",
                               "equation": "eq. 22-24, spectral route"})


PERSSON_VARIABLES = ("p_star", "a_r", "a_ri", "sigma_c", "sigma_quick", "G_sigma",
                     "Gamma_sigma", "G_du")


def _restrict_to(G: xr.DataArray, gradient: xr.DataArray) -> xr.DataArray:
    """G on the lags where gbar is given (the exact gbar covers only supported lags)."""
    if gradient.sizes["dr"] == G.sizes["dr"]:
        return G
    keep = np.isin(G["dr"].values, gradient["dr"].values)
    if keep.sum() != gradient.sizes["dr"]:
        return G  # not a subset: _gradient_on explains
    return G.isel(dr=np.flatnonzero(keep))


def _gradient_on(gradient: xr.DataArray, G: xr.DataArray) -> np.ndarray:
    """Gbar on G's lags, refusing a gradient that does not cover them."""
    gradient = gradient.transpose(..., "dr")
    if gradient.sizes["dr"] != G.sizes["dr"] or not np.allclose(gradient["dr"].values,
                                                               G["dr"].values, rtol=1e-9):
        raise ValueError(
            "the rms gradient is not given on the lags of G (an 'exact' gradient is only "
            "defined where G supports the spectrum); restrict G with G.sel(dr=gbar.dr) or "
            "use gradient_method='simple' or 'fit'")
    values = np.broadcast_to(gradient.values, G.shape)
    if not np.all(np.isfinite(values)) or np.any(values <= 0):
        raise ValueError("the rms gradient must be positive and finite on every lag of G")
    return values


def _quick_stress(G: xr.DataArray, fit: xr.Dataset, E: float, p0s: np.ndarray) -> np.ndarray:
    """Eq. 41 below lambda_r, eq. 42 beyond it, never below p0 (shape p0, ..., dr)."""
    from ._kernels.shape_factors import rolloff_factor, self_affine_factor

    lf, gf = check_acf(G)
    hurst = np.asarray(fit["hurst"].values, dtype=float)
    rolloff = str(fit.attrs.get("rolloff", "sharp"))
    c_sa = self_affine_factor(np.clip(hurst, 1e-3, 1 - 1e-3))
    c_ro = rolloff_factor(np.clip(hurst, 1e-3, 1 - 1e-3), rolloff=rolloff)
    lam_r = np.asarray(fit["lambda_r"].values, dtype=float) * lf
    sig_h = np.asarray(fit["sigma_h"].values, dtype=float) * lf
    extra = (...,) + (None,)
    dr = G["dr"].values * lf
    g = G.values * gf
    sa = E * np.sqrt(np.asarray(c_sa)[extra] * g) / dr
    ro = E * np.sqrt(np.asarray(c_ro)[extra]) * lam_r[extra] * sig_h[extra] / dr**2
    est = np.where(dr < lam_r[extra], sa, ro)
    return np.maximum(est[None], p0s.reshape((-1,) + (1,) * G.ndim))





def persson(G: xr.DataArray, *, E_star: Any, p0: Any, theory: str = "persson",
            kappa: float = KAPPA_PERSSON, gradient: xr.DataArray | None = None,
            gradient_method: str = "auto", variables: tuple[str, ...] | None = None,
            fit: xr.Dataset | None = None) -> xr.Dataset:
    r"""Real-space Persson theory of partial contact as a function of resolution ``dr``.

    Wherever Persson theory evaluates a function of wavenumber at resolution ``2 pi / q``,
    it is evaluated at ``dr = 2 pi / q`` from G:

    - ``p_star = p0 / (E* gbar(dr))``, the reduced pressure;
    - ``a_r = erf(sqrt(pi) kappa p* / 2)`` (eq. 29; ``erf(sqrt(2) p*)`` for Persson's
      ``kappa = sqrt(8/pi)``), the relative contact area at resolution ``dr``;
    - ``a_ri = (1 - a_r^2) erf(sqrt(pi) p*) + a_r^3`` (eq. 50);
    - ``sigma_c = p0 / a_r`` (eq. 39/40), the mean contact stress;
    - ``sigma_quick``: the quick estimates ``E* sqrt(c_sa(H) G(dr)) / dr`` below
      ``lambda_r`` (eq. 41) and ``E* sqrt(c_ro(H)) lambda_r sigma_h / dr^2`` beyond it
      (eq. 42), or ``p0`` where that is larger, with ``H``, ``sigma_h``, ``lambda_r`` from
      :func:`xrough.fit_acf` (or ``fit``);
    - ``G_sigma = p0^2 + (E*/2)^2 Laplacian(G) W`` (eq. 30/48), ``W = a_r`` or
      ``a_r^2 / a_ri`` (eq. 49);
    - ``Gamma_sigma = G_sigma / a(dr -> 0)`` (eq. 47, ``a = a_r`` or ``a_ri``);
    - ``G_du = G W`` (eq. 34), the displacement ACF.

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers), > 0.
    p0 : float, str, Quantity or array
        Mean pressure(s), > 0; several give a ``p0`` dim (vectorised).
    theory : {'persson', 'modified'}
        Weighting of eq. 49 for ``G_sigma``, ``Gamma_sigma`` and ``G_du``.
    kappa : float
        Small-pressure slope of the contact area (simulations suggest about 2).
    gradient : xarray.DataArray, optional
        Precomputed ``gbar(dr)`` on the same ``dr``; computed once otherwise.
    gradient_method : {'auto', 'exact', 'simple', 'fit'}
        See :func:`xrough.rms_gradient`. The exact gradient exists only on the lags where G
        supports the spectrum; the result then covers those lags only. ``'auto'`` falls
        back to the fit where G does not support it.
    variables : tuple of str, optional
        Only these outputs (others are not computed); default all of
        ``p_star, a_r, a_ri, sigma_c, sigma_quick, G_sigma, Gamma_sigma, G_du``.
    fit : xarray.Dataset, optional
        Precomputed :func:`xrough.fit_acf` result for ``sigma_quick``.

    Returns
    -------
    xarray.Dataset
        On ``dr`` (and ``p0``); units 1, Pa, Pa^2 and length^2.

    Raises
    ------
    ValueError
        Non-positive ``E_star``, ``p0`` or ``kappa``, unknown options, invalid G.

    Examples
    --------
    >>> C = xrough.model_spectrum(hurst=0.8, lambda_r="10 um", lambda_s="10 nm",
    ...                           rms_gradient=1.0, unit="um")
    >>> G = xrough.acf_from_spectrum(C, dr_min="1 nm", dr_max="1 mm")
    >>> ds = xrough.persson(G, E_star="25 MPa", p0=["0.1 MPa", "1 MPa"])
    >>> ds.a_r.dims, ds.sigma_c.attrs["units"]
    (('p0', 'dr'), 'Pa')
    """
    if theory not in THEORIES:
        raise ValueError(f"theory must be one of {THEORIES}, got {theory!r}")
    if not (np.isfinite(kappa) and kappa > 0):
        raise ValueError(f"kappa must be positive, got {kappa!r}")
    wanted = PERSSON_VARIABLES if variables is None else tuple(variables)
    unknown = set(wanted) - set(PERSSON_VARIABLES)
    if unknown:
        raise ValueError(f"unknown variables {sorted(unknown)}; choose from "
                         f"{PERSSON_VARIABLES}")
    E = _positive(E_star, "[pressure]", "E_star")
    p0s, many = _p0_values(p0)
    check_acf(G)
    G = G.transpose(..., "dr")
    extra = G.dims[:-1]
    dims = ("p0",) + extra + ("dr",)
    pshape = (-1,) + (1,) * len(G.dims)
    out: dict[str, tuple] = {}
    restricted = "none"
    if set(wanted) - {"sigma_quick"}:  # everything else needs gbar(dr)
        if gradient is None:
            gradient = rms_gradient(G, method=gradient_method)
        full_range = (float(G["dr"][0]), float(G["dr"][-1]), G.sizes["dr"])
        G = _restrict_to(G, gradient)
        gbar = _gradient_on(gradient, G)
        if G.sizes["dr"] < full_range[2]:
            restricted = (f"{G.sizes['dr']} of {full_range[2]} lags of G, "
                          f"{float(G['dr'][0]):.4g} to {float(G['dr'][-1]):.4g} "
                          f"{G['dr'].attrs['units']}: where the rms gradient is determined")
        p_star = p0s.reshape(pshape) / (E * gbar[None])
        a_r = _contact_area(p_star, kappa)
        need_ai = theory == "modified" or "a_ri" in wanted
        a_ri = _improved_area(p_star, a_r) if need_ai else None
        weight = a_r if theory == "persson" else a_r**2 / a_ri
    if "p_star" in wanted:
        out["p_star"] = (dims, p_star * np.ones_like(a_r), {
            "units": "1", "long_name": "reduced pressure p0 / (E* gbar)", "equation":
            "eq. 29"})
    if "a_r" in wanted:
        out["a_r"] = (dims, a_r, {"units": "1", "long_name": "relative contact area",
                                  "equation": "eq. 29: erf(sqrt(pi) kappa p* / 2)"})
    if "a_ri" in wanted:
        out["a_ri"] = (dims, a_ri, {"units": "1", "long_name":
                                    "improved relative contact area", "equation": "eq. 50"})
    if "sigma_c" in wanted:
        out["sigma_c"] = (dims, p0s.reshape(pshape) / a_r, {
            "units": "Pa", "long_name": "mean contact stress at resolution dr",
            "equation": "eq. 39/40: p0 / a_r"})
    if "sigma_quick" in wanted:
        if fit is None:
            from .fitting import fit_acf

            fit = fit_acf(G)
        out["sigma_quick"] = (dims, _quick_stress(G, fit, E, p0s), {
            "units": "Pa", "long_name": "quick estimate of the mean contact stress",
            "equation": "eq. 41 (dr < lambda_r), eq. 42 (dr > lambda_r), at least p0"})
    if "G_sigma" in wanted or "Gamma_sigma" in wanted:
        full = _full_stress(G, E)
        g_sigma = p0s.reshape(pshape) ** 2 + full[None] * weight
        if "G_sigma" in wanted:
            out["G_sigma"] = (dims, g_sigma, {
                "units": "Pa2", "long_name": "stress autocorrelation function",
                "equation": f"eq. 30/48 with W of eq. 49 ({theory})"})
        if "Gamma_sigma" in wanted:
            p_zero = p0s.reshape(pshape) / (E * gbar[..., :1][None])
            a0 = _contact_area(p_zero, kappa)
            if theory == "modified":
                a0 = _improved_area(p_zero, a0)
            out["Gamma_sigma"] = (dims, g_sigma / a0, {
                "units": "Pa2", "long_name": "reduced stress autocorrelation function",
                "equation": f"eq. 47 ({theory}: divided by "
                f"{'a_ri' if theory == 'modified' else 'a_r'} at the smallest dr)"})
    if "G_du" in wanted:
        out["G_du"] = (dims, G.values[None] * weight, {
            "units": G.attrs["units"], "long_name": "displacement autocorrelation function",
            "equation": f"eq. 34 with W of eq. 49 ({theory})"})
    coords = {**_extra_coords(G), "dr": _lag_coord(G),
              "p0": ("p0", p0s, {"units": "Pa", "long_name": "mean pressure"})}
    ds = xr.Dataset(out, coords=coords, attrs={
        "E_star": E, "E_star_units": "Pa", "kappa": float(kappa), "theory": theory,
        "gradient_method": "none" if gradient is None else gradient.attrs.get("method",
                                                                              "given"),
        "note": "real-space Persson theory: functions of q evaluated at dr = 2 pi / q",
        "dr_restricted_to": restricted})
    if not many:
        ds = ds.isel(p0=0)
    return ds


# ---------------------------------------------------------------------------------------
# adhesion: patch radius (eq. 43-46)
# ---------------------------------------------------------------------------------------
def _first_root(f, lo: float, hi: float, n: int = 4000) -> float:
    """Smallest root of ``f`` on a log grid of [lo, hi] (inf if ``f`` stays negative)."""
    grid = np.geomspace(lo, hi, n)
    vals = f(grid)
    sign = np.flatnonzero(vals >= 0)
    if sign.size == 0:
        return np.inf
    k = sign[0]
    if k == 0:
        return float(grid[0])
    return float(optimize.brentq(lambda x: float(f(np.array([x]))[0]), grid[k - 1], grid[k],
                                 xtol=1e-14 * grid[k], rtol=1e-12))


def patch_radius(G: xr.DataArray, *, E_star: Any, gamma: Any) -> xr.Dataset:
    r"""Radius of spontaneously adhering patches (Dahlquist-type criterion, eq. 43-46).

    - upper estimate (eq. 44): the smallest ``a_c`` with ``gamma = v_el(a_c)``;
    - refined (eq. 46): the patch grows while ``a_c^2 [v_el(a_c) - gamma]`` decreases:
      the smallest ``a_c`` with ``gamma = v_el(a_c) + E* G(a_c) / (8 a_c)``;

    with ``v_el(a_c) = (E*/4) int_0^{a_c} G(r)/r^2 dr``. When ``gamma`` exceeds the energy
    of full contact, no finite radius solves the equation and the result is ``inf`` (the
    surfaces stick everywhere).

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on ``dr``.
    E_star : float, str or Quantity
        Contact modulus (Pa for numbers), > 0.
    gamma : float, str or Quantity
        Work of adhesion per area (J m-2 for numbers), > 0.

    Returns
    -------
    xarray.Dataset
        ``a_c`` (eq. 46) and ``a_c_upper`` (eq. 44) in the unit of ``dr``.

    Raises
    ------
    ValueError
        Non-positive ``E_star`` or ``gamma``; invalid G.

    Examples
    --------
    Ballistic G (``gbar = 1``): eq. 44 gives ``16 gamma / (E* gbar^2)``, eq. 46 two thirds
    of it.

    >>> import numpy as np, xarray as xr
    >>> dr = np.geomspace(1e-3, 1e3, 50)
    >>> G = xr.DataArray(dr**2 / 4, dims="dr", attrs={"units": "nm2"},
    ...                  coords={"dr": ("dr", dr, {"units": "nm"})})
    >>> pr = xrough.patch_radius(G, E_star="25 MPa", gamma="50 mJ/m^2")
    >>> print(f"{float(pr.a_c_upper):.2f} {float(pr.a_c):.2f} {pr.a_c.attrs['units']}")
    32.00 21.33 nm
    """
    E = _positive(E_star, "[pressure]", "E_star")
    gam = _positive(gamma, _ENERGY, "gamma")
    lf, _ = check_acf(G)

    def one(curve):
        lo, hi = curve.dr[0] * 1e-6, curve.dr[-1] * 1e6

        def upper(a):
            return E / 4 * curve.cumulative_g_over_r2(a)[0] - gam

        def refined(a):
            return upper(a) + E * curve(a) / (8 * a)

        return np.array([_first_root(refined, lo, hi), _first_root(upper, lo, hi)]) / lf

    res = _apply_lines(G, one, ["k"], {"k": 2})
    extra = G.transpose(..., "dr").dims[:-1]
    unit = G["dr"].attrs["units"]
    return xr.Dataset(
        {"a_c": (extra, res[..., 0], {"units": unit, "long_name": "adhesive patch radius",
                                      "equation": "eq. 46: gamma = v_el(a_c) + E* G(a_c) / "
                                      "(8 a_c)"}),
         "a_c_upper": (extra, res[..., 1], {"units": unit, "long_name":
                                            "adhesive patch radius, upper estimate",
                                            "equation": "eq. 44: gamma = v_el(a_c)"})},
        coords=_extra_coords(G),
        attrs={"E_star": E, "E_star_units": "Pa", "gamma": gam, "gamma_units": "J m-2"})
