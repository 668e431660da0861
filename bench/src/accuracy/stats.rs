//! Figures drawn from a convergence curve: its log-log slope, the time it needs to reach a
//! relMSE, and its efficiency 1 / (relMSE · time).
use super::measure::Point;

/// The fewest samples per pixel a slope is fitted from: below it, per-call overhead and the
/// first samples' outliers dominate.
pub const SLOPE_FROM_SPP: u32 = 4;

/// Least-squares slope of ln y against ln x (None with fewer than two usable points).
pub fn log_log_slope(xy: impl Iterator<Item = (f64, f64)>) -> Option<f64> {
    let pts: Vec<(f64, f64)> =
        xy.filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) =
        (pts.iter().map(|p| p.0).sum::<f64>() / n, pts.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// Slope of ln relMSE against ln time over the points with at least [`SLOPE_FROM_SPP`] spp.
pub fn time_slope(points: &[Point]) -> Option<f64> {
    log_log_slope(points.iter().filter(|p| p.spp >= SLOPE_FROM_SPP).map(|p| (p.time_s, p.rel_mse)))
}

/// How the time to a relMSE target was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Already below the target at the first point (time of that point, an upper bound).
    AtOnce(f64),
    /// Interpolated in log-log between the two points around the target.
    Measured(f64),
    /// Not reached within the budget: extrapolated along the fitted slope.
    Extrapolated(f64),
    /// The extrapolation lands beyond [`EXTRAPOLATE_AT_MOST`]× the measured time (a value that far
    /// out means nothing: flat slopes there are pre-asymptotic or heavy-tailed); at least this.
    Beyond(f64),
    /// Not reached and the curve does not fall.
    Never,
}

/// How far past the last measured time an extrapolated time is still given.
pub const EXTRAPOLATE_AT_MOST: f64 = 100.0;

pub fn time_to(points: &[Point], target: f64) -> Reach {
    let Some(first) = points.first() else { return Reach::Never };
    if first.rel_mse <= target {
        return Reach::AtOnce(first.time_s);
    }
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if b.rel_mse <= target {
            let f = (target.ln() - a.rel_mse.ln()) / (b.rel_mse.ln() - a.rel_mse.ln());
            return Reach::Measured((a.time_s.ln() + f * (b.time_s.ln() - a.time_s.ln())).exp());
        }
    }
    let last = points[points.len() - 1];
    match time_slope(points) {
        Some(s) if s < -0.1 && last.rel_mse > 0.0 => {
            let t = last.time_s * (target / last.rel_mse).powf(1.0 / s);
            if t <= EXTRAPOLATE_AT_MOST * last.time_s {
                Reach::Extrapolated(t)
            } else {
                Reach::Beyond(EXTRAPOLATE_AT_MOST * last.time_s)
            }
        }
        _ => Reach::Never,
    }
}

/// 1 / (relMSE · time) at the end of the budget (the last point); larger is better. For a curve
/// of slope −1 it does not depend on where it is read.
pub fn efficiency(points: &[Point]) -> f64 {
    points.last().map_or(0.0, |p| 1.0 / (p.rel_mse * p.time_s).max(f64::MIN_POSITIVE))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(slope: f64) -> Vec<Point> {
        (0..8)
            .map(|k| Point {
                spp: 1 << k,
                time_s: 0.01 * (1 << k) as f64,
                rel_mse: 0.5 * ((1 << k) as f64).powf(slope),
            })
            .collect()
    }

    #[test]
    fn slope_and_times_of_an_exact_power_law() {
        let c = curve(-1.0);
        assert!((time_slope(&c).unwrap() + 1.0).abs() < 1e-12);
        // relMSE = 0.5 · (t / 0.01)^−1 reaches 0.05 at t = 0.1 (between points) and 1e-3 at t = 5.
        match time_to(&c, 0.05) {
            Reach::Measured(t) => assert!((t - 0.1).abs() < 1e-12, "{t}"),
            r => panic!("{r:?}"),
        }
        match time_to(&c, 1e-3) {
            Reach::Extrapolated(t) => assert!((t - 5.0).abs() < 1e-9, "{t}"),
            r => panic!("{r:?}"),
        }
        assert_eq!(time_to(&c, 0.9), Reach::AtOnce(0.01));
        assert!((efficiency(&c) - 1.0 / 0.005).abs() < 1e-9);
        assert_eq!(time_to(&curve(0.0), 0.1), Reach::Never);
        // 1e-6 would need t = 5000 s, beyond 100× the last point's 1.28 s.
        assert_eq!(time_to(&c, 1e-6), Reach::Beyond(128.0));
    }
}
