//! χ² distribution: CDF through the regularised lower incomplete gamma function, quantiles by bisection.

/// ln Γ(x) for x > 0 (Lanczos, g = 7, n = 9; relative error < 1e-13).
fn ln_gamma(x: f64) -> f64 {
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + 7.5;
    let sum = C.iter().enumerate().skip(1).fold(C[0], |acc, (i, c)| acc + c / (x + i as f64));
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

/// Regularised lower incomplete gamma P(a, x).
fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let front = (a * x.ln() - x - ln_gamma(a)).exp();
    if x < a + 1.0 {
        // Series expansion.
        let (mut term, mut sum, mut n) = (1.0 / a, 1.0 / a, a);
        while term.abs() > sum.abs() * 1e-16 {
            n += 1.0;
            term *= x / n;
            sum += term;
        }
        sum * front
    } else {
        // Continued fraction for Q (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            d = if d.abs() < tiny { tiny } else { d };
            c = b + an / c;
            c = if c.abs() < tiny { tiny } else { c };
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-16 {
                break;
            }
        }
        1.0 - front * h
    }
}

/// P(χ²_dof ≤ x).
pub fn chi2_cdf(x: f64, dof: f64) -> f64 {
    gamma_p(dof / 2.0, x / 2.0)
}

/// The critical value χ²_{dof, α}: P(χ²_dof ≥ value) = α.
pub fn chi2_critical(dof: f64, alpha: f64) -> f64 {
    let target = 1.0 - alpha;
    let (mut lo, mut hi) = (0.0, dof.max(1.0));
    while chi2_cdf(hi, dof) < target {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi2_cdf(mid, dof) < target {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-12 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn critical_values_match_tables() {
        // Standard χ² table values (Abramowitz & Stegun table 26.8; dof 150 to three decimals).
        let table = [(1.0, 0.05, 3.841_459), (1.0, 0.001, 10.827_566), (3.0, 0.05, 7.814_728), (3.0, 0.01, 11.344_867)];
        for (dof, alpha, want) in table {
            let got = chi2_critical(dof, alpha);
            assert!((got - want).abs() < 1e-5, "dof {dof} α {alpha}: {got} vs {want}");
        }
        let big = chi2_critical(150.0, 0.05);
        assert!((big - 179.581).abs() < 1e-3, "dof 150: {big}");
    }

    #[test]
    fn cdf_of_two_dof_is_exponential() {
        for x in [0.1, 1.0, 3.0, 10.0, 40.0] {
            let want = 1.0 - (-x / 2.0f64).exp();
            assert!((chi2_cdf(x, 2.0) - want).abs() < 1e-12, "x {x}");
        }
    }
}
