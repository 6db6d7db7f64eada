"""Reference values for crates/optics/tests/thinfilm.rs from the `tmm` package.

tmm (S. J. Byrnes, https://pypi.org/project/tmm/, MIT licence) is an independent
transfer-matrix implementation. This script draws 24 random stacks (seeded), evaluates
each with `tmm.coh_tmm` for s and p at 5 angles and 10 wavelengths, and writes
`tmm_reference.csv`. Run with tmm 0.2.x/2.x and numpy installed:

    python3 make_tmm.py        # rewrites tmm_reference.csv beside this file

Columns: stack (layers from the incidence side as `n:k:d_nm` joined by `/`),
ambient_n (real incidence medium), exit_n, exit_k (exit medium), theta_deg (in the
ambient), wavelength_nm, then rs_re, rs_im, rp_re, rp_im, ts_re, ts_im, tp_re, tp_im,
R_s, R_p, T_s, T_p as tmm returns them (repr of float64: every digit).
"""
import csv
import os

import numpy as np
import tmm

rng = np.random.default_rng(47)
rows = []
for sid in range(24):
    nlay = int(rng.integers(1, 8))
    layers = []
    for _ in range(nlay):
        kind = rng.random()
        if kind < 0.15:  # a thin metal layer
            n, k, d = rng.uniform(0.2, 1.5), rng.uniform(2.0, 7.0), rng.uniform(5, 40)
        elif kind < 0.55:  # an absorbing dielectric (Fe2O3-like)
            n, k, d = rng.uniform(1.2, 3.0), rng.uniform(0.0, 0.5), rng.uniform(10, 600)
        else:  # a clear dielectric, sometimes below the ambient's index (evanescent inside)
            n, k, d = rng.uniform(1.1, 3.0), 0.0, rng.uniform(10, 600)
        layers.append((float(n), float(k), float(d)))
    ambient = float(rng.choice([1.0, 1.5, float(rng.uniform(1.0, 1.7))]))
    ex = rng.random()
    if ex < 0.3:
        exit_n, exit_k = float(rng.uniform(0.5, 1.5)), float(rng.uniform(3.0, 7.0))  # metal core
    elif ex < 0.6:
        exit_n, exit_k = ambient, 0.0  # a free flake in its binder
    else:
        exit_n, exit_k = 1.0, 0.0  # air below: total internal reflection when ambient > 1
    thetas = np.sort(rng.uniform(0.0, 85.0, 5))
    thetas[0] = 0.0 if sid % 4 == 0 else thetas[0]
    wls = np.sort(rng.uniform(380.0, 780.0, 10))
    spec = "/".join(f"{n!r}:{k!r}:{d!r}" for n, k, d in layers)
    n_list = [ambient] + [complex(n, k) for n, k, _ in layers] + [complex(exit_n, exit_k)]
    d_list = [np.inf] + [d for _, _, d in layers] + [np.inf]
    for th in thetas:
        for wl in wls:
            res = {}
            for pol in ("s", "p"):
                out = tmm.coh_tmm(pol, n_list, d_list, np.radians(th), wl)
                res[pol] = out
            rs, rp, ts, tp = res["s"]["r"], res["p"]["r"], res["s"]["t"], res["p"]["t"]
            rows.append([spec, repr(ambient), repr(exit_n), repr(exit_k), repr(float(th)),
                         repr(float(wl)),
                         repr(float(np.real(rs))), repr(float(np.imag(rs))),
                         repr(float(np.real(rp))), repr(float(np.imag(rp))),
                         repr(float(np.real(ts))), repr(float(np.imag(ts))),
                         repr(float(np.real(tp))), repr(float(np.imag(tp))),
                         repr(float(res["s"]["R"])), repr(float(res["p"]["R"])),
                         repr(float(res["s"]["T"])), repr(float(res["p"]["T"]))])

here = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(here, "tmm_reference.csv"), "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(["stack", "ambient_n", "exit_n", "exit_k", "theta_deg", "wavelength_nm",
                "rs_re", "rs_im", "rp_re", "rp_im", "ts_re", "ts_im", "tp_re", "tp_im",
                "R_s", "R_p", "T_s", "T_p"])
    w.writerows(rows)
print(len(rows), "rows")
