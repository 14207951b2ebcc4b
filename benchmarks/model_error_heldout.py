"""The model-error table of Persson's contact area against solver runs it was not made from.

``xrough/data/persson_area_error.csv`` (the validation study of docs/validation.md: H = 0.5
and 0.8, ``N = 1024`` and 4096, ``lambda_s`` = 4, 8, 16 px, ``p*`` = 0.001-0.3) gives, at
each reduced pressure, the expected relative error ``a / a_sim - 1`` of Persson's ``a_r``
(eq. 29) and of ``a_ri`` (eq. 50) and its spread (:func:`area_model_error`; persson's
``a_r_model_error``, ``a_ri_model_error``, ``sigma_c_model_error``). Here the contact
solver runs on surfaces outside that table: ``N = 512`` (``lambda_r`` = 128 px), Hurst
exponents 0.3, 0.65 and 0.9 (0.3 and 0.9 outside the table's H), ``lambda_s`` = 4 and 8 px
(bandwidths 32 and 16), loads between and beyond the table's (``p*`` 0.002 to 0.5), two
seeds each (``benchmarks/validation_study.py`` makes and caches the runs in
``<out>/runs``). Printed per configuration and load: the solver's error (mean over
seeds), the table's prediction and spread, and ``|observed - predicted| / spread``
(within 1: the model error covers it). About 20 s of solving on two cores.

Usage::

    python benchmarks/model_error_heldout.py                  # --out model-error-heldout
    python benchmarks/model_error_heldout.py --out /tmp/held --hurst 0.65 --seeds 1
"""

from __future__ import annotations

import argparse
import contextlib
import io
from pathlib import Path

import numpy as np
import validation_study

from xrough._kernels.model_error import area_model_error

LOADS = (0.002, 0.005, 0.02, 0.05, 0.2, 0.5)


def parse(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="model-error-heldout", help="output directory")
    p.add_argument("--n", type=int, default=512)
    p.add_argument("--hurst", type=float, nargs="+", default=[0.3, 0.65, 0.9])
    p.add_argument("--lambda-s", type=float, nargs="+", default=[4, 8])
    p.add_argument("--seeds", type=int, default=2)
    p.add_argument("--loads", type=float, nargs="+", default=list(LOADS))
    return p.parse_args(argv)


def main(argv=None) -> dict:
    args = parse(argv)
    study = ["--out", args.out, "--n", str(args.n), "--seeds", str(args.seeds),
             "--hurst", *map(str, args.hurst), "--lambda-s", *map(str, args.lambda_s),
             "--loads", *map(str, args.loads)]
    with contextlib.redirect_stdout(io.StringIO()):  # its own tables: not ours
        validation_study.main(study)
    runs = {}
    for h in args.hurst:
        for ls in args.lambda_s:
            runs[h, ls] = [validation_study.xr.open_dataset(
                Path(args.out) / "runs" / validation_study.run_name(
                    args.n, h, ls, s, 4.0, "sharp")) for s in range(args.seeds)]
    print(f"Persson's contact area against the solver on {args.n}^2 maps (L = 4 lambda_r, "
          f"{args.seeds} seeds): observed a / a_sim - 1 (mean over seeds), the model-error "
          "table's prediction +- spread, and |observed - predicted| / spread\n")
    print(f"{'H':>5} {'ls px':>5} {'bw':>4} {'p*':>6} | {'a_r obs':>8} {'pred':>14} {'r':>5}"
          f" | {'a_ri obs':>8} {'pred':>14} {'r':>5}")
    ratios = {"a_r": [], "a_ri": []}
    for (h, ls), sel in runs.items():
        for i, p in enumerate(args.loads):
            row = f"{h:>5} {ls:>5g} {args.n / 4 / ls:>4g} {p:>6g} |"
            for area, theory in (("a_r", "persson"), ("a_ri", "modified")):
                obs = np.mean([float(c.area_error.sel(theory=theory)[i]) for c in sel])
                pred, spread = (float(v) for v in area_model_error(p, area))
                r = abs(obs - pred) / spread
                ratios[area].append(r)
                row += f" {obs:>+8.3f} {pred:>+7.3f} +-{spread:.3f} {r:>5.2f} |"
            print(row.rstrip(" |"))
    print()
    for area, r in ratios.items():
        r = np.array(r)
        print(f"{area}: within the spread in {np.mean(r <= 1):.0%} of {r.size} cases, "
              f"within twice the spread in {np.mean(r <= 2):.0%}; largest ratio {r.max():.2f}")
    return ratios


if __name__ == "__main__":
    main()
