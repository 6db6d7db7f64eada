//! The floor of the criterion benches (`cargo xtask bench`, docs/benchmarks.md): one
//! streaming, single-threaded pass that reads every input value once. `time / floor`
//! says how far an operation is from being memory-bound, a figure that survives noisy
//! machines. Dev-only: the benches of `stats`, `synth` and `topo` use it.
//!
//! ```
//! let z = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0];
//! assert_eq!(flakescatter_benchfloor::streaming_sum(&z), 55.0);
//! ```

/// The sum of `z` in one pass, with eight independent accumulators so that the loop is
/// limited by memory bandwidth rather than by the latency of one add.
#[must_use]
pub fn streaming_sum(z: &[f64]) -> f64 {
    let mut acc = [0.0f64; 8];
    let chunks = z.chunks_exact(8);
    let tail: f64 = chunks.remainder().iter().sum();
    for ch in chunks {
        for (a, v) in acc.iter_mut().zip(ch) {
            *a += v;
        }
    }
    acc.iter().sum::<f64>() + tail
}

#[cfg(test)]
mod tests {
    use super::streaming_sum;

    #[test]
    fn sums_every_value_once() {
        // 1 + 2 + ... + n = n (n + 1) / 2, exact in f64 for these n; lengths around the
        // 8-wide chunks and their remainder.
        for n in [0usize, 1, 7, 8, 9, 16, 1001] {
            let z: Vec<f64> = (1..=n).map(|k| k as f64).collect();
            assert_eq!(streaming_sum(&z), (n * (n + 1) / 2) as f64, "n = {n}");
        }
        // NaN (an invalid pixel) propagates: the floor reads it like any value.
        assert!(streaming_sum(&[1.0, f64::NAN]).is_nan());
    }
}
