#!/usr/bin/python3
"""The NumPy peer of dbbkit's Monte Carlo (BM_MonteCarloPaperC): what a careful Python
user writes for the same job. The paper's C design (designs/paper-c-turntable.json),
per-angle model, rectangular reading noise +-a; the six errors at every angle are
theta = pinv(J) y, so each trial is one column of pinv(J) V with V the drawn noise;
trials in batches of 10,000 (float32 kept for the quantiles), then np.quantile for the
probabilistically symmetric 95 % interval of every value.

    OPENBLAS_NUM_THREADS=1 /usr/bin/python3 benchmarks/peer_monte_carlo.py [trials]

J is built from the design as dbbkit builds it (model.md): the row of a reading at
angle g is s (R u, 1e-3 R P x R u) with R the rotation about z, u the direction and P
the ball in the rotating frame. As a check of the peer, its linear standard
uncertainties are printed beside the Monte Carlo ones (they must equal dbbkit
evaluate's worst_std_um, 2.0565 um for angles at 100 mm).
"""

import json
import os
import resource
import sys
import time

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def jacobian(design):
    a = design["angles_deg"]
    angles = np.arange(a["start"], a["stop"] + 1e-9, a["step"]) if isinstance(a, dict) else np.array(a, float)
    stations = sorted({round(float(g) % 360.0, 9) for g in angles})
    body = {"radial": np.array([1.0, 0, 0]), "tangential": np.array([0, 1.0, 0]), "axial": np.array([0, 0, 1.0])}
    rows = []
    for inst in design["installations"]:
        b = inst["ball_mm"]
        P0 = np.array([b.get("L", 0.0), b.get("D", 0.0), b.get("H", 0.0)])
        u0 = body[inst["direction"]]
        s = inst.get("sign", 1)
        for g in angles:
            c, sn = np.cos(np.radians(g)), np.sin(np.radians(g))
            R = np.array([[c, -sn, 0], [sn, c, 0], [0, 0, 1.0]])
            P, u = R @ P0, R @ u0
            row = np.zeros(6 * len(stations))
            k = 6 * stations.index(round(float(g) % 360.0, 9))
            row[k:k + 3] = s * u
            row[k + 3:k + 6] = 1e-3 * s * np.cross(P, u)
            rows.append(row)
    return np.array(rows)


def main():
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    design = json.load(open(os.path.join(root, "designs", "paper-c-turntable.json")))
    a = design["noise"]["accuracy_um"]
    J = jacobian(design)
    G = np.linalg.pinv(J)  # theta per um of the readings
    n_out, n = G.shape
    sigma = a / np.sqrt(3.0)
    u_lin = sigma * np.sqrt((G * G).sum(axis=1))
    scale = np.tile([1, 1, 1, 0.1, 0.1, 0.1], n_out // 6)  # urad at 100 mm: um
    print(f"linear worst standard uncertainty {np.max(u_lin * scale):.4f} um (dbbkit evaluate: 2.0565 um)")

    rng = np.random.default_rng(1)
    batch = 10_000
    t0, c0 = time.perf_counter(), time.process_time()
    out = np.empty((n_out, trials), dtype=np.float32)
    for start in range(0, trials, batch):
        m = min(batch, trials - start)
        V = rng.uniform(-a, a, size=(n, m))
        out[:, start:start + m] = G @ V
    draws_s = time.perf_counter() - t0
    low, high = np.quantile(out, [0.025, 0.975], axis=1)
    mean, std = out.mean(axis=1), out.std(axis=1, ddof=1)
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"{trials} trials of {n_out} values from {n} readings: {wall:.3f} s wall, {cpu:.3f} s CPU "
          f"(draws and products {draws_s:.3f} s), peak RSS {peak:.0f} MiB")
    print(f"  largest |std / u_lin - 1| = {np.max(np.abs(std / u_lin - 1)):.2e}; "
          f"dz at 20 deg: interval [{low[8]:.4f}, {high[8]:.4f}] um, mean {mean[8]:+.1e}")


if __name__ == "__main__":
    main()
