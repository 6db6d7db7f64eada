"""Simulated behaviour of the pooled-width statistics of `flakescatter_stats::pool`.

An independent re-implementation in numpy/scipy of the two things `pool.rs` claims in
its module docs:

1. coverage of the map-level 95 % interval (ratio estimator over maps, Student's t on
   M - 1 degrees of freedom, on ln m2; also on m2 itself for comparison);
2. how often the per-map consistency test (Gamma-corrected log mean square tilt,
   Bonferroni bound, most extreme map set aside and the rest tested again) flags maps.

Maps: Poisson(70) flakes (at least 2), log-normal areas (sigma_ln = 1), small Gaussian
tilts: theta^2 = 2 s^2 E with E ~ Exp(1). Only ratios matter, so s^2 = 1.

Run: python3 pool_simulation.py   (numpy, scipy; about a minute)
"""
import numpy as np
from scipy import special, stats

rng = np.random.default_rng(20260416)


def draw_map(s2, n_mean=70):
    n = max(rng.poisson(n_mean), 2)
    return 2.0 * s2 * rng.exponential(size=n), rng.lognormal(0.0, 1.0, size=n)


def coverage(M, reps, tau):
    cov_log = cov_lin = 0
    for _ in range(reps):
        S = np.empty(M)
        A = np.empty(M)
        for j in range(M):
            th2, a = draw_map(np.exp(tau * rng.standard_normal()))
            S[j] = (a * th2).sum()
            A[j] = a.sum()
        m2 = S.sum() / A.sum()
        se = np.sqrt(M / (M - 1) * ((S - m2 * A) ** 2).sum()) / A.sum()
        t = stats.t.ppf(0.975, M - 1)
        target = 2.0 * np.exp(tau**2 / 2)
        cov_lin += m2 - t * se <= target <= m2 + t * se
        cov_log += m2 * np.exp(-t * se / m2) <= target <= m2 * np.exp(t * se / m2)
    return cov_log / reps, cov_lin / reps


def y_v(a_sum, s_sum, a2_sum):
    n = a_sum**2 / a2_sum
    return np.log(s_sum / a_sum) - special.digamma(n) + np.log(n), special.polygamma(1, n)


def flags(maps):
    M = len(maps)
    sums = [(a.sum(), (a * th2).sum(), (a * a).sum()) for th2, a in maps]
    bound = stats.norm.ppf(1 - 0.025 / M)
    accepted = list(range(M))
    flagged = set()
    while True:
        z = {}
        for j in range(M):
            rest = [k for k in accepted if k != j]
            r = [sum(sums[k][i] for k in rest) for i in range(3)]
            yr, vr = y_v(*r)
            yj, vj = y_v(*sums[j])
            z[j] = (yj - yr) / np.sqrt(vj + vr)
        worst = max(accepted, key=lambda k: abs(z[k]))
        if abs(z[worst]) > bound and len(accepted) > 2:
            flagged.add(worst)
            accepted.remove(worst)
        elif abs(z[worst]) > bound and len(accepted) == 2:
            flagged.update(accepted)
            break
        else:
            break
    return flagged


def flag_rates(M, reps, bad_s2):
    any_flag = bad_flag = good_flag = 0
    for _ in range(reps):
        maps = [draw_map(bad_s2 if (bad_s2 and j == 0) else 1.0) for j in range(M)]
        f = flags(maps)
        any_flag += len(f) > 0
        bad_flag += 0 in f
        good_flag += len(f - {0}) > 0
    return any_flag / reps, bad_flag / reps, good_flag / reps


if __name__ == "__main__":
    print("map-level coverage (log interval, linear interval), 4000 repetitions")
    for tau in (0.0, 0.1):
        for M in (2, 3, 4, 6, 8, 12):
            lg, ln = coverage(M, 4000, tau)
            print(f"  scatter {tau:.1f}  maps {M:2d}: {100 * lg:.1f} %  {100 * ln:.1f} %")
    print("consistency test, 1000 repetitions")
    for M in (3, 6, 8, 12):
        null = flag_rates(M, 1000, None)[0]
        _, bad, good = flag_rates(M, 1000, (10 / 6) ** 2)
        _, small, _ = flag_rates(M, 1000, 1.5)
        print(
            f"  maps {M:2d}: no bad map, some flagged {100 * null:.1f} %; "
            f"hwhm 10 vs 6: bad flagged {100 * bad:.1f} %, a good one too {100 * good:.1f} %; "
            f"m2 x 1.5: flagged {100 * small:.1f} %"
        )
