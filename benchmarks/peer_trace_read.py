#!/usr/bin/env python3
"""Peer of BM_ReadingsFromTrace: what a notebook does with a raw trace of 10^7 samples, NumPy's
np.loadtxt of the same CSV layout (time_s,reading_um after one comment line), reading only (no
dwell search). Writes the file itself (np.savetxt), then times the read.

    OPENBLAS_NUM_THREADS=1 /usr/bin/python3 benchmarks/peer_trace_read.py [samples]
"""
import os
import sys
import tempfile
import time

import numpy as np

n = int(sys.argv[1]) if len(sys.argv) > 1 else 10_000_000
rng = np.random.default_rng(1)
t = np.arange(n) / 1000.0
x = np.round(0.15 * rng.standard_normal(n) + 20 * np.sin(t / 30.0) ** 2, 4)
with tempfile.TemporaryDirectory() as tmp:
    path = os.path.join(tmp, "trace.csv")
    np.savetxt(path, np.column_stack([t, x]), fmt="%.4f", delimiter=",",
               header="peer trace\ntime_s,reading_um", comments="")
    start = time.process_time()
    data = np.loadtxt(path, delimiter=",", skiprows=2)
    seconds = time.process_time() - start
print(f"np.loadtxt of {n} samples: {seconds:.2f} s CPU, {n / seconds / 1e6:.2f} M samples/s "
      f"({data.shape[0]} rows)")
