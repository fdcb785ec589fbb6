//! Automatic choice of IAFV breakpoints and orders: exact dynamic-programming change-point
//! search minimising a BIC over a candidate grid.
//!
//! The travel [u_0, u_1] (u in leads) is cut into G equal cells; breakpoints may only sit on
//! cell edges and an interval must span at least `min_interval_leads`. An interval of length L
//! leads may use orders 0..=min(max_order, ⌊L / leads_per_order⌋) (at least 1). The score of a
//! partition is
//!
//! BIC = Σ_k [ RSS_k / σ² + (m_k + 1) ln n ] + (K − 1) ln n,
//!
//! with RSS_k the weighted residual sum of squares of the interval's own least-squares
//! polynomial (fitted without continuity; the continuity is imposed on the final fit), n the
//! number of raw samples (the block means carry the same likelihood as the raw samples up to a
//! constant) and σ² the per-sample noise variance estimated robustly from differences of
//! neighbouring block means. Each breakpoint costs ln n for its position. The additive form is
//! solved exactly by dynamic programming over the cell edges.

use super::lsq::forsythe_rss;

/// Options of the search (a view of [`super::ProfileParams`]).
#[derive(Clone)]
pub(crate) struct SelectParams {
    pub cells: usize,
    pub min_interval_leads: f64,
    pub leads_per_order: f64,
    pub max_order: usize,
}

/// Chosen layout.
#[derive(Debug, Clone)]
pub(crate) struct Selected {
    pub interior_breaks: Vec<f64>,
    pub orders: Vec<usize>,
    pub bic: f64,
    pub sigma: f64,
    pub intervals_evaluated: usize,
}

/// Highest order allowed on an interval of `len_leads`.
pub(crate) fn order_cap(len_leads: f64, p: &SelectParams) -> usize {
    ((len_leads / p.leads_per_order).floor().max(1.0) as usize).min(p.max_order)
}

/// Search on block means `r` at centres `u` with weights `w` (points per block), data range
/// [start, end] in leads, `n_total` raw samples.
pub(crate) fn select(
    u: &[f64],
    r: &[f64],
    w: &[f64],
    start: f64,
    end: f64,
    n_total: usize,
    p: &SelectParams,
) -> Selected {
    let nb = u.len();
    let ln_n = (n_total.max(2) as f64).ln();
    // Robust per-sample σ from neighbouring differences: (r_{b+1} − r_b)/sqrt(1/w_b + 1/w_{b+1})
    // is N(0, σ²) for white noise; the slow mean hardly contributes.
    let mut d: Vec<f64> = (1..nb)
        .map(|b| ((r[b] - r[b - 1]) / (1.0 / w[b] + 1.0 / w[b - 1]).sqrt()).abs())
        .collect();
    let sigma_raw = if d.is_empty() {
        0.0
    } else {
        let mid = d.len() / 2;
        *d.select_nth_unstable_by(mid, |a, b| a.total_cmp(b)).1 / 0.6745
    };
    let scale = (r.iter().map(|v| v * v).sum::<f64>() / nb.max(1) as f64).sqrt();
    let sigma = sigma_raw.max(1e-9 * scale).max(1e-150);
    let s2 = sigma * sigma;

    let len = end - start;
    let g = p.cells.max(1);
    let cell = len / g as f64;
    let cmin = if cell > 0.0 {
        ((p.min_interval_leads / cell) - 1e-9).ceil().max(1.0) as usize
    } else {
        g
    };
    let edge_block: Vec<usize> = (0..=g)
        .map(|i| {
            if i == g {
                nb
            } else {
                u.partition_point(|&v| v < start + i as f64 * cell)
            }
        })
        .collect();
    let seg_cost = |i: usize, j: usize| -> Option<(f64, usize)> {
        let (lo, hi) = (edge_block[i], edge_block[j]);
        if hi <= lo + 1 {
            return None;
        }
        let len_leads = (j - i) as f64 * cell;
        let cap = order_cap(len_leads, p).min(hi - lo - 2);
        let rss = forsythe_rss(&u[lo..hi], &r[lo..hi], Some(&w[lo..hi]), cap);
        rss.iter()
            .enumerate()
            .map(|(m, v)| (v / s2 + (m + 1) as f64 * ln_n, m))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    let mut best = vec![f64::INFINITY; g + 1];
    let mut from: Vec<(usize, usize)> = vec![(0, 0); g + 1];
    best[0] = 0.0;
    let mut evaluated = 0;
    for j in 1..=g {
        for i in 0..j {
            let whole = i == 0 && j == g;
            if (j - i < cmin && !whole) || !best[i].is_finite() {
                continue;
            }
            // An interval ending before the stroke end must leave room for another one.
            if j < g && g - j < cmin {
                continue;
            }
            evaluated += 1;
            if let Some((c, m)) = seg_cost(i, j) {
                let total = best[i] + c + if i > 0 { ln_n } else { 0.0 };
                if total < best[j] {
                    best[j] = total;
                    from[j] = (i, m);
                }
            }
        }
    }
    let mut edges = Vec::new();
    let mut orders = Vec::new();
    let mut j = g;
    if best[g].is_finite() {
        while j > 0 {
            let (i, m) = from[j];
            orders.push(m);
            if i > 0 {
                edges.push(start + i as f64 * cell);
            }
            j = i;
        }
    } else {
        orders.push(order_cap(len, p).min(nb.saturating_sub(2)));
    }
    edges.reverse();
    orders.reverse();
    Selected {
        interior_breaks: edges,
        orders,
        bic: best[g],
        sigma,
        intervals_evaluated: evaluated,
    }
}
