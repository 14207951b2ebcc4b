"""Quality of a result: one convention for numbers that may mean nothing.

A fit that did not converge, a gradient taken from a failed fit or a G whose arithmetic
overflowed returns numbers all the same. xrough marks such results rather than present
them as findings, in one way for every result (see docs/quality.md):

``attrs["quality"]``
    ``"good"``, ``"questionable"`` or ``"failed"`` (:data:`LEVELS`): the worst level of
    the checks of a result of one curve.  A result of many curves (extra dims such as
    ``scan``), or a lazy (dask) one, has it only from checks that did not need the data
    (the same with numpy and dask); its verdict per curve is the coordinate below, and
    :func:`worst` reads (computes) it.
``attrs["quality_notes"]``
    why, in words, ``"; "``-joined (each note names the check, what it found and what to
    do); ``""`` for a good result.
coordinate ``quality_flag``
    the level per curve as an ``int8`` (0 good, 1 questionable, 2 failed; CF
    ``flag_values``/``flag_meanings``), on the extra dims of the result (0-d for one
    curve); computed with the result, so it is lazy where the result is.
coordinate ``quality_reasons``
    which check set that level, per curve: a CF bit mask (``flag_masks``/
    ``flag_meanings``, the words of :data:`REASONS`), on the same dims and as lazy as the
    flag; the same for a dask result and its numpy twin (whose notes give the numbers), so
    that the verdict of each map of a stack, or of a lazy map, says why
    (:func:`reasons_of`). Carried from input to result (a fit of a G whose regions
    disagree says ``regions_disagree``).
:class:`QualityWarning`
    emitted once per marked result, naming the result, the problem and what to do.

Numbers that mean nothing (a fit parameter of a failed fit, a cutoff far outside the
measured lags) are NaN, never a plausible-looking value; the notes say why.

All attributes are str, so a NetCDF archive keeps them; the flag is an ``int8`` coordinate.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import sys
import warnings
from collections.abc import Iterable, Iterator
from types import FrameType

import numpy as np
import xarray as xr

from ._kernels.deferred import dask_array as dsa

__all__ = ["LEVELS", "QualityWarning", "FLAG", "REASON", "REASONS", "SEPARATOR",
           "level_code", "worst", "mark", "mark_curves", "flag_coord", "flag_of", "notes_of",
           "reasons_of", "unrated", "warn", "user_stacklevel", "recorded", "inherit"]

#: The levels, best first; the integer code of a level is its index.
LEVELS = ("good", "questionable", "failed")
#: Name of the per-curve flag coordinate.
FLAG = "quality_flag"
#: Name of the per-curve coordinate of the reasons (a bit mask).
REASON = "quality_reasons"
#: The checks that rate a result per curve, one bit each (bit k: the k-th word), and what
#: each means; the notes of a computed result give the numbers.
REASONS = {
    "regions_disagree": "G of the map's four quarters scatters beyond their finite-area "
                        "error (not a stationary surface: a band, drift, particle, scratch)",
    "anisotropic": "G along the two axes of the map differs beyond its errors",
    "above_target_error": "G's relative standard error exceeds the target asked for",
    "few_valid_points": "too few valid points for the spectrum",
    "beyond_tip": "curvature beyond the tip's: the map may show the tip, not the surface",
    "fit": "the fit does not describe G or is not determined (see variable fit_problems)",
    "gradient": "the rms gradient's own checks (route, resolution, plateau, the fit it "
                "uses)",
    "contact": "the contact result's own checks (inputs failed, outside the model's range)",
    "stitch_levels": "the stitched measurements' levels differ beyond their errors",
    "input": "an input of the result was rated so (its notes say why)",
}
#: Separator of the notes in ``attrs["quality_notes"]``.
SEPARATOR = "; "


class QualityWarning(UserWarning):
    """A result is questionable or failed; its ``quality_notes`` attribute says why.

    Silence it with ``warnings.filterwarnings("ignore", category=xrough.QualityWarning)``
    (the attributes and the ``quality_flag`` coordinate are set all the same).
    """


#: The folder of the package: frames of files below it are xrough's own.
_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep


def user_stacklevel() -> int:
    """Return the ``stacklevel`` that points a warning at the user's line.

    Counted for a :func:`warnings.warn` call in the function that calls this one: the
    frame just outside the outermost xrough frame on the stack, i.e. the line of the
    user's script, notebook cell or test that called into xrough (through the accessor,
    a public function, or xrough code that numpy or xarray called back).

    Returns
    -------
    int

    Examples
    --------
    >>> def inside():  # a frame outside xrough calling this: its caller is the user
    ...     return user_stacklevel()
    >>> inside()
    1
    """
    frame: FrameType | None = sys._getframe(1)  # the one that will call warnings.warn: 1
    level, found = 1, 1
    while frame is not None:
        if os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE_DIR):
            found = level + 1
        frame = frame.f_back
        level += 1
    return found


def warn(message, category: type[Warning] = UserWarning) -> None:
    """Issue a warning at the user's line (the one warning call of xrough).

    Parameters
    ----------
    message : str or Warning
        The text (or a warning instance, whose class is then the category).
    category : type of Warning
        E.g. :class:`QualityWarning`, :class:`UserWarning`, :class:`RuntimeWarning`.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     warn("a note", RuntimeWarning)
    >>> caught[0].category.__name__, caught[0].filename.startswith("<doctest")  # this line
    ('RuntimeWarning', True)
    """
    for said in _RECORDINGS.get():
        said.append((message, category))
    if _QUIET.get() and issubclass(category, QualityWarning):
        return  # said by the result that holds this one (see quiet)
    warnings.warn(message, category, stacklevel=user_stacklevel())


#: The open :func:`recorded` lists of this context (innermost last).
_RECORDINGS: contextvars.ContextVar[tuple[list, ...]] = contextvars.ContextVar(
    "xrough_recorded_warnings", default=())


#: Inside :func:`quiet`: quality warnings are recorded but not issued.
_QUIET: contextvars.ContextVar[bool] = contextvars.ContextVar("xrough_quiet",
                                                              default=False)


@contextlib.contextmanager
def quiet() -> Iterator[None]:
    """Hold back the :class:`QualityWarning` of the steps inside the block.

    For a result computed from intermediate results (``persson`` from a fit and a
    gradient it computes itself): their notes become the result's notes, and the result
    warns once, so that one cause is said once.  :func:`recorded` still collects them (a
    step kept by :func:`xrough.memo.by_content` says them when the user asks for it).

    Examples
    --------
    >>> import warnings, xarray as xr
    >>> with warnings.catch_warnings(record=True) as caught, quiet():
    ...     warnings.simplefilter("always")
    ...     r = mark(xr.DataArray(1.0), "no plateau in G", what="sigma_h")
    >>> r.attrs["quality"], len(caught)
    ('questionable', 0)
    """
    token = _QUIET.set(True)
    try:
        yield
    finally:
        _QUIET.reset(token)


@contextlib.contextmanager
def recorded() -> Iterator[list]:
    """Collect what :func:`warn` says inside the block (it is still issued as usual).

    Yields a list that fills with ``(message, category)`` pairs, so that a result
    computed once can say the same again when it is handed out a second time
    (:func:`xrough.memo.by_content`).  Per context (thread, task): safe under threads.

    Examples
    --------
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     with recorded() as said:
    ...         warn("a note", QualityWarning)
    >>> said == [("a note", QualityWarning)]
    True
    """
    said: list = []
    token = _RECORDINGS.set((*_RECORDINGS.get(), said))
    try:
        yield said
    finally:
        _RECORDINGS.reset(token)


def level_code(level) -> int:
    """Return the integer code (0, 1, 2) of a level given by name or code.

    Parameters
    ----------
    level : {'good', 'questionable', 'failed'} or int

    Returns
    -------
    int

    Examples
    --------
    >>> level_code("questionable"), level_code(2)
    (1, 2)
    """
    if isinstance(level, str):
        if level not in LEVELS:
            raise ValueError(f"quality level must be one of {LEVELS}, got {level!r}")
        return LEVELS.index(level)
    code = int(level)
    if not 0 <= code < len(LEVELS):
        raise ValueError(f"quality code must be 0, 1 or 2, got {level!r}")
    return code


def _codes_of(item) -> list[int]:
    """Codes of one item of :func:`worst` (a level, a result, or an iterable of them)."""
    if item is None:
        return []
    if isinstance(item, (str, int, np.integer)):
        return [level_code(item)]
    if isinstance(item, (xr.DataArray, xr.Dataset)):
        codes = []
        if "quality" in item.attrs and item.attrs["quality"] in LEVELS:
            codes.append(level_code(item.attrs["quality"]))
        if FLAG in item.coords and item[FLAG].size:
            codes.append(int(np.nanmax(np.asarray(item[FLAG].values))))
        return codes
    if isinstance(item, np.ndarray):
        return [int(np.max(item))] if item.size else []
    if isinstance(item, Iterable):
        return [c for x in item for c in _codes_of(x)]
    return [level_code(item)]


def worst(*items) -> str:
    """Return the worst level among levels, codes, arrays of codes or results.

    A result (DataArray or Dataset) counts with its ``attrs["quality"]`` and its
    ``quality_flag`` coordinate (computed if lazy); nothing known counts as good.

    Parameters
    ----------
    *items : str, int, ndarray, DataArray, Dataset, or iterables of these

    Returns
    -------
    {'good', 'questionable', 'failed'}

    Examples
    --------
    >>> worst("good", "questionable"), worst(), worst([0, 2])
    ('questionable', 'good', 'failed')
    """
    codes = _codes_of(items)
    return LEVELS[max(codes, default=0)]


def flag_of(obj: xr.DataArray | xr.Dataset) -> xr.DataArray:
    """Return the level codes per curve of a result, as a bare int8 DataArray.

    Its ``quality_flag`` coordinate without coordinates of its own (so that it broadcasts
    onto another result's curves), else the code of ``attrs["quality"]`` (0-d), else 0.
    This is how a result inherits the rating of its inputs (a gradient from its fit,
    Persson theory from its gradient).

    Examples
    --------
    >>> import xarray as xr
    >>> flag_of(xr.DataArray(1.0, attrs={"quality": "failed"})).item()
    2
    >>> r = xr.DataArray([1.0, 2.0], dims="scan", coords={FLAG: ("scan", [0, 1])})
    >>> flag_of(r).values.tolist()
    [0, 1]
    """
    if FLAG in obj.coords:
        flag = obj[FLAG]
        return flag.reset_coords(drop=True).astype(np.int8)
    level = obj.attrs.get("quality", "good")
    return xr.DataArray(np.int8(level_code(level) if level in LEVELS else 0))


def notes_of(obj: xr.DataArray | xr.Dataset) -> list[str]:
    """Return the notes of a result as a list (empty when it is good or unmarked).

    Examples
    --------
    >>> import xarray as xr
    >>> notes_of(xr.DataArray(1.0, attrs={"quality_notes": "a; b"}))
    ['a', 'b']
    """
    text = str(obj.attrs.get("quality_notes", ""))
    return [n for n in text.split(SEPARATOR) if n]


def reasons_of(obj: xr.DataArray | xr.Dataset) -> list[str]:
    """Return the words of :data:`REASONS` that rate any curve of a result (computed).

    Read from the ``quality_reasons`` coordinate (computed if lazy): the same for a dask
    result and its numpy twin.  Per curve, decode the coordinate with its CF
    ``flag_masks`` (or ``result.quality_reasons & mask``).

    Examples
    --------
    >>> import warnings, xarray as xr
    >>> G = xr.DataArray([[1.0], [2.0]], dims=("scan", "dr"))
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     G = mark_curves(G, xr.DataArray([0, 1], dims="scan"), what="G",
    ...                     reason="regions_disagree")
    >>> reasons_of(G), G.quality_reasons.values.tolist()
    (['regions_disagree'], [0, 1])
    """
    if REASON not in obj.coords:
        return []
    bits = np.bitwise_or.reduce(np.asarray(obj[REASON].values, dtype=np.int64).ravel())
    return [w for k, w in enumerate(REASONS) if int(bits) >> k & 1]


def reason_bit(reason: str) -> int:
    """Return the bit of a word of :data:`REASONS` (``reason_bit("anisotropic") == 2``)."""
    if reason not in REASONS:
        raise ValueError(f"quality reason must be one of {list(REASONS)}, got {reason!r}")
    return 1 << list(REASONS).index(reason)


def unrated(obj):
    """Return ``obj`` without its per-curve rating (``quality_flag``, ``quality_reasons``).

    A verdict is a function of the data: dropped where a result is taken as an input
    anew or compared as a key.
    """
    return obj.drop_vars([FLAG, REASON], errors="ignore")


def reasons_coord(bits) -> xr.DataArray:
    """Build the ``quality_reasons`` coordinate from bit masks (lazy allowed).

    ``int16`` with CF ``flag_masks`` and ``flag_meanings`` (the words of
    :data:`REASONS`).

    Examples
    --------
    >>> reasons_coord([0, 1]).attrs["flag_meanings"].split()[0]
    'regions_disagree'
    """
    da = bits if isinstance(bits, xr.DataArray) else xr.DataArray(np.asarray(bits))
    da = da.astype(np.int16)
    da.attrs = {"long_name": "checks that rate the result per curve (bit mask)",
                "units": "1", **cf_flags(REASONS, np.int16, masks=True)}
    da.name = REASON
    return da


def rate_curves(obj, codes, *, what: str, reason: str):
    """Set the per-curve coordinates of ``obj``: the flag and the reasons, nothing else.

    ``quality_flag`` becomes the worse of its codes and ``codes``; ``quality_reasons``
    gains the bit of ``reason`` where ``codes`` is not good (lazy where they are).  No
    attrs, no warning (:func:`mark_curves` adds them).
    """
    codes = codes if isinstance(codes, xr.DataArray) else xr.DataArray(np.asarray(codes))
    codes = codes.reset_coords(drop=True)
    new = xr.where(codes > 0, np.int16(reason_bit(reason)), np.int16(0))
    if FLAG in obj.coords:
        # the flag alone, without the scalar coordinates it carries out of a Dataset
        # (dr_ref, lambda_0 of a fit): under keep_attrs=False (contact's functions)
        # np.maximum would strip their attrs, and assign_coords below would put them back
        # on the result without units
        codes = np.maximum(obj[FLAG].reset_coords(drop=True), codes)
    if REASON in obj.coords:
        new = np.bitwise_or(obj[REASON].reset_coords(drop=True).astype(np.int16),
                            new.astype(np.int16))
    return obj.assign_coords({FLAG: flag_coord(codes, what=what),
                              REASON: reasons_coord(new)})


def flag_coord(codes, *, what: str) -> xr.DataArray:
    """Build the ``quality_flag`` coordinate from integer codes (0, 1, 2; lazy allowed).

    Parameters
    ----------
    codes : xarray.DataArray or array_like of int
        One level code per curve (on the extra dims of the result; 0-d for one curve).
    what : str
        The result it rates, for ``long_name``.

    Returns
    -------
    xarray.DataArray
        ``int8``, with ``flag_values`` (``[0, 1, 2]``, an array of the flag's dtype as
        CF asks: :func:`cf_flags`), ``flag_meanings`` and ``units = "1"``.

    Examples
    --------
    >>> flag = flag_coord([0, 2], what="fit")
    >>> flag.attrs["flag_meanings"], flag.dtype.name
    ('good questionable failed', 'int8')
    """
    da = codes if isinstance(codes, xr.DataArray) else xr.DataArray(np.asarray(codes))
    da = da.astype(np.int8)
    da.attrs = {"long_name": f"quality of {what} per curve", "units": "1",
                **cf_flags(LEVELS, np.int8)}
    da.name = FLAG
    return da


def cf_flags(meanings, dtype, *, masks: bool = False) -> dict:
    """CF flag attributes of a flag variable: the values (or bit masks) and their meanings.

    ``flag_values`` ``0, 1, ...`` (or ``flag_masks`` ``1, 2, 4, ...``) as an array of the
    variable's own ``dtype`` (CF 1.10, sec. 3.5: the same type as the variable, which
    cf-xarray's flag decoding reads), ``flag_meanings`` the words joined by spaces (a
    meaning holds no blank).

    Examples
    --------
    >>> attrs = cf_flags(["good", "questionable", "failed"], np.int8)
    >>> attrs["flag_values"], attrs["flag_meanings"]
    (array([0, 1, 2], dtype=int8), 'good questionable failed')
    >>> cf_flags(["a", "b"], np.int16, masks=True)["flag_masks"]
    array([1, 2], dtype=int16)
    """
    words = [str(m) for m in meanings]
    if any(not w or any(c.isspace() for c in w) for w in words):
        raise ValueError(f"flag meanings must be single words, got {words}")
    n = len(words)
    key, values = (("flag_masks", [1 << k for k in range(n)]) if masks else
                   ("flag_values", list(range(n))))
    return {key: np.asarray(values, dtype=dtype), "flag_meanings": " ".join(words)}


def _join(old: str, new: str) -> str:
    parts = [n for n in str(old).split(SEPARATOR) if n]
    for n in new.split(SEPARATOR):
        if n and n not in parts:
            parts.append(n)
    return SEPARATOR.join(parts)


def _warn(what: str, level: str, text: str) -> None:
    warn(f"{what}: {level}: {text}", QualityWarning)


def mark(obj, reason: str, *, level: str = "questionable", what: str,
         warn: bool = True):
    """Mark a whole result (every curve of it) and warn once.

    ``attrs["quality"]`` becomes the worse of its level and ``level``, ``reason`` is
    appended to ``attrs["quality_notes"]``, the ``quality_flag`` coordinate (if any) is
    raised to ``level`` on every curve, and a :class:`QualityWarning` says
    ``"<what>: <level>: <reason>"``.  At ``level="good"`` the reason is a remark (e.g. a
    gap in G that the result bridges): appended to ``attrs["quality_remarks"]``, with no
    warning, so that ``quality == "good"`` always comes with empty ``quality_notes``.

    Parameters
    ----------
    obj : xarray.DataArray or xarray.Dataset
        The result (not modified: a shallow copy is returned).
    reason : str
        What the check found and what to do, e.g. ``"reduced chi^2 = 597 > 30: the model
        does not describe G; use model='eq36'"``.
    level : {'good', 'questionable', 'failed'}
        ``'failed'``: the numbers mean nothing (set them NaN); ``'questionable'``: they
        may be biased or uncertain beyond their stated error.
    what : str
        The result named in the warning, e.g. ``"fit_acf (model 'spectrum')"``.
    warn : bool
        Emit the warning (False when the caller warns once for several marks).

    Returns
    -------
    Same type as ``obj``.

    Examples
    --------
    >>> import warnings, xarray as xr
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     r = mark(xr.DataArray(1.0), "no plateau in G", what="sigma_h")
    >>> r.attrs["quality"], r.attrs["quality_notes"], caught[0].category.__name__
    ('questionable', 'no plateau in G', 'QualityWarning')
    """
    code = level_code(level)
    out = obj.copy()
    new = worst(out.attrs.get("quality", "good"), code)
    out.attrs["quality"] = new
    if code == 0:  # a remark: said, but no finding against the result (notes stay empty)
        out.attrs["quality_remarks"] = _join(out.attrs.get("quality_remarks", ""), reason)
        out.attrs.setdefault("quality_notes", "")
        return out
    out.attrs["quality_notes"] = _join(out.attrs.get("quality_notes", ""), reason)
    if FLAG in out.coords:
        flag = out[FLAG]
        raised = flag.copy(data=np.maximum(flag.data, np.int8(code)).astype(np.int8))
        out = out.assign_coords({FLAG: raised.assign_attrs(flag.attrs)})
    if warn and code > 0:
        _warn(what, LEVELS[code], reason)
    return out


def _same(block):
    return block


def _own_output_layers(obj):
    """Return a copy of ``obj`` whose lazy data variables end in a layer of their own.

    The flag is computed from the variables, and the variables of one result from each
    other (``a_r`` from ``p_star``): a variable's output would then also be an input of
    other outputs, and ``dask.compute`` of two variables of one result loses that
    dependency when it optimises their graphs (dask 2025.4 and newer: "Missing
    dependency"). An identity task per chunk after each variable separates what is
    returned from what is reused, at the cost of one trivial task per chunk.
    """
    def fresh(v):
        if v.chunks is None:
            return v
        return v.copy(data=dsa.map_blocks(_same, v.data, dtype=v.dtype, meta=v.data._meta))

    if isinstance(obj, xr.Dataset):
        if all(v.chunks is None for v in obj.data_vars.values()):
            return obj  # nothing lazy: no copy (assign costs a copy of every variable)
        return obj.assign({k: fresh(v) for k, v in obj.data_vars.items()})
    return fresh(obj)


def mark_curves(obj, codes, *, what: str, reason: str, notes: str = "",
                warn: bool = True):
    """Attach the per-curve level codes of a result; rate a single computed curve.

    The ``quality_flag`` coordinate becomes the worse of its codes and ``codes`` (lazy
    where they are).  Then:

    * one curve (0-d codes), computed: ``attrs["quality"]`` is set to its level and, if
      that is not good, ``notes`` appended and one :class:`QualityWarning` emitted;
    * many curves: the attrs hold no per-curve verdict (so that a dask result and its
      numpy twin have the same attrs); ``attrs["quality_notes"]`` says where the verdict
      is, and when the codes are computed and not all good, one warning gives ``notes``;
    * one lazy curve: as many curves, without the warning.

    Parameters
    ----------
    obj : xarray.DataArray or xarray.Dataset
        The result.
    codes : xarray.DataArray of int
        0, 1 or 2 per curve (dims: the extra dims of ``obj``; 0-d for one curve).
    what : str
        The result named in the warning and the flag's ``long_name``.
    reason : str
        The check, a word of :data:`REASONS`: set in ``quality_reasons`` where ``codes``
        is not good.
    notes : str
        What was found (``"; "``-joined), used when the worst code is not 0.
    warn : bool
        Emit the warning.

    Returns
    -------
    Same type as ``obj``.

    Examples
    --------
    >>> import warnings, xarray as xr
    >>> G = xr.DataArray([1.0, 2.0], dims="dr")
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     r = mark_curves(G, xr.DataArray(2), what="fit", reason="fit",
    ...                     notes="no plateau")
    >>> r.attrs["quality"], r.attrs["quality_notes"], int(r.quality_flag)
    ('failed', 'no plateau', 2)
    >>> many = xr.DataArray([[1.0, 2.0], [1.0, 2.0]], dims=("scan", "dr"))
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     r = mark_curves(many, xr.DataArray([0, 2], dims="scan"), what="fit",
    ...                     reason="fit")
    >>> worst(r), r.quality_flag.values.tolist()
    ('failed', [0, 2])
    """
    out = rate_curves(_own_output_layers(obj), codes, what=what, reason=reason)
    flag = out[FLAG]
    if flag.ndim or flag.chunks is not None:
        out.attrs["quality_notes"] = _join(
            out.attrs.get("quality_notes", ""),
            f"{what}: quality per curve in coordinate {FLAG} (xrough.quality.worst(result) "
            "gives the worst)")
        if flag.chunks is None and notes and warn:
            code = int(np.max(flag.values)) if flag.size else 0
            if code:
                _warn(what, LEVELS[code], notes)
        return out
    code = int(flag.values)
    out.attrs["quality"] = worst(out.attrs.get("quality", "good"), code)
    out.attrs.setdefault("quality_notes", "")
    if code > 0 and notes:
        out.attrs["quality_notes"] = _join(out.attrs["quality_notes"], notes)
        if warn:
            _warn(what, LEVELS[code], notes)
    return out


def inherit(result, source, *, what: str):
    """Rate ``result`` per curve at least as its input ``source``, up to questionable.

    What made the input questionable (G's regions or directions that disagree, a tip that
    resolves no lag) holds for every result drawn from it: the result gets the input's
    flag (a failed input counts as questionable: the result's own checks decide whether
    its numbers mean anything) and, on a computed result, its notes and one warning.

    Examples
    --------
    >>> import warnings, xarray as xr
    >>> G = xr.DataArray([1.0], dims="dr", attrs={"quality": "questionable",
    ...                                           "quality_notes": "regions disagree"})
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     fit = inherit(xr.Dataset({"hurst": 0.5}), G, what="fit_acf")
    >>> fit.attrs["quality"], fit.attrs["quality_notes"]
    ('questionable', 'regions disagree')
    """
    if FLAG not in source.coords and source.attrs.get("quality", "good") == "good":
        return result
    codes = np.minimum(flag_of(source), np.int8(level_code("questionable")))
    notes = SEPARATOR.join(n for n in notes_of(source)
                           if f"quality per curve in coordinate {FLAG}" not in n)
    # one warning per result: a result that has warned at this level already says the
    # input's notes in its attrs only
    lazy = getattr(codes, "chunks", None) is not None or (
        FLAG in result.coords and result[FLAG].chunks is not None)
    said = not lazy and level_code(worst(result)) >= int(np.max(codes))
    before = result[REASON].reset_coords(drop=True) if REASON in result.coords else None
    out = mark_curves(result, codes, what=what, reason="input", notes=notes, warn=not said)
    # the input's reasons are the result's (a G's regions), else "input"
    out = out.drop_vars(REASON)
    if before is not None:
        out = out.assign_coords({REASON: reasons_coord(before)})
    return add_reasons(out, reasons_from(source))


def reasons_from(source) -> xr.DataArray:
    """Return the reason bits a result takes from its input ``source``, per curve (int16).

    The input's own reasons where it is rated and says why, else the bit of ``"input"``
    where it is rated (by attrs only, say); 0 where it is good.
    """
    codes = flag_of(source)
    given = (source[REASON].reset_coords(drop=True).astype(np.int16)
             if REASON in source.coords else xr.DataArray(np.int16(0)))
    return xr.where(codes > 0, xr.where(given != 0, given, np.int16(reason_bit("input"))),
                    np.int16(0)).astype(np.int16)


def add_reasons(obj, bits):
    """Return ``obj`` with ``bits`` or-ed into its ``quality_reasons`` coordinate."""
    if REASON in obj.coords:
        bits = np.bitwise_or(obj[REASON].reset_coords(drop=True).astype(np.int16),
                             bits.astype(np.int16))
    return obj.assign_coords({REASON: reasons_coord(bits)})
