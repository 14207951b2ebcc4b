"""Run time and memory of ``.rough.acf()`` against an FFT baseline measured in the same run.

For each map size and case (periodic, open, open with 10 % missing points) this prints

* the time of one ``scipy.fft.rfft2`` of the array the estimator transforms (the map, or
  the map zero padded to the FFT shape used for open boundaries), measured here;
* the time of ``height_difference_acf`` and its ratio to that baseline;
* the peak memory of the call above the input, as a multiple of the input size;
* when SurfaceTopography is installed (``pip install xrough[bench]``), the time and memory
  of its ``autocorrelation_from_area`` on the same map and the speed-up of xrough.

Method: each case and library runs in a fresh subprocess, so that peak resident memory is
its own. Both libraries are treated alike: the first call on the map is untimed (it
loads the libraries and builds what they cache per grid, FFT plans included; its peak
memory above the input is the memory figure), then ``--repeats`` calls are timed. Times
are the best of those calls, and every time and ratio is printed with its spread: the
time's max / min, and the ratio's range from best-over-worst to worst-over-best.

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
    n, case, what, repeats = int(sys.argv[1]), sys.argv[2], sys.argv[3], int(sys.argv[4])

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
        call = topo.rough.acf
    else:
        from SurfaceTopography import Topography
        t = Topography(h, (float(n), float(n)), periodic=periodic)
        call = t.autocorrelation_from_area
    base_mem = rss()
    t0 = time.perf_counter(); call(); out["t_cold"] = time.perf_counter() - t0
    out["peak_extra"] = rss() - base_mem
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter(); call(); times.append(time.perf_counter() - t0)
    out["t"] = [min(times), max(times)]
    if what == "xrough":  # the baseline, after the memory measurement
        hh = np.nan_to_num(h)
        ft = []
        for _ in range(repeats + 2):
            t0 = time.perf_counter(); a = sfft.rfft2(hh, s=fshape, workers=-1)
            ft.append(time.perf_counter() - t0); del a
        out["t_rfft"] = [min(ft), max(ft)]
        out["fshape"] = list(fshape)
    out["input"] = h.nbytes
    print(json.dumps(out))
    """
)


def run(n: int, case: str, what: str, repeats: int) -> dict | None:
    """Run one library on one case in a fresh subprocess; None if it is not installed."""
    proc = subprocess.run([sys.executable, "-c", CHILD, str(n), case, what, str(repeats)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        if what == "surfacetopography" and "No module named" in proc.stderr:
            return None
        raise RuntimeError(proc.stderr)
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None) -> None:
    """Parse the arguments and print one row per size and case."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1024, 4096, 8192])
    parser.add_argument("--cases", nargs="+", default=["periodic", "open", "masked"])
    parser.add_argument("--repeats", type=int, default=5, help="timed calls after the first")
    parser.add_argument("--no-peer", action="store_true", help="skip SurfaceTopography")
    args = parser.parse_args(argv)

    def ratio(a, b):  # best over best (worst case range)
        return f"{a[0] / b[0]:.2f} ({a[0] / b[1]:.2f}-{a[1] / b[0]:.2f})"

    print("| size | case | FFT shape | rfft2 s (max/min) | acf s (max/min) | acf / rfft2 "
          "| mem / input | ST s (max/min) | ST first call s | ST / xrough | ST mem / input |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for case in args.cases:
            r = run(n, case, "xrough", args.repeats)
            st = None if args.no_peer else run(n, case, "surfacetopography", args.repeats)
            st_cols = (f"{st['t'][0]:.3g} ({st['t'][1] / st['t'][0]:.2f}) | "
                       f"{st['t_cold']:.3g} | {ratio(st['t'], r['t'])} | "
                       f"{st['peak_extra'] / st['input']:.1f}") if st else "- | - | - | -"
            shape = "x".join(str(k) for k in r["fshape"])
            print(f"| {n} | {case} | {shape} | {r['t_rfft'][0]:.3g} "
                  f"({r['t_rfft'][1] / r['t_rfft'][0]:.2f}) | {r['t'][0]:.3g} "
                  f"({r['t'][1] / r['t'][0]:.2f}) | {ratio(r['t'], r['t_rfft'])} "
                  f"| {r['peak_extra'] / r['input']:.1f} | {st_cols} |", flush=True)
    print("\nacf / rfft2: best time of .rough.acf() over the best rfft2 of the (padded) "
          "array, with its range; mem / input: peak memory of the first call above the "
          "input over the input size; ST: SurfaceTopography autocorrelation_from_area on "
          "the same map, warmed up by one call like xrough; ST first call: that untimed "
          "call, for reference.")


if __name__ == "__main__":
    main()
