"""Random periodic self-affine surfaces and profiles with a model spectrum (eq. 35).

Fourier synthesis on a periodic grid: ``h(r) = sum_q h~(q) exp(i q.r)`` with
``<|h~(q)|^2> = C(q) / A`` (docs/theory.md conventions), the complex amplitudes drawn as the
FFT of white Gaussian noise (so Hermitian symmetry is exact) or, with
``random_amplitudes=False``, with fixed moduli and random phases. A profile is one line
scan of such an isotropic surface: its 1D spectrum is the projection of ``C(q)``, so the
profile has the same G(dr) as the surface.
"""

from __future__ import annotations

import dataclasses
import os
from typing import Any

import numpy as np
import xarray as xr

from . import units as u
from ._kernels.checks import require_count
from ._kernels.deferred import fft as sfft
from ._kernels.hankel import profile_spectrum_kernel
from .models import model_attrs, self_affine_model
from .topography import topography
from .units import QuantityLike

__all__ = ["self_affine_surface"]


#: float64 arrays of the map's size that synthesis holds at once (white noise, its
#: transform, the spectrum and the heights).
_ARRAYS_AT_ONCE = 4


def _require_memory(ns: tuple) -> None:
    """Refuse a size whose synthesis needs more memory than the machine has."""
    need = float(np.prod(ns, dtype=float)) * 8 * _ARRAYS_AT_ONCE
    try:
        have = float(os.sysconf("SC_PAGE_SIZE")) * float(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # not a POSIX system: no bound known
        return
    if need > have:
        raise ValueError(f"n = {ns}: {np.prod(ns, dtype=float):.3g} points need about "
                         f"{need / 2**30:.3g} GiB to synthesise, more than this machine's "
                         f"{have / 2**30:.3g} GiB; use fewer points")


def _as_tuple(value: Any, nd: int, what: str) -> tuple:
    if isinstance(value, (tuple, list)):
        if len(value) != nd:
            raise ValueError(f"{what} needs {nd} entries, got {len(value)}")
        return tuple(value)
    return (value,) * nd


def self_affine_surface(
    *,
    hurst: float,
    lambda_r: QuantityLike,
    lambda_s: QuantityLike,
    size: QuantityLike,
    n: int | tuple[int, int],
    rms_height: QuantityLike | None = None,
    rms_gradient: QuantityLike | None = None,
    C_r: QuantityLike | None = None,
    lambda_0: QuantityLike | None = None,
    rolloff: str = "sharp",
    unit: str = "m",
    profile: bool = False,
    cutoff: str = "sharp",
    random_amplitudes: bool = True,
    seed: int | np.random.Generator | None = None,
) -> xr.DataArray:
    r"""Random periodic self-affine topography with the spectrum of eq. 35.

    Parameters
    ----------
    hurst : float
        Hurst exponent H, 0 < H < 1.
    lambda_r, lambda_s : float, str or Quantity
        Roll-off wavelength ``2 pi / q_r`` and short-wavelength cutoff ``2 pi / q_s``
        (numbers in ``unit``). ``lambda_s`` must be at least two pixels.
    size : float, str, Quantity or pair
        Physical size of the periodic domain ``(Ly, Lx)`` (one value: square).
    n : int or pair of int
        Grid points ``(ny, nx)`` (one value: square; the number of points of a profile).
    rms_height, rms_gradient, C_r : optional
        Exactly one sets the amplitude: rms height (length), rms gradient (dimensionless)
        or plateau ``C_r`` (length^4) of the model's continuous spectrum (docs/theory.md,
        "Synthetic surfaces": a realisation scatters around them).
    lambda_0 : float, str or Quantity, optional
        Long-wavelength cutoff ``2 pi / q_0`` of the model (default: the system size).
    rolloff : {'sharp', 'smooth'}
        Eq. 35's flat plateau below ``q_r``, or ``C ~ [1 + (q/q_r)^2]^-(1+H)``.
    unit : str
        Length unit of the output (heights and coordinates).
    profile : bool
        Return a 1D line scan (dims ``x``) of the isotropic surface instead of a map.
    cutoff : {'sharp', 'gaussian'}
        Eq. 35's sharp end at ``q_s``, or the spectrum times ``exp(-(q/q_s)^2)`` (a Gaussian
        transfer of an instrument; ``lambda_s`` may then be as short as one pixel).
    random_amplitudes : bool
        Gaussian random amplitudes (a Gaussian random field, default) or fixed moduli
        ``sqrt(C/A)`` with random phases (less scatter, not Gaussian at the largest scales).
    seed : int or numpy.random.Generator, optional
        Random seed.

    Returns
    -------
    xarray.DataArray
        Periodic topography (``attrs["periodic"] = 1``) whose attrs record the model in the
        output unit (``hurst``, ``q_r``, ``q_s``, ``q_0``, ``rolloff``, ``C_r``, ``rms_height``,
        ``rms_gradient``: :func:`xrough.models.model_attrs`) and the ``seed``.

    Raises
    ------
    ValueError
        Invalid model parameters, or ``lambda_s`` below two pixels (Gaussian cutoff: one).

    See Also
    --------
    xrough.model_spectrum : the model spectrum as a DataArray.
    xrough.acf_from_spectrum : its exact G(dr) (eq. 9).

    Examples
    --------
    >>> import xrough
    >>> topo = xrough.self_affine_surface(hurst=0.8, lambda_r="1 um", lambda_s="20 nm",
    ...                                   size="4 um", n=512, rms_gradient=0.3, seed=1,
    ...                                   unit="nm")
    >>> topo.dims, topo.attrs["units"], round(float(topo.x[1]), 3)
    (('y', 'x'), 'nm', 7.812)
    """
    nd = 1 if profile else 2
    sizes = _as_tuple(size, nd, "size")
    ns = tuple(require_count(k, "n (points per dim)", minimum=2) for k in _as_tuple(n, nd, "n"))
    _require_memory(ns)
    lengths = tuple(u.length_in(s, unit, what="size") for s in sizes)
    if lambda_0 is None:
        lambda_0 = f"{max(lengths)!r} {unit}"
    model = self_affine_model(hurst=hurst, lambda_r=lambda_r, lambda_s=lambda_s,
                              lambda_0=lambda_0, C_r=C_r, rms_height=rms_height,
                              rms_gradient=rms_gradient, rolloff=rolloff, unit=unit,
                              cutoff=cutoff)
    spacing = tuple(L / k for L, k in zip(lengths, ns))
    if 2 * np.pi / model.q_s < (2 if cutoff == "sharp" else 1) * max(spacing) * (1 - 1e-9):
        raise ValueError(
            f"lambda_s = {2 * np.pi / model.q_s:g} {unit} is shorter than "
            f"{'two pixels' if cutoff == 'sharp' else 'a pixel'} ({max(spacing):g} {unit} "
            "each): the cutoff is not resolved; use more points"
        )
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    white = rng.standard_normal(ns)
    coeff = sfft.rfftn(white, workers=-1)
    if not random_amplitudes:
        mod = np.abs(coeff)
        coeff = np.divide(coeff, mod, out=np.ones_like(coeff), where=mod > 0)
        coeff *= np.sqrt(np.prod(ns))
    qs = [2 * np.pi * sfft.fftfreq(k, d) for k, d in zip(ns[:-1], spacing[:-1])]
    qs.append(2 * np.pi * sfft.rfftfreq(ns[-1], spacing[-1]))
    # grid modes that sit on a cutoff (q_0 = 2 pi / L is the lowest mode by default) are
    # kept whatever the round-off of the unit: the band is closed, [q_0, q_s]
    band = dataclasses.replace(model, q_0=model.q_0 * (1 - 1e-9),
                               q_s=model.q_s * (1 + 1e-9) if cutoff == "sharp" else model.q_s)
    if profile:
        C = profile_spectrum_kernel(qs[0], band, band.breakpoints)
    else:
        C = band(np.hypot(qs[0][:, None], qs[1][None, :]))
    C = np.asarray(C, dtype=float)
    C.flat[0] = 0.0  # zero mean
    area = float(np.prod(lengths))
    coeff *= np.sqrt(np.prod(ns) * C / area)
    heights = sfft.irfftn(coeff, s=ns, workers=-1)
    attrs = {"source": "synthetic self-affine surface", **model_attrs(model),
             "random_amplitudes": int(bool(random_amplitudes)),
             "seed": -1 if seed is None or isinstance(seed, np.random.Generator) else int(seed)}
    return topography(heights, spacing=spacing if nd == 2 else spacing[0], unit=unit,
                      periodic=True, attrs=attrs)
