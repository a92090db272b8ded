#!/usr/bin/env python3
"""Reference vectors for gradtac-stages' Savitzky-Golay tests (tests/savgol_scipy.rs).

Run from this directory:  python3 gen_savgol.py
Writes savgol_coeffs.json and savgol_filter.json next to itself.

Two independent references are produced:
* scipy.signal.savgol_coeffs / savgol_filter (the versions are recorded in the files), and
* the exact coefficients, computed in rational arithmetic (fractions.Fraction) from the
  definition c = A^T (A A^T)^{-1} y (minimum-norm solution of the moment equations, which is
  what scipy's lstsq computes) and rounded to f64 once at the end.

scipy's savgol_coeffs solves a raw (unscaled) Vandermonde system with lstsq and a relative
singular-value cutoff of eps * window; for long windows and higher orders that cutoff drops
singular values and scipy's coefficients are wrong (relative error up to 1.0). Every case
records scipy's own error against the exact coefficients (`scipy_err`), so the tests compare
to scipy exactly where scipy is well-conditioned (`scipy_err <= SCIPY_OK`) and to the exact
values everywhere.
"""
import json
import sys
from fractions import Fraction
from math import factorial

import numpy as np
import scipy
from scipy.signal import savgol_coeffs, savgol_filter

SCIPY_OK = 1e-12


def exact_dot(w, p, d, pos, delta=1.0):
    """Exact weights (dot order: weight j multiplies sample j of the window) for the d-th
    derivative of the degree-p least-squares fit, evaluated at sample `pos`, divided by
    delta**d. Returns a list of floats (each rounded once)."""
    xs = [j - pos for j in range(w)]
    m = p + 1
    if d > p:
        return [0.0] * w
    # moments M[i][k] = sum x^(i+k); rows of A are x^i.
    mom = [sum(Fraction(x) ** e for x in xs) for e in range(2 * m - 1)]
    A = [[mom[i + k] for k in range(m)] + [Fraction(factorial(d)) if i == d else Fraction(0)] for i in range(m)]
    for c in range(m):
        piv = next(r for r in range(c, m) if A[r][c] != 0)
        A[c], A[piv] = A[piv], A[c]
        inv = 1 / A[c][c]
        A[c] = [v * inv for v in A[c]]
        for r in range(m):
            if r != c and A[r][c] != 0:
                f = A[r][c]
                A[r] = [a - f * b for a, b in zip(A[r], A[c])]
    a = [A[i][m] for i in range(m)]
    out = []
    for x in xs:
        v = Fraction(0)
        xp = Fraction(1)
        for k in range(m):
            v += a[k] * xp
            xp *= x
        out.append(float(v) / delta ** d)
    return out


def exact_conv(w, p, d, delta=1.0):
    """Exact centred coefficients in scipy's default 'conv' order (reversed)."""
    return exact_dot(w, p, d, (w - 1) // 2, delta)[::-1]


def rel_err(a, ref):
    a = np.asarray(a, float)
    ref = np.asarray(ref, float)
    scale = np.max(np.abs(ref))
    if scale == 0:
        return float(np.max(np.abs(a)))
    return float(np.max(np.abs(a - ref)) / scale)


def fingerprint_weights(w):
    """u_j = ((37 j + 11) mod 23)/23 - 1/2: a fixed pseudo-random probe, exactly reproducible in Rust."""
    return np.array([((37 * j + 11) % 23) / 23.0 - 0.5 for j in range(w)])


def fingerprint(c):
    c = np.asarray(c, float)
    return float(np.dot(c, fingerprint_weights(len(c))))


def main():
    versions = {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__}

    # 1. Full sweep, fingerprints only: every odd window 5..201, every order 0..12 (< window),
    #    derivatives 0..2, centred, conv order, delta = 1.
    sweep = []
    for w in range(5, 202, 2):
        for p in range(0, 13):
            if p >= w:
                continue
            for d in range(0, 3):
                ex = exact_conv(w, p, d)
                sc = savgol_coeffs(w, p, deriv=d)
                sweep.append({
                    "window": w, "polyorder": p, "deriv": d,
                    "max_abs": float(np.max(np.abs(ex))),
                    "exact_fp": fingerprint(ex), "scipy_fp": fingerprint(sc),
                    "scipy_err": rel_err(sc, ex),
                })
    n_ok = sum(1 for s in sweep if s["scipy_err"] <= SCIPY_OK)
    print(f"sweep: {len(sweep)} cases, scipy well-conditioned (err <= {SCIPY_OK:g}) in {n_ok}", file=sys.stderr)

    # 2. Full vectors for a subset: centred conv order, and dot order at the window's first and
    #    last sample (the edges of mode='interp' and the causal filter), plus a non-unit delta.
    full = []
    windows = [5, 7, 9, 11, 13, 15, 21, 25, 31, 41, 51, 75, 101, 151, 201]
    for w in windows:
        for p in range(0, 13):
            if p >= w:
                continue
            for d in range(0, 3):
                cases = [("conv", None, 1.0)]
                if w <= 31:
                    cases += [("dot", 0, 1.0), ("dot", w - 1, 1.0)]
                if w in (11, 21) and d > 0:
                    cases += [("conv", None, 0.01)]
                for use, pos, delta in cases:
                    if use == "conv":
                        ex = exact_conv(w, p, d, delta)
                        sc = savgol_coeffs(w, p, deriv=d, delta=delta)
                    else:
                        ex = exact_dot(w, p, d, pos, delta)
                        sc = savgol_coeffs(w, p, deriv=d, delta=delta, pos=pos, use="dot")
                    err = rel_err(sc, ex)
                    ok = err <= SCIPY_OK
                    full.append({
                        "window": w, "polyorder": p, "deriv": d, "delta": delta, "use": use,
                        "pos": pos, "scipy_err": err,
                        "source": "scipy" if ok else "exact",
                        "coeffs": [float(v) for v in (sc if ok else ex)],
                    })
    print(f"full vectors: {len(full)} cases, {sum(f['source'] == 'scipy' for f in full)} from scipy",
          file=sys.stderr)

    # 3. High orders, beyond the 0..12 sweep, exact only (scipy is hopeless there): where the
    #    Rust side accepts a case it must match; near-interpolating ones it should refuse.
    high = []
    for (w, p) in [(21, 20), (23, 22), (41, 25), (61, 30), (101, 40), (201, 40), (25, 24), (31, 30), (41, 40)]:
        for d in range(0, 3):
            high.append({"window": w, "polyorder": p, "deriv": d,
                         "coeffs": exact_conv(w, p, d)})

    with open("savgol_coeffs.json", "w") as f:
        json.dump({"versions": versions, "scipy_ok": SCIPY_OK,
                   "fingerprint": "sum_j c_j * (((37 j + 11) mod 23)/23 - 1/2), conv order",
                   "sweep": sweep, "full": full, "high": high}, f, separators=(",", ":"))

    # 3. savgol_filter(mode='interp') over whole signals, edges included. Three taxels per
    #    signal set (a noisy sine, a ramp with a step, a random walk), several configs.
    rng = np.random.default_rng(20261121)
    n = 160
    t = np.arange(n)
    signals = [
        2000 + 300 * np.sin(2 * np.pi * t / 37.0) + rng.normal(0, 5, n),
        1500 + 2.5 * t + 400 * (t > 80) + rng.normal(0, 3, n),
        np.cumsum(rng.normal(0, 1, n)),
    ]
    configs = [(5, 2, 0, 1.0), (11, 3, 0, 1.0), (11, 3, 1, 0.01), (11, 3, 2, 0.01), (21, 4, 0, 1.0),
               (31, 5, 1, 1.0), (7, 6, 0, 1.0), (9, 0, 0, 1.0), (15, 4, 3, 0.5), (51, 3, 0, 1.0)]
    filt = []
    for (w, p, d, delta) in configs:
        for length in (n, w):  # a whole recording, and one exactly a window long
            xs = [s[:length] for s in signals]
            outs = [savgol_filter(x, w, p, deriv=d, delta=delta, mode="interp") for x in xs]
            # exact-coefficient reference of the same filter, to record scipy's own error
            h = w // 2
            exact_outs = []
            for x in xs:
                y = np.empty(length)
                cen = np.array(exact_dot(w, p, d, h, delta))
                for i in range(h, length - h):
                    y[i] = np.dot(cen, x[i - h:i + h + 1])
                for i in range(h):
                    y[i] = np.dot(np.array(exact_dot(w, p, d, i, delta)), x[:w])
                    j = length - h + i
                    y[j] = np.dot(np.array(exact_dot(w, p, d, w - h + i, delta)), x[length - w:])
                exact_outs.append(y)
            err = max(rel_err(o, e) for o, e in zip(outs, exact_outs))
            filt.append({"window": w, "polyorder": p, "deriv": d, "delta": delta, "scipy_err": err,
                         "input": [x.tolist() for x in xs], "output": [o.tolist() for o in outs]})
            print(f"filter w={w} p={p} d={d} delta={delta} n={length}: scipy vs exact {err:.2e}", file=sys.stderr)
    with open("savgol_filter.json", "w") as f:
        json.dump({"versions": versions, "mode": "interp", "cases": filt}, f, separators=(",", ":"))


if __name__ == "__main__":
    main()
