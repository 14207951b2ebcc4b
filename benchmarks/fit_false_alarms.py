"""False alarms and misses of the default fit's rating on the synthetic family, over seeds.

The family of ``benchmarks/quality_calibration.py`` (self-affine maps of eq. 35,
rms gradient 0.1, lambda_r = L/8, lambda_s = 4 pixels; H = 0.3, 0.5, 0.8; sharp and smooth
roll-off; without and with white noise of 0.5 times the rms step between neighbouring
pixels), ``--seeds`` realisations of each at ``--size`` pixels, fitted with
``G.rough.fit()``.  A fit matches the truth when ``|H - H_true| <= min(3 hurst_std, 0.1)``
(its own stated error, and close enough to quote).  A false alarm is a mark (questionable
or failed) on a match; a miss is a good rating of a fit that does not match.  Prints the
counts and each false alarm with its notes.

Usage::

    python benchmarks/fit_false_alarms.py --seeds 20 --size 128 256   # about 4 min
"""

from __future__ import annotations

import argparse
import collections
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import quality_calibration as qc  # noqa: E402  (the family and its truth)

from xrough.memo import forget  # noqa: E402


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--size", type=int, nargs="+", default=[128, 256])
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    for n in args.size:
        counts = collections.Counter()
        checks = collections.Counter()
        for seed in range(1, args.seeds + 1):
            for hurst in (0.3, 0.5, 0.8):
                for rolloff in ("sharp", "smooth"):
                    for noise in (0.0, 0.5):
                        spec = dict(kind="self-affine", hurst=hurst, rolloff=rolloff, n=n,
                                    noise=noise, seed=seed)
                        topo, _ = qc.synthetic(spec)
                        fit = topo.rough.acf().rough.fit()
                        forget()
                        H, Hs = float(fit.hurst), float(fit.hurst_std)
                        match = bool(np.isfinite(H) and np.isfinite(Hs) and
                                     abs(H - hurst) <= min(3 * Hs, qc.H_CLOSE))
                        good = fit.attrs["quality"] == "good"
                        counts[("match" if match else "off",
                                "good" if good else "marked")] += 1
                        if match and not good:
                            for note in fit.attrs["quality_notes"].split("; "):
                                checks[" ".join(note.split()[:6])] += 1
                            print(f"false alarm: {spec}: H = {H:.3f} +- {Hs:.3f}: "
                                  f"{fit.attrs['quality_notes'][:120]}")
        total = sum(counts.values())
        print(f"{n}^2, {args.seeds} seeds, {total} maps: match & good "
              f"{counts['match', 'good']}, false alarms {counts['match', 'marked']}, "
              f"misses (off & good) {counts['off', 'good']}, off & marked "
              f"{counts['off', 'marked']}")
        for check, k in checks.most_common():
            print(f"    {k:4d}  {check}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
