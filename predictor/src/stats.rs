//! Small statistics used by the stage tests (seed 002, "Progression of obstacle
//! characterization"): the chi-square survival function, Pearson's goodness-of-fit test
//! against a uniform distribution, Pearson's test of independence on a contingency table,
//! and the weighted Jensen-Shannon divergence between conditional and marginal
//! distributions.
//!
//! # Example
//! ```
//! use predictor::stats::chi_square_sf;
//! // The 95th percentile of chi-square with 1 degree of freedom is 3.841.
//! assert!((chi_square_sf(3.841, 1) - 0.05).abs() < 1e-3);
//! ```

/// Result of a chi-square test.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChiSquare {
    /// Pearson's statistic.
    pub statistic: f64,
    /// Degrees of freedom.
    pub df: usize,
    /// Upper-tail probability of `statistic` under the null hypothesis.
    pub p_value: f64,
    /// Number of samples the test used.
    pub n: usize,
}

/// Natural log of the gamma function (Lanczos, g = 7, n = 9; ~1e-15 relative).
pub fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
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
        // Reflection: Gamma(x) Gamma(1 - x) = pi / sin(pi x).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularized upper incomplete gamma function Q(a, x) (series for x < a + 1, continued
/// fraction otherwise).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    let gln = ln_gamma(a);
    if x < a + 1.0 {
        let mut ap = a;
        let mut sum = 1.0 / a;
        let mut del = sum;
        for _ in 0..1000 {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        let p = sum * (-x + a * x.ln() - gln).exp();
        (1.0 - p).clamp(0.0, 1.0)
    } else {
        // Lentz's continued fraction.
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..1000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-15 {
                break;
            }
        }
        ((-x + a * x.ln() - gln).exp() * h).clamp(0.0, 1.0)
    }
}

/// Upper-tail probability P(X >= x) of a chi-square variable with `df` degrees of freedom.
pub fn chi_square_sf(x: f64, df: usize) -> f64 {
    if df == 0 {
        return 1.0;
    }
    gamma_q(df as f64 / 2.0, x / 2.0)
}

/// Pearson's goodness-of-fit test of `counts` against equal probabilities per bin.
/// `None` when there are no samples or fewer than two bins.
pub fn chi_square_uniform(counts: &[usize]) -> Option<ChiSquare> {
    let k = counts.len();
    let n: usize = counts.iter().sum();
    if n == 0 || k < 2 {
        return None;
    }
    let e = n as f64 / k as f64;
    let statistic = counts.iter().map(|&c| (c as f64 - e).powi(2) / e).sum();
    Some(ChiSquare {
        statistic,
        df: k - 1,
        p_value: chi_square_sf(statistic, k - 1),
        n,
    })
}

/// Pearson's test of independence of rows and columns of a contingency table
/// (`table[row][col]` counts). Empty rows and columns are dropped; `None` when fewer than
/// two non-empty rows or columns remain (independence cannot be tested).
pub fn chi_square_independence(table: &[Vec<usize>]) -> Option<ChiSquare> {
    let cols = table.first().map_or(0, Vec::len);
    let row_sums: Vec<usize> = table.iter().map(|r| r.iter().sum()).collect();
    let col_sums: Vec<usize> = (0..cols)
        .map(|j| table.iter().map(|r| r[j]).sum())
        .collect();
    let n: usize = row_sums.iter().sum();
    let rows_used = row_sums.iter().filter(|&&s| s > 0).count();
    let cols_used = col_sums.iter().filter(|&&s| s > 0).count();
    if rows_used < 2 || cols_used < 2 {
        return None;
    }
    let mut statistic = 0.0;
    for (i, row) in table.iter().enumerate() {
        if row_sums[i] == 0 {
            continue;
        }
        for j in 0..cols {
            if col_sums[j] == 0 {
                continue;
            }
            let e = row_sums[i] as f64 * col_sums[j] as f64 / n as f64;
            statistic += (row[j] as f64 - e).powi(2) / e;
        }
    }
    let df = (rows_used - 1) * (cols_used - 1);
    Some(ChiSquare {
        statistic,
        df,
        p_value: chi_square_sf(statistic, df),
        n,
    })
}

/// Additively smoothed distribution: `(count + alpha) / (n + alpha * k)`.
pub fn smoothed(counts: &[usize], alpha: f64) -> Vec<f64> {
    let n: usize = counts.iter().sum();
    let denom = n as f64 + alpha * counts.len() as f64;
    if denom <= 0.0 {
        return vec![1.0 / counts.len().max(1) as f64; counts.len()];
    }
    counts.iter().map(|&c| (c as f64 + alpha) / denom).collect()
}

/// Jensen-Shannon divergence between two distributions, in nats (0 ..= ln 2).
pub fn js_divergence(p: &[f64], q: &[f64]) -> f64 {
    let mut d = 0.0;
    for (&a, &b) in p.iter().zip(q) {
        let m = 0.5 * (a + b);
        if a > 0.0 {
            d += 0.5 * a * (a / m).ln();
        }
        if b > 0.0 {
            d += 0.5 * b * (b / m).ln();
        }
    }
    d.max(0.0)
}

/// Weighted Jensen-Shannon divergence between each row's smoothed conditional distribution
/// and the smoothed marginal distribution of the columns, each row weighted by its share of
/// the samples. 0 when the rows are identical to the marginal (memoryless behaviour).
pub fn weighted_js_divergence(table: &[Vec<usize>], alpha: f64) -> f64 {
    let cols = table.first().map_or(0, Vec::len);
    let col_sums: Vec<usize> = (0..cols)
        .map(|j| table.iter().map(|r| r[j]).sum())
        .collect();
    let n: usize = col_sums.iter().sum();
    if n == 0 {
        return 0.0;
    }
    let marginal = smoothed(&col_sums, alpha);
    table
        .iter()
        .map(|row| {
            let n_row: usize = row.iter().sum();
            if n_row == 0 {
                0.0
            } else {
                n_row as f64 / n as f64 * js_divergence(&smoothed(row, alpha), &marginal)
            }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chi_square_sf_matches_table_values() {
        // Textbook 95th percentiles: df 1 -> 3.841, df 8 -> 15.507, df 16 -> 26.296;
        // 99.9th percentile of df 8 -> 26.124.
        assert!((chi_square_sf(3.841, 1) - 0.05).abs() < 2e-4);
        assert!((chi_square_sf(15.507, 8) - 0.05).abs() < 2e-4);
        assert!((chi_square_sf(26.296, 16) - 0.05).abs() < 2e-4);
        assert!((chi_square_sf(26.124, 8) - 0.001).abs() < 2e-5);
        // df 2 has a closed form: exp(-x/2).
        assert!((chi_square_sf(3.0, 2) - (-1.5f64).exp()).abs() < 1e-12);
    }

    #[test]
    fn uniform_counts_are_not_rejected_and_peaked_ones_are() {
        // Expected 10 per bin; statistic = (1 + 1 + 0) / 10 = 0.2.
        let t = chi_square_uniform(&[9, 11, 10]).unwrap();
        assert!((t.statistic - 0.2).abs() < 1e-12);
        assert!(t.p_value > 0.9);
        let t = chi_square_uniform(&[0, 0, 45, 0, 0]).unwrap();
        // E = 9: 4 * 9 + 36^2 / 9 = 36 + 144 = 180.
        assert!((t.statistic - 180.0).abs() < 1e-9);
        assert!(t.p_value < 1e-30);
    }

    #[test]
    fn independence_detects_alternation_and_accepts_a_product_table() {
        // Perfect alternation: row 0 always goes to col 1 and vice versa.
        let t = chi_square_independence(&[vec![0, 50], vec![50, 0]]).unwrap();
        // Every expected count is 25, every cell deviates by 25: 4 * 625 / 25 = 100.
        assert!((t.statistic - 100.0).abs() < 1e-9);
        assert_eq!(t.df, 1);
        let t = chi_square_independence(&[vec![10, 20], vec![20, 40]]).unwrap();
        assert!(t.statistic.abs() < 1e-12);
        assert!(chi_square_independence(&[vec![5, 0], vec![0, 0]]).is_none());
    }

    #[test]
    fn js_divergence_is_zero_for_equal_rows_and_ln2_for_disjoint() {
        assert!(weighted_js_divergence(&[vec![10, 20], vec![10, 20]], 0.0) < 1e-12);
        let d = js_divergence(&[1.0, 0.0], &[0.0, 1.0]);
        assert!((d - std::f64::consts::LN_2).abs() < 1e-12);
    }
}
