#!/usr/bin/env python3
"""Reference vectors for gradtac-stages' drift map and the one-fingertip slip classifier's drift
features (tests/dos_drift_reference.rs).

An independent, vectorised numpy implementation of the definitions in gradtac_stages::drift and
gradtac_stages::dos (drift features), run on synthetic integer "BioTac counts" (seeded numpy RNG:
per-taxel baselines and noise, a slow pressure bump sliding along a direction or turning about the
pad's centre, some values <= 0 that hit the floor, a constant taxel). The recordings are stored as
integers, so Rust reads exactly the same input.

Run from the repository root:  python3 gradtac-stages/tests/reference/gen_dos_drift.py
Writes dos_drift.json next to itself (numpy version recorded in "generator").
"""
import json
import os

import numpy as np

from biotac_sp import biotac_positions  # the shared BioTac SP layout

LAGS = (30, 60, 120)
FLOOR = 1e-3
EPS = 1e-9

P = np.array(biotac_positions())  # (x_mm, y_mm) of electrodes 1..24, as Layout::biotac_sp


def drift_map(counts):
    """weights w_i, signs s_i: mean over the lags with at least one difference."""
    r = np.log(np.maximum(counts.astype(float), FLOOR))
    T = len(r)
    noise = np.abs(np.diff(r, axis=0)).mean(0)
    used = [S for S in LAGS if S < T]
    w = np.zeros(r.shape[1])
    s = np.zeros(r.shape[1])
    for S in used:
        d = r[S:] - r[:-S]
        absd = np.abs(d).sum(0)
        drift = absd / len(d)
        with np.errstate(divide='ignore', invalid='ignore'):
            ws = np.where(drift > 0, np.maximum(np.log(drift / (noise + EPS)), 0.0), 0.0)
            ss = np.where(absd > 0, 2.0 * np.maximum(d, 0).sum(0) / absd - 1.0, 0.0)
        w += ws
        s += ss
    return w / len(used), s / len(used)


def drift_features(w, s):
    W = w.sum()
    c = (w @ P) / W
    dx, dy = P[:, 0] - c[0], P[:, 1] - c[1]
    return [float(np.log1p(W)), float(c[0]), float(c[1]), float(np.log1p((w * (dx**2 + dy**2)).sum() / W)),
            float((w * (dx**2 - dy**2)).sum() / W), float((w * dx * dy).sum() / W), float((w * s * P[:, 1]).sum() / W)]


def recording(rng, frames, motion):
    base = rng.integers(2400, 3700, 24).astype(float)
    t = np.arange(frames) / 100.0
    if motion == "touch":
        centre = np.zeros((frames, 2))
    elif motion == "rotate":
        ang = 0.8 * t
        centre = np.c_[4 * np.cos(ang), 4 * np.sin(ang)]
    else:
        v = np.array(motion)
        centre = np.outer(t, v) - v
    d2 = ((P[None, :, :] - centre[:, None, :]) ** 2).sum(-1)
    press = 300 * np.exp(-d2 / (2 * 4.0**2))
    x = base[None, :] - press + rng.normal(0, 3, (frames, 24))
    x = np.rint(x)
    return x


def main():
    rng = np.random.default_rng(20261121)
    cases = []
    for name, frames, motion in [("north", 280, (3.0, 0.0)), ("west", 275, (0.0, -2.5)), ("rotate", 270, "rotate"),
                                 ("touch", 260, "touch"), ("short", 45, (4.0, 1.0))]:
        x = recording(rng, frames, motion)
        if name == "north":
            x[:, 5] = 3333.0           # a constant taxel: no noise, no drift
            x[100:110, 7] = -5.0       # values <= 0 hit the floor
        w, s = drift_map(x)
        cases.append({"name": name, "counts": x.astype(int).tolist(), "weights": w.tolist(), "signs": s.tolist(),
                      "features": drift_features(w, s)})
    out = {
        "generator": f"gen_dos_drift.py, numpy {np.__version__}",
        "lags": list(LAGS),
        "floor": FLOOR,
        "features": ["drift_level", "drift_x", "drift_y", "drift_spread", "drift_anisotropy", "drift_cross",
                     "drift_signed_y"],
        "cases": cases,
    }
    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "dos_drift.json")
    with open(path, "w") as f:
        json.dump(out, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
