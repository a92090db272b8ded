#!/usr/bin/env python3
"""Reference vectors for gradtac-stages' spatial stages (tests/spatial_*.rs).

- natural_neighbour.json: MetPy `natural_neighbor_to_grid` (Sibson) on the BioTac SP layout and on
  seeded random layouts; grids as numpy.linspace over an extent (row = y, column = x).
- contours.json: scikit-image `measure.find_contours` on reference surfaces, several levels, both
  saddle rules (`fully_connected` = "low" / "high").

Run from the repository root:  python3 gradtac-stages/tests/reference/gen_spatial.py
Versions used are recorded in each file ("generator" field).
"""
import json
import math
import os
import warnings

import metpy
import numpy as np
import skimage
from metpy.interpolate import natural_neighbor_to_grid
from skimage.measure import find_contours

from biotac_sp import biotac_positions  # the shared BioTac SP layout

HERE = os.path.dirname(os.path.abspath(__file__))


def nn_case(name, pos, values, extent, nx, ny):
    pos = np.asarray(pos, dtype=float)
    xs = np.linspace(extent[0], extent[1], nx)
    ys = np.linspace(extent[2], extent[3], ny)
    gx, gy = np.meshgrid(xs, ys)  # shape (ny, nx): row = y
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        z = natural_neighbor_to_grid(pos[:, 0], pos[:, 1], np.asarray(values, dtype=float), gx, gy)
    z = np.asarray(z, dtype=float)
    return {
        "name": name,
        "positions": pos.tolist(),
        "values": list(map(float, values)),
        "extent": {"x_min": extent[0], "x_max": extent[1], "y_min": extent[2], "y_max": extent[3]},
        "nx": nx,
        "ny": ny,
        # row-major (row = y); null where MetPy returned NaN (outside the hull or a failure)
        "expected": [None if not np.isfinite(v) else float(v) for v in z.ravel()],
    }


def natural_neighbour():
    rng = np.random.default_rng(20261121)
    cases = []
    bt = biotac_positions()
    p = np.asarray(bt)
    ext = [p[:, 0].min() - 2.0, p[:, 0].max() + 2.0, p[:, 1].min() - 2.0, p[:, 1].max() + 2.0]
    cases.append(nn_case("biotac-random-values", bt, rng.normal(0.0, 3.0, 24), ext, 48, 40))
    smooth = [math.sin(0.3 * x) * math.cos(0.2 * y) * 5.0 + 0.1 * x * y for x, y in bt]
    cases.append(nn_case("biotac-smooth", bt, smooth, ext, 33, 37))
    for k in range(3):
        n = [10, 30, 60][k]
        pts = rng.uniform(0.0, 10.0, (n, 2))
        vals = rng.uniform(-5.0, 5.0, n)
        cases.append(nn_case(f"random-{n}", pts.tolist(), vals, [-0.5, 10.5, -0.5, 10.5], 41, 43))
    return cases


def surfaces():
    out = {}
    ys, xs = np.mgrid[0:40, 0:50].astype(float)
    out["gaussian"] = np.exp(-((xs - 21.3) ** 2 + (ys - 17.8) ** 2) / (2 * 6.0**2))
    out["two-peaks"] = np.exp(-((xs - 12.0) ** 2 + (ys - 20.0) ** 2) / 30.0) + np.exp(
        -((xs - 36.0) ** 2 + (ys - 20.0) ** 2) / 30.0
    )
    out["waves"] = np.sin(xs / 3.1) * np.cos(ys / 2.3) + 0.05 * xs
    # exact saddles: a checkerboard-like field whose saddle cells are ambiguous at level 0
    out["checker"] = np.cos(np.pi * xs / 2.0 + 0.1) * np.cos(np.pi * ys / 2.0 + 0.2)
    rng = np.random.default_rng(7)
    out["noise"] = rng.normal(size=(23, 29))
    nan = out["gaussian"].copy()
    nan[5:9, 30:44] = np.nan
    nan[0, 0] = np.nan
    out["gaussian-nan"] = nan
    return out


def contours():
    cases = []
    for name, z in surfaces().items():
        finite = z[np.isfinite(z)]
        levels = list(np.linspace(finite.min(), finite.max(), 7)[1:-1])
        if name == "checker":
            levels = [0.0, 0.05]
        for level in levels:
            for fc in ["low", "high"]:
                cs = find_contours(z, level, fully_connected=fc)
                cases.append(
                    {
                        "surface": name,
                        "level": float(level),
                        "fully_connected": fc,
                        # (row, col) as skimage returns them; a closed line repeats its first point
                        "contours": [c.tolist() for c in cs],
                    }
                )
    return {
        "surfaces": {k: {"shape": list(v.shape), "values": [None if not np.isfinite(x) else float(x) for x in v.ravel()]} for k, v in surfaces().items()},
        "cases": cases,
    }


def main():
    gen = {"numpy": np.__version__, "metpy": metpy.__version__, "scikit-image": skimage.__version__}
    with open(os.path.join(HERE, "natural_neighbour.json"), "w") as f:
        json.dump({"generator": gen, "cases": natural_neighbour()}, f)
    c = contours()
    c["generator"] = gen
    with open(os.path.join(HERE, "contours.json"), "w") as f:
        json.dump(c, f)


if __name__ == "__main__":
    main()
