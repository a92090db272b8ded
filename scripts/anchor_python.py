"""The Python anchor for the surface → maximal-contour step: scipy + scikit-image on the very
window aggregates `gradtac run` wrote, timed per window, beside gradtac's own contours.

    python3 scripts/anchor_python.py OUT_DIR [WINDOWS]

OUT_DIR holds `window.parquet`, `surface.parquet` (for the grid) and `contour.parquet` of one
run (see scripts/anchor_python.sh, which makes them). For each of the first WINDOWS windows
(default 300):

- `linear_nd`: scipy's `LinearNDInterpolator` on the layout's Delaunay triangulation (built
  once), evaluated on the 64 × 64 grid (the naive use: the point location runs per window);
- `weights`: the same surface from barycentric weights precomputed once (`W @ v`, what a
  careful numpy user writes; gradtac's weight tables are the same idea);
- `contour`: the maximal contour from the `weights` surface with
  `skimage.measure.find_contours` at gradtac's levels (10 evenly spaced between the surface's
  minimum and maximum, from the top): the first level whose closed contour around the peak
  has at least 1 mm², its area centroid the contact.

Prints the median ms per window of each part and of the pipelines (`linear_nd + contour`,
`weights + contour`), and how often the contact centroid lies within 0.5 mm of gradtac's
(the interpolants differ: linear here, natural neighbour in gradtac; the check is that both
find the same contact, not the same digits).
"""
import json
import sys
import time

import numpy as np
import pyarrow.parquet as pq
from scipy.interpolate import LinearNDInterpolator
from scipy.spatial import Delaunay
from skimage.measure import find_contours


def main():
    out = sys.argv[1]
    n_windows = int(sys.argv[2]) if len(sys.argv) > 2 else 300
    meta = pq.read_metadata(f"{out}/window.parquet").metadata
    layout = [l.split(",") for l in meta[b"gradtac.layout"].decode().splitlines()[1:] if l.strip()]
    pts = np.array([[float(x), float(y)] for _, x, y in layout])
    grid = json.loads(pq.read_schema(f"{out}/surface.parquet").metadata[b"gradtac.grid"])
    nx, ny = grid["nx"], grid["ny"]
    xs = np.linspace(grid["x_min"], grid["x_max"], nx)
    ys = np.linspace(grid["y_min"], grid["y_max"], ny)
    gx, gy = np.meshgrid(xs, ys)
    q = np.column_stack([gx.ravel(), gy.ravel()])
    windows = np.array(pq.read_table(f"{out}/window.parquet").column("values").to_pylist())[:n_windows]
    ours = pq.read_table(f"{out}/contour.parquet").to_pylist()[:n_windows]

    tri = Delaunay(pts)
    # barycentric weights of every grid point, once
    simplex = tri.find_simplex(q)
    inside = simplex >= 0
    W = np.zeros((len(q), len(pts)))
    T = tri.transform[simplex[inside]]
    b = np.einsum("ijk,ik->ij", T[:, :2], q[inside] - T[:, 2])
    bary = np.column_stack([b, 1 - b.sum(axis=1)])
    verts = tri.simplices[simplex[inside]]
    rows = np.nonzero(inside)[0]
    for k in range(3):
        np.add.at(W, (rows, verts[:, k]), bary[:, k])
    W[~inside] = np.nan
    dx, dy = xs[1] - xs[0], ys[1] - ys[0]

    def maximal_contour(z):
        finite = z[np.isfinite(z)]
        zmax, zmin = finite.max(), finite.min()
        if zmax < 1.0 or zmax <= zmin:
            return None
        pr, pc = np.unravel_index(np.nanargmax(z), z.shape)
        # outside the grid and the hull: below every level (finite, so crossings interpolate)
        low = zmin - 1.0
        padded = np.pad(np.where(np.isfinite(z), z, low), 1, constant_values=low)
        for k in range(10, 0, -1):
            level = zmin + k * (zmax - zmin) / 11
            if level >= zmax:
                continue
            for c in find_contours(padded, level):
                if len(c) < 3 or not np.allclose(c[0], c[-1]):
                    continue
                r, cc = c[:, 0] - 1, c[:, 1] - 1
                # does the ring enclose the peak? (ray casting)
                inside_peak = False
                for i in range(len(r) - 1):
                    if (r[i] > pr) != (r[i + 1] > pr):
                        x = cc[i] + (pr - r[i]) * (cc[i + 1] - cc[i]) / (r[i + 1] - r[i])
                        if x > pc:
                            inside_peak = not inside_peak
                if not inside_peak:
                    continue
                x, y = cc * dx + xs[0], r * dy + ys[0]
                cross = x[:-1] * y[1:] - x[1:] * y[:-1]
                area = cross.sum() / 2
                if abs(area) < 1.0:
                    break
                cx = ((x[:-1] + x[1:]) * cross).sum() / (6 * area)
                cy = ((y[:-1] + y[1:]) * cross).sum() / (6 * area)
                return cx, cy
        return None

    t_lin, t_w, t_c, agree, both = [], [], [], 0, 0
    for v, o in zip(windows, ours):
        t0 = time.perf_counter()
        z_lin = LinearNDInterpolator(tri, v)(q).reshape(ny, nx)
        t1 = time.perf_counter()
        z = (W @ v).reshape(ny, nx)
        t2 = time.perf_counter()
        c = maximal_contour(z)
        t3 = time.perf_counter()
        t_lin.append(t1 - t0)
        t_w.append(t2 - t1)
        t_c.append(t3 - t2)
        assert np.allclose(np.nan_to_num(z_lin, nan=0), np.nan_to_num(z, nan=0))
        if c is not None and o["contact"]:
            both += 1
            agree += np.hypot(c[0] - o["centroid_x_mm"], c[1] - o["centroid_y_mm"]) <= 0.5
    med = lambda a: 1e3 * float(np.median(a))
    print(f"windows: {len(windows)}; contact in both: {both}; centroids within 0.5 mm of gradtac's: {agree}")
    print(f"linear_nd {med(t_lin):.3f} ms, weights {med(t_w):.3f} ms, contour {med(t_c):.3f} ms per window (medians)")
    print(f"pipelines: linear_nd + contour {med(np.add(t_lin, t_c)):.3f} ms, weights + contour {med(np.add(t_w, t_c)):.3f} ms per window")


if __name__ == "__main__":
    main()
