"""Scale-dependent rms gradient gbar(dr) from G(dr): eq. 26 and its approximations.

``gbar^2(dr) = (1/2pi) int_0^{2pi/dr} dq q^3 C(q)`` (eq. 26) is the mean-square slope of
the surface with all wavelengths shorter than ``dr`` removed; it is what Persson theory
needs at resolution ``dr``. Three ways to get it from G:

``"exact"``
    eq. 26 with C(q) from G by the Hankel transform of eq. 10/11.
``"simple"``
    ``gbar^2 = 4 G(dr) / dr^2``, exact only in the ballistic regime (``q_s dr << 1``) and an
    overestimate elsewhere.
``"auto"``
    the first of these that G supports.
``"fit"``
    from the fit of G (:func:`xrough.fit_acf`): eq. 26 of the fitted model spectrum, or
    eq. 37/38 for a fit of eq. 36.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from .curves import check_acf

__all__ = ["rms_gradient", "GRADIENT_METHODS"]

GRADIENT_METHODS = ("auto", "exact", "simple", "fit")


def _simple(G: xr.DataArray) -> xr.DataArray:
    lf, gf = check_acf(G)
    dr = G["dr"] * lf
    return np.sqrt(4.0 * G * gf / dr**2)


def rms_gradient(G: xr.DataArray, *, method: str = "auto") -> xr.DataArray:
    r"""Scale-dependent rms gradient ``gbar(dr)`` (eq. 26 or its approximations).

    Parameters
    ----------
    G : xarray.DataArray
        Height-difference ACF on dim ``dr`` (length^2, ``dr`` in length).
    method : {'auto', 'exact', 'simple', 'fit'}
        Eq. 26 via the spectrum from eq. 10/11; ``sqrt(4 G / dr^2)``; or from the fit of G
        (eq. 26 of the fitted spectrum, or eq. 37/38 for eq. 36). ``'auto'`` (default)
        takes ``'exact'`` where G supports it on at least half of its lags, else ``'fit'``,
        else ``'simple'``, and says which in ``attrs["method"]`` (with
        ``attrs["fallback_reason"]``).

    Returns
    -------
    xarray.DataArray
        ``gbar`` on ``dr`` (dimensionless, ``units="1"``), ``attrs["method"]`` and the
        paper equation. ``"exact"`` returns only the lags where G supports the spectrum
        (see :func:`xrough.rms_gradient_exact`); the others return every lag of G.

    Raises
    ------
    ValueError
        If ``G`` is not a height-difference ACF or ``method`` is unknown.

    Notes
    -----
    .. math:: \bar g^2(\Delta r) = \frac{1}{2\pi}\int_0^{2\pi/\Delta r} dq\, q^3 C(q)
              \approx \frac{4 G(\Delta r)}{\Delta r^2}

    Examples
    --------
    >>> import numpy as np, xarray as xr
    >>> dr = xr.DataArray([1.0, 2.0, 4.0], dims="dr", name="dr", attrs={"units": "nm"})
    >>> G = xr.DataArray([0.25, 1.0, 4.0], dims="dr", coords={"dr": dr},
    ...                  attrs={"units": "nm2"})  # ballistic: G = gbar^2 dr^2 / 4, gbar = 1
    >>> rms_gradient(G, method="simple").values
    array([1., 1., 1.])
    """
    if method not in GRADIENT_METHODS:
        raise ValueError(f"method must be one of {GRADIENT_METHODS}, got {method!r}")
    if method == "auto":
        reasons = []
        for candidate in ("exact", "fit"):
            try:
                out = rms_gradient(G, method=candidate)
            except ValueError as err:
                reasons.append(f"{candidate}: {str(err).splitlines()[0]}")
                continue
            if candidate == "exact" and 2 * out.sizes["dr"] < G.sizes["dr"]:
                reasons.append(f"exact: determined on {out.sizes['dr']} of "
                               f"{G.sizes['dr']} lags only")
                continue
            if reasons:
                out.attrs["fallback_reason"] = "; ".join(reasons)
            return out
        out = rms_gradient(G, method="simple")
        out.attrs["fallback_reason"] = "; ".join(reasons)
        return out
    if method == "simple":
        out = _simple(G)
        equation = "gbar^2 ~ 4 G(dr) / dr^2 (ballistic approximation of eq. 26)"
    elif method == "exact":
        from .spectra import rms_gradient_exact

        out = rms_gradient_exact(G)
        equation = "eq. 26 with C(q) from eq. 10/11"
    else:
        from .fitting import fit_acf, gradient_from_fit

        params = fit_acf(G)
        out = gradient_from_fit(params, G["dr"])
        equation = ("eq. 26 of the fitted model spectrum" if params.attrs.get("model") ==
                    "spectrum" else "eq. 37/38 with the fit of eq. 36")
    out = out.drop_vars([c for c in out.coords if c not in out.dims and c != "dr"],
                        errors="ignore")
    out.name = "gbar"
    out.attrs = {**out.attrs, "units": "1", "long_name": "scale-dependent rms gradient",
                 "equation": equation, "method": method}
    return out
