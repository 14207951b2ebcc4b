"""Run time and memory of ``.rough.acf()`` against an FFT baseline measured in the same run.

For each map size and case (periodic, open, open with 10 % missing points) this prints

* the time of one ``scipy.fft.rfft2`` of the array the estimator transforms (the map, or
  the map zero padded to the FFT shape used for open boundaries), measured here;
* the time of ``height_difference_acf`` and its ratio to that baseline;
* the peak memory of the call above the input, as a multiple of the input size;
* when SurfaceTopography is installed (``pip install xrough[bench]``), the time and memory
  of its ``autocorrelation_from_area`` on the same map and the speed-up of xrough.

Each case runs in a fresh subprocess so that peak resident memory is its own.

Usage::

    python benchmarks/bench_acf.py                 # 1024, 4096, 8192
    python benchmarks/bench_acf.py --sizes 512 1024
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import textwrap

CHILD = textwrap.dedent(
    r"""
    import json, resource, sys, time
    import numpy as np
    n, case, what = int(sys.argv[1]), sys.argv[2], sys.argv[3]

    def rss():
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024

    rng = np.random.default_rng(0)
    h = np.empty((n, n))
    for row in range(0, n, 256):  # fill without full-size temporaries
        h[row:row + 256] = rng.standard_normal((min(256, n - row), n))
        if case == "masked":
            blk = h[row:row + 256]
            blk[rng.random(blk.shape) < 0.1] = np.nan
    periodic = case == "periodic"
    out = {}
    if what == "xrough":
        import xrough
        from scipy import fft as sfft
        from xrough._kernels.pairs import padded_shape
        topo = xrough.topography(h, spacing=1.0, unit="nm", periodic=periodic)
        ks = (n // 2,) * 2 if periodic else (n - 1,) * 2
        fshape = padded_shape((n, n), ks, periodic)
        sfft.rfft2(h[:64, :64])  # load the FFT library before measuring memory
        base_mem = rss()
        t0 = time.perf_counter(); topo.rough.acf(); t_first = time.perf_counter() - t0
        out["peak_extra"] = rss() - base_mem
        times = []
        for _ in range(2):
            t0 = time.perf_counter(); topo.rough.acf(); times.append(time.perf_counter() - t0)
        out["t"] = min(times + [t_first])
        hh = np.nan_to_num(h)
        ft = []
        for _ in range(3):
            t0 = time.perf_counter(); a = sfft.rfft2(hh, s=fshape, workers=-1)
            ft.append(time.perf_counter() - t0); del a
        out["t_rfft"] = min(ft)
        out["fshape"] = list(fshape)
    else:
        from SurfaceTopography import Topography
        t = Topography(h, (float(n), float(n)), periodic=periodic)
        base_mem = rss()
        t0 = time.perf_counter(); t.autocorrelation_from_area(); out["t"] = time.perf_counter() - t0
        out["peak_extra"] = rss() - base_mem
    out["input"] = h.nbytes
    print(json.dumps(out))
    """
)


def run(n: int, case: str, what: str) -> dict | None:
    proc = subprocess.run([sys.executable, "-c", CHILD, str(n), case, what],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        if what == "surfacetopography" and "No module named" in proc.stderr:
            return None
        raise RuntimeError(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096, 8192])
    parser.add_argument("--cases", nargs="+", default=["periodic", "open", "masked"])
    parser.add_argument("--no-peer", action="store_true", help="skip SurfaceTopography")
    args = parser.parse_args(argv)
    head = (f"{'size':>6} {'case':>9} {'FFT shape':>12} {'rfft2 s':>8} {'acf s':>7} "
            f"{'acf/rfft2':>9} {'mem/input':>9} {'ST s':>7} {'ST/xrough':>9} {'ST mem':>7}")
    print(head)
    print("-" * len(head))
    for n in args.sizes:
        for case in args.cases:
            r = run(n, case, "xrough")
            st = None if args.no_peer else run(n, case, "surfacetopography")
            st_cols = (f"{st['t']:7.2f} {st['t'] / r['t']:9.2f} "
                       f"{st['peak_extra'] / st['input']:7.1f}") if st else \
                f"{'-':>7} {'-':>9} {'-':>7}"
            shape = "x".join(str(k) for k in r["fshape"])
            print(f"{n:>6} {case:>9} {shape:>12} {r['t_rfft']:8.3f} {r['t']:7.3f} "
                  f"{r['t'] / r['t_rfft']:9.2f} {r['peak_extra'] / r['input']:9.2f} {st_cols}",
                  flush=True)
    print("\nacf/rfft2: time of .rough.acf() over one rfft2 of the (padded) array; "
          "mem/input: peak memory above the input over the input size; "
          "ST: SurfaceTopography autocorrelation_from_area on the same map.")


if __name__ == "__main__":
    main()
