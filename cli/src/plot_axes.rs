//! Axis ranges for the run's plots: padded linear ranges, log ranges of at least two decades
//! (so that an axis carries more than one label), and ranges widened to equal aspect.

/// A range around the values with a 5% margin (never empty).
pub fn bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.05)
        .max(1e-12 * lo.abs().max(hi.abs()))
        .max(1e-300);
    (lo - pad, hi + pad)
}

/// A log range of positive values: whole decades around them, at least two.
pub fn log_bounds(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
    if !lo.is_finite() {
        return (1e-17, 1e-15);
    }
    let (mut a, mut b) = (lo.log10().floor(), hi.log10().ceil());
    if b - a < 2.0 {
        let missing = 2.0 - (b - a);
        a -= (missing / 2.0).ceil();
        b += (missing / 2.0).floor();
    }
    (10f64.powf(a), 10f64.powf(b))
}

/// Widens the narrower of the ranges `x`, `y` about its centre so that a unit takes as many
/// pixels on both axes of a plotting area of `pixels = (width, height)`: circles stay round.
pub fn equal_aspect(x: (f64, f64), y: (f64, f64), pixels: (f64, f64)) -> ((f64, f64), (f64, f64)) {
    let (w, h) = (pixels.0.max(1.0), pixels.1.max(1.0));
    let (dx, dy) = (x.1 - x.0, y.1 - y.0);
    // Units per pixel on each axis; both become the larger.
    let scale = (dx / w).max(dy / h);
    let widen = |(a, b): (f64, f64), span: f64| {
        let c = 0.5 * (a + b);
        (c - 0.5 * span, c + 0.5 * span)
    };
    (widen(x, scale * w), widen(y, scale * h))
}

#[cfg(test)]
mod tests {
    use super::{equal_aspect, log_bounds};

    #[test]
    fn a_circle_stays_round_and_both_ranges_cover_their_data() {
        // A crank circle of radius 0.4 on an 800 × 300 pixel area.
        let ((x0, x1), (y0, y1)) = equal_aspect((-0.4, 0.4), (-0.4, 0.4), (800.0, 300.0));
        assert!(((x1 - x0) / 800.0 - (y1 - y0) / 300.0).abs() < 1e-15);
        assert!(x0 <= -0.4 && x1 >= 0.4 && y0 <= -0.4 && y1 >= 0.4);
        // A tall path on a wide area widens x, keeps y.
        let ((x0, x1), (y0, y1)) = equal_aspect((0.0, 1.0), (0.0, 10.0), (600.0, 300.0));
        assert_eq!((y0, y1), (0.0, 10.0));
        assert!((x1 - x0 - 20.0).abs() < 1e-12 && (x0 + x1 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn log_ranges_span_whole_decades_at_least_two() {
        assert_eq!(log_bounds([2e-16, 3e-16].into_iter()), (1e-17, 1e-15));
        let (lo, hi) = log_bounds([1e-16, 5e-12].into_iter());
        assert!((lo - 1e-16).abs() < 1e-30 && (hi - 1e-11).abs() < 1e-25);
        assert_eq!(log_bounds([0.0].into_iter()), (1e-17, 1e-15));
    }
}
