"""Run time and memory of ``.rough.acf()`` against an FFT baseline measured in the same run.

For each map size and case (periodic, open, open with 10 % missing points; ``open-half``:
open with ``dr_max`` half the scan, the lags the reliability window keeps) this prints

* the time of one ``scipy.fft.rfft2`` of the array the estimator transforms (the map, or
  the map zero padded to the FFT shape used for open boundaries), measured here;
* the time of ``height_difference_acf`` and its ratio to that baseline, and to one
  ``rfft2`` of the map itself (unpadded);
* the estimator ``'auto'`` chose (attr ``estimator``) and the memory budget it weighed;
* the peak memory of the call above the input, as a multiple of the input size;
* when SurfaceTopography is installed (``pip install xrough[bench]``), the time and memory
  of its ``autocorrelation_from_area`` on the same map and the speed-up of xrough.

Method: like with like. All timings of one size and case come from one process, in
which both libraries and the baseline are warmed up by one untimed call each (imports,
per-grid caches, FFT plans), then take turns for ``--repeats`` rounds of one call each,
so that they see the same process state and load. Times are the best of the rounds and
every ratio is printed as best over best, with its range (best over worst to worst over
best), and as the median of the ratios within a round. Memory is measured apart: the
peak resident memory of the first call on the map in a fresh process, above the state
before the call (library and FFT library loaded), as a multiple of the input size.

Usage::

    python benchmarks/bench_acf.py                 # 512, 1024, 4096, 8192
    python benchmarks/bench_acf.py --sizes 512 1024 --cases open
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import numpy as np

SETUP = r"""
import json, resource, sys, time
import numpy as np
n, case = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(0)
h = np.empty((n, n))
for row in range(0, n, 256):  # fill without full-size temporaries
    h[row:row + 256] = rng.standard_normal((min(256, n - row), n))
    if case == "masked":
        blk = h[row:row + 256]
        blk[rng.random(blk.shape) < 0.1] = np.nan
periodic = case == "periodic"
half = case == "open-half"


def rss():
    # peak resident memory so far (VmHWM), in bytes
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def xrough_call():
    import xrough
    topo = xrough.topography(h, spacing=1.0, unit="nm", periodic=periodic)
    if half:
        return lambda: topo.rough.acf(dr_max=f"{(n - 1) / 2} nm")
    return topo.rough.acf


def st_call():
    from SurfaceTopography import Topography
    return Topography(h, (float(n), float(n)), periodic=periodic).autocorrelation_from_area
"""

#: Memory: one library in a fresh process; the peak resident memory of its first call on
#: the map above the state before it (libraries and the FFT library already loaded).
MEMORY_CHILD = SETUP + r"""
from scipy import fft as sfft
sfft.rfft2(h[:64, :64])
call = xrough_call() if sys.argv[3] == "xrough" else st_call()
base = rss()
t0 = time.perf_counter(); G = call(); t_first = time.perf_counter() - t0
peak = rss() - base
estimator = str(getattr(G, "attrs", {}).get("estimator", "-"))
reason = str(getattr(G, "attrs", {}).get("estimator_reason", ""))
print(json.dumps({"peak_extra": peak, "t_first": t_first, "input": h.nbytes,
                  "estimator": estimator, "reason": reason}))
"""

#: Time: every library in one process, each warmed up by one call, then ``repeats``
#: interleaved rounds of one call each and of the rfft2 baseline.
TIME_CHILD = SETUP + r"""
from scipy import fft as sfft
from xrough._kernels.pairs import padded_shape
repeats, peer = int(sys.argv[3]), sys.argv[4] == "1"
ks = (n // 2,) * 2 if periodic else ((n - 1) // 2,) * 2 if half else (n - 1,) * 2
fshape = padded_shape((n, n), ks, periodic)
hh = np.nan_to_num(h)
calls = {"xrough": xrough_call()}
if peer:
    try:
        calls["st"] = st_call()
    except ImportError:
        pass


def baseline():
    a = sfft.rfft2(hh, s=fshape, workers=-1)
    del a


def unpadded():
    a = sfft.rfft2(hh, workers=-1)
    del a


calls["rfft"] = baseline
calls["rfft_map"] = unpadded
for call in calls.values():  # warm-up: imports, caches, FFT plans
    call()
times = {k: [] for k in calls}
for _ in range(repeats):
    for k, call in calls.items():
        t0 = time.perf_counter(); call(); times[k].append(time.perf_counter() - t0)
print(json.dumps({"times": times, "fshape": list(fshape)}))
"""


def _child(script: str, *args) -> dict | None:
    """Run a child script; None when its library is not installed."""
    proc = subprocess.run([sys.executable, "-c", script, *map(str, args)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        if "No module named 'SurfaceTopography'" in proc.stderr:
            return None
        raise RuntimeError(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    """Parse the arguments and print one row per size and case."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[512, 1024, 4096, 8192])
    parser.add_argument("--cases", nargs="+", default=["periodic", "open", "masked"],
                        choices=["periodic", "open", "masked", "open-half"])
    parser.add_argument("--repeats", type=int, default=5, help="timed rounds after warm-up")
    parser.add_argument("--no-peer", action="store_true", help="skip SurfaceTopography")
    parser.add_argument("--peer-max-size", type=int, default=4096,
                        help="largest map given to SurfaceTopography (28x its size in memory)")
    args = parser.parse_args(argv)

    def ratio(a, b):  # best over best (worst-case range); median of the per-round ratios
        rounds = [x / y for x, y in zip(a, b)]
        return (f"{min(a) / min(b):.2f} ({min(a) / max(b):.2f}-{max(a) / min(b):.2f}); "
                f"{np.median(rounds):.2f}")

    def spread(t):
        return f"{min(t):.3g} ({max(t) / min(t):.2f})"

    print("| size | case | FFT shape | estimator | rfft2 s (max/min) | acf s (max/min) "
          "| acf / rfft2 | acf / map rfft2 | mem / input | ST s (max/min) | ST / xrough "
          "| ST first call s | ST mem / input |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for case in args.cases:
            peer = not args.no_peer and n <= args.peer_max_size
            t = _child(TIME_CHILD, n, case, args.repeats, int(peer))
            times = t["times"]
            mem = _child(MEMORY_CHILD, n, case, "xrough")
            st = None if not peer or "st" not in times else _child(
                MEMORY_CHILD, n, case, "st")
            x, f = times["xrough"], times["rfft"]
            st_cols = (f"{spread(times['st'])} | {ratio(times['st'], x)} | "
                       f"{st['t_first']:.3g} | {st['peak_extra'] / st['input']:.1f}"
                       ) if st else "- | - | - | -"
            shape = "x".join(str(k) for k in t["fshape"])
            print(f"| {n} | {case} | {shape} | {mem['estimator']} | {spread(f)} | {spread(x)} "
                  f"| {ratio(x, f)} | {ratio(x, times['rfft_map'])} "
                  f"| {mem['peak_extra'] / mem['input']:.1f} | {st_cols} |", flush=True)
    print("\nAll timings of a row come from one process: every library warmed up by one "
          "call, then interleaved rounds of one call each. acf / rfft2 and ST / xrough: "
          "best over best (range best/worst to worst/best); median of the ratios within "
          "a round; map rfft2: one rfft2 of the unpadded map. mem / input: peak "
          "resident memory of the first call in a fresh "
          "process above the state before it, over the input size; ST first call: the "
          "time of that call, for reference.")


if __name__ == "__main__":
    main()
