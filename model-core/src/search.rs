//! One-dimensional minimisation shared by the models that need it (the CLC planner's radii, the
//! bulldozing failure angle).

/// (√5 − 1) / 2.
const INV_PHI: f64 = 0.618_033_988_749_894_8;

/// Golden-section search for a minimum of `f` on [lo, hi]: stops when the bracket is narrower
/// than `tolerance` or after `max_iterations` evaluations. Needs no derivative, so a kink (the
/// energy at R') does not disturb it. Ties move towards `lo`. Returns (x, f(x)) of the better
/// of the two final interior points.
pub fn golden_section_min(
    f: impl Fn(f64) -> f64,
    mut lo: f64,
    mut hi: f64,
    tolerance: f64,
    max_iterations: usize,
) -> (f64, f64) {
    let mut c = hi - INV_PHI * (hi - lo);
    let mut d = lo + INV_PHI * (hi - lo);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..max_iterations {
        if hi - lo <= tolerance {
            break;
        }
        if fc <= fd {
            hi = d;
            d = c;
            fd = fc;
            c = hi - INV_PHI * (hi - lo);
            fc = f(c);
        } else {
            lo = c;
            c = d;
            fc = fd;
            d = lo + INV_PHI * (hi - lo);
            fd = f(d);
        }
    }
    if fc <= fd {
        (c, fc)
    } else {
        (d, fd)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_smooth_and_kinked_minima() {
        let (x, fx) = golden_section_min(|x| (x - 0.3) * (x - 0.3) + 1.0, -2.0, 5.0, 1e-9, 200);
        assert!((x - 0.3).abs() < 1e-6 && (fx - 1.0).abs() < 1e-9);
        // |x − R'| kink, as in the arc energy at R'.
        let (x, _) = golden_section_min(|x| (x - 0.645).abs(), 0.0, 10.0, 1e-9, 200);
        assert!((x - 0.645).abs() < 1e-8);
        // Iteration cap respected on a tolerance of 0.
        let calls = core::cell::Cell::new(0);
        golden_section_min(
            |x| {
                calls.set(calls.get() + 1);
                x
            },
            0.0,
            1.0,
            0.0,
            10,
        );
        assert_eq!(calls.get(), 12);
        // NaN never panics.
        let _ = golden_section_min(|_| f64::NAN, 0.0, 1.0, 1e-9, 50);
    }
}
