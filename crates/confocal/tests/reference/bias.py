"""Independent numpy reference for crates/confocal/tests/bias.rs.

Systematic (noise-free) peak-position error of each estimator for a surface whose true
peak sits at a fraction d of a z step from a slice, d on 201 points in [-1/2, 1/2];
z step 0.3 um, slices 0..40, true peak near slice 20. Estimators as documented in
crates/confocal/src/peak.rs (fraction 0.5; Gaussian LSQ weighted by I^2).
Prints max |error| and rms error in um. Run: python bias.py
"""
import numpy as np


def gauss(z, w):
    return np.exp(-4 * np.log(2) * z**2 / w**2)


def sinc2(z, w):
    x = 2 * 1.39155737825151 * z / w
    out = np.ones_like(x)
    nz = np.abs(x) > 1e-8
    out[nz] = (np.sin(x[nz]) / x[nz]) ** 2
    return out


def run(i, frac=0.5):
    k = int(np.argmax(i))
    t = frac * i[k]
    lo = k
    while lo > 0 and i[lo - 1] >= t:
        lo -= 1
    hi = k
    while hi + 1 < len(i) and i[hi + 1] >= t:
        hi += 1
    return k, lo, hi, t


def estimate(i, method):
    k, lo, hi, t = run(i)
    if method == "argmax":
        return float(k)
    if method == "centroid":
        x = np.arange(lo, hi + 1)
        w = i[lo:hi + 1] - t
        return float((x * w).sum() / w.sum())
    lo, hi = min(lo, k - 1), max(hi, k + 1)
    x = np.arange(lo, hi + 1) - k
    y = i[lo:hi + 1]
    if method == "parabolic":
        c = np.polyfit(x, y, 2)
    else:
        # weighted least squares of ln I with weights I^2 (polyfit's w multiplies residuals)
        c = np.polyfit(x, np.log(y), 2, w=y)
    return k - c[1] / (2 * c[0])


dz = 0.3
for name, resp in (("gaussian", gauss), ("sinc2", sinc2)):
    for w in (0.5, 0.6, 0.7):
        for m in ("argmax", "parabolic", "gaussian", "centroid"):
            e = []
            for d in np.linspace(-0.5, 0.5, 201):
                z0 = (20 + d) * dz
                i = resp(np.arange(40) * dz - z0, w)
                e.append(estimate(i, m) * dz - z0)
            e = np.array(e)
            print(f"{name} {w} {m} {np.abs(e).max():.6f} {np.sqrt((e**2).mean()):.6f}")
