#!/usr/bin/python3
"""The NumPy peer of dbbkit's series identify (BM_IdentifyFourier/360/20): what a careful
Python user writes for the same job. The paper's C design with the five extra installations
of the benchmark (12 in all), 360 angles over a turn, every error a Fourier series of order
20 (41 coefficients each, 246 unknowns, 4,320 readings); the readings whitened by the
declared noise (rectangular +-1.25 um), the estimate by np.linalg.lstsq and its covariance
as the inverse of the information (J' J)^-1.

    OPENBLAS_NUM_THREADS=1 /usr/bin/python3 benchmarks/peer_series_identify.py [angles] [order]

J is built as dbbkit builds it (model.md): the row of a reading at angle g is
s (R u, 1e-3 R P x R u) with R the rotation about z, u the direction and P the ball in the
rotating frame, times the series basis (1, cos g, sin g, ..., cos K g, sin K g) of each
error. As a check of the peer, chi2 over its degrees of freedom (about 1 for noise as
declared) and the largest standard uncertainty of a coefficient are printed.
"""

import json
import os
import sys
import time

import numpy as np

root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def installations():
    with open(os.path.join(root, "designs", "paper-c-turntable.json")) as f:
        design = json.load(f)
    base = design["installations"]
    out = [dict(i) for i in base]
    for k in range(5):  # as BM_IdentifyFourier adds them
        i = json.loads(json.dumps(base[k % 7]))
        i["ball_mm"]["L"] = i["ball_mm"].get("L", 0.0) + 30 + 10 * k
        i["ball_mm"]["H"] = i["ball_mm"].get("H", 0.0) + 20 * k
        out.append(i)
    return out


def jacobian(angles_deg, order):
    body = {"radial": np.array([1.0, 0, 0]), "tangential": np.array([0, 1.0, 0]), "axial": np.array([0, 0, 1.0])}
    g = np.radians(angles_deg)
    basis = [np.ones_like(g)]
    for k in range(1, order + 1):
        basis += [np.cos(k * g), np.sin(k * g)]
    basis = np.stack(basis, axis=1)  # angles x (2K + 1)
    blocks = []
    for inst in installations():
        b = inst["ball_mm"]
        P0 = np.array([b.get("L", 0.0), b.get("D", 0.0), b.get("H", 0.0)])
        u0 = body[inst["direction"]]
        s = inst.get("sign", 1)
        c, sn = np.cos(g), np.sin(g)
        P = np.stack([c * P0[0] - sn * P0[1], sn * P0[0] + c * P0[1], np.full_like(g, P0[2])], axis=1)
        u = np.stack([c * u0[0] - sn * u0[1], sn * u0[0] + c * u0[1], np.full_like(g, u0[2])], axis=1)
        row6 = s * np.concatenate([u, 1e-3 * np.cross(P, u)], axis=1)  # angles x 6
        # error e's coefficients multiply row6[:, e] times the basis
        blocks.append((row6[:, :, None] * basis[:, None, :]).reshape(len(g), -1))
    return np.concatenate(blocks, axis=0)


def main():
    angles = int(sys.argv[1]) if len(sys.argv) > 1 else 360
    order = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    a = np.arange(angles) * 360.0 / angles
    sigma = 1.25 / np.sqrt(3.0)
    rng = np.random.default_rng(1)
    J = jacobian(a, order)
    theta = np.ones(J.shape[1])
    y = J @ theta + rng.uniform(-1.25, 1.25, J.shape[0])
    repeats = 5
    t0 = time.process_time()
    for _ in range(repeats):
        Jw, yw = J / sigma, y / sigma
        est, _, rank, _ = np.linalg.lstsq(Jw, yw, rcond=None)
        cov = np.linalg.inv(Jw.T @ Jw)
        r = yw - Jw @ est
        chi2 = float(r @ r)
    cpu = (time.process_time() - t0) / repeats
    dof = J.shape[0] - rank
    print(f"peer series identify: {J.shape[0]} readings x {J.shape[1]} unknowns (rank {rank}), "
          f"{cpu * 1e3:.1f} ms CPU per identify (mean of {repeats}); chi2/dof {chi2 / dof:.3f}, "
          f"largest coefficient std {np.sqrt(np.max(np.diag(cov))):.4g}")


if __name__ == "__main__":
    main()
