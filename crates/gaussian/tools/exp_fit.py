"""Coefficients of the polynomial for e^r in the batch kernel (crates/gaussian/src/batch/lanes.rs).

A Chebyshev fit of degree 11 to e^r on [-ln 2 / 2, ln 2 / 2] (mpmath's `chebyfit`, 50
digits), its coefficients rounded to f64, and the largest relative error of the rounded
polynomial against e^r, evaluated in 50-digit arithmetic on 40,001 points. Run with
`python3 exp_fit.py` (needs `pip install mpmath`); it prints the coefficients, lowest
degree first, as Rust literals, and the error (1.7e-17 with mpmath 1.3.0: a sixth of
an ulp, before the kernel's own rounding).
"""

import mpmath as mp

mp.mp.dps = 50
HALF_LN2 = mp.log(2) / 2
DEGREE = 11

coeffs = mp.chebyfit(mp.exp, [-HALF_LN2, HALF_LN2], DEGREE + 1)
rounded = [float(c) for c in coeffs[::-1]]

worst = mp.mpf(0)
for i in range(40_001):
    r = -HALF_LN2 + 2 * HALF_LN2 * i / 40_000
    p = mp.mpf(0)
    for c in reversed(rounded):
        p = p * r + mp.mpf(c)
    worst = max(worst, abs(p / mp.exp(r) - 1))

for c in rounded:
    print(f"    {c!r},")
print("largest relative error", mp.nstr(worst, 3))
