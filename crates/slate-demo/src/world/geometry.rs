//! Small 2D helpers: points, angles, Gaussian noise.

use slate_ici::Rng;

/// A point or vector in the plane, metres.
pub type P2 = [f64; 2];

/// `a + b`.
pub fn add(a: P2, b: P2) -> P2 {
    [a[0] + b[0], a[1] + b[1]]
}

/// `a - b`.
pub fn sub(a: P2, b: P2) -> P2 {
    [a[0] - b[0], a[1] - b[1]]
}

/// `k a`.
pub fn scale(a: P2, k: f64) -> P2 {
    [a[0] * k, a[1] * k]
}

/// Length of `a`.
pub fn norm(a: P2) -> f64 {
    a[0].hypot(a[1])
}

/// Distance between two points.
pub fn dist(a: P2, b: P2) -> f64 {
    norm(sub(a, b))
}

/// The unit vector at angle `theta`.
pub fn unit(theta: f64) -> P2 {
    [theta.cos(), theta.sin()]
}

/// The direction of `a` (radians, counter-clockwise from +x).
pub fn angle(a: P2) -> f64 {
    a[1].atan2(a[0])
}

/// An angle wrapped to `[-pi, pi)`.
pub fn wrap(theta: f64) -> f64 {
    let t = (theta + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU);
    t - std::f64::consts::PI
}

/// A standard normal draw (Box-Muller).
pub fn gauss(rng: &mut Rng) -> f64 {
    let u = rng.next_f64().max(1e-12);
    let v = rng.next_f64();
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

/// Uniform in `[lo, hi)`.
pub fn uniform(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.next_f64()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_keeps_angles_in_one_turn() {
        assert!((wrap(3.0 * std::f64::consts::PI) + std::f64::consts::PI).abs() < 1e-9);
        assert!((wrap(0.5) - 0.5).abs() < 1e-12);
        assert!((wrap(-7.0) - (-7.0 + std::f64::consts::TAU)).abs() < 1e-9);
    }

    #[test]
    fn gauss_has_unit_spread() {
        let mut rng = Rng::new(3);
        let n = 20_000;
        let xs: Vec<f64> = (0..n).map(|_| gauss(&mut rng)).collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64;
        assert!(
            mean.abs() < 0.03 && (var - 1.0).abs() < 0.05,
            "{mean} {var}"
        );
    }
}
