//! The order scan (paper 000 Table 2): residual of least-squares polynomials of increasing
//! order over a whole stroke, alone or as a table over several strokes.

use serde::{Deserialize, Serialize};

use super::piecewise::MAX_INTERVAL_ORDER;
use super::prepare::prepare;
use super::ProfileError;
use crate::stroke::{Direction, StrokeView};

/// Residual standard deviation of one global polynomial order (a row of the paper's Table 2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderScanRow {
    /// Polynomial order m of Eq. 6.
    pub order: usize,
    /// sqrt(RSS / (n − m − 1)) (N).
    pub residual_std_n: f64,
}

/// Residual standard deviation of single-polynomial fits of increasing order (Table 2).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderScan {
    /// Direction of the stroke.
    pub direction: Direction,
    /// One row per order 1..=max.
    pub rows: Vec<OrderScanRow>,
    /// Order with the lowest residual standard deviation (the paper's criterion).
    pub best_order: usize,
}

/// Residual standard deviation of least-squares polynomials of orders 1..=`max_order` over the
/// whole stroke (Eq. 6, Table 2), by orthogonal polynomials on the samples (Forsythe).
///
/// # Errors
/// The input errors of [`fit_iafv`](super::fit_iafv); [`ProfileError::InvalidParameter`] for `max_order` 0 or
/// above 20.
pub fn order_scan(stroke: &StrokeView<'_>, max_order: usize) -> Result<OrderScan, ProfileError> {
    if max_order == 0 || max_order > MAX_INTERVAL_ORDER {
        return Err(ProfileError::InvalidParameter {
            name: "max_order",
            value: max_order as f64,
            reason: "must be in 1..=20",
        });
    }
    let p = prepare(stroke)?;
    let n = p.y.len();
    let top = max_order.min(n - 2);
    let rss = super::lsq::forsythe_rss(&p.u, &p.y, None, top);
    let rows: Vec<OrderScanRow> = (1..=top)
        .map(|m| OrderScanRow {
            order: m,
            residual_std_n: (rss[m] / (n - m - 1) as f64).sqrt(),
        })
        .collect();
    let best_order = rows
        .iter()
        .min_by(|a, b| a.residual_std_n.total_cmp(&b.residual_std_n))
        .map_or(1, |r| r.order);
    Ok(OrderScan {
        direction: stroke.direction,
        rows,
        best_order,
    })
}

/// One row of [`OrderScanTable`]: mean residual standard deviation per direction.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OrderScanTableRow {
    /// Polynomial order m of Eq. 6.
    pub order: usize,
    /// Mean over the forward strokes (N), `None` without forward strokes.
    pub forward_std_n: Option<f64>,
    /// Mean over the backward strokes (N), `None` without backward strokes.
    pub backward_std_n: Option<f64>,
}

/// The paper's Table 2: average residual standard deviation of single polynomials of orders
/// 1..=max per feed direction.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OrderScanTable {
    /// One row per order.
    pub rows: Vec<OrderScanTableRow>,
    /// Forward strokes averaged.
    pub forward_strokes: usize,
    /// Backward strokes averaged.
    pub backward_strokes: usize,
    /// Order of the lowest forward mean, if any.
    pub best_order_forward: Option<usize>,
    /// Order of the lowest backward mean, if any.
    pub best_order_backward: Option<usize>,
}

/// Table 2 over several strokes: [`order_scan`] of each, averaged per direction.
///
/// # Errors
/// The first error of [`order_scan`] on any stroke.
pub fn order_scan_table(
    strokes: &[StrokeView<'_>],
    max_order: usize,
) -> Result<OrderScanTable, ProfileError> {
    let scans = strokes
        .iter()
        .map(|s| order_scan(s, max_order))
        .collect::<Result<Vec<_>, _>>()?;
    let mean = |dir: Direction, order: usize| -> Option<f64> {
        let v: Vec<f64> = scans
            .iter()
            .filter(|s| s.direction == dir)
            .filter_map(|s| s.rows.iter().find(|r| r.order == order))
            .map(|r| r.residual_std_n)
            .collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let rows: Vec<OrderScanTableRow> = (1..=max_order)
        .map(|m| OrderScanTableRow {
            order: m,
            forward_std_n: mean(Direction::Forward, m),
            backward_std_n: mean(Direction::Backward, m),
        })
        .filter(|r| r.forward_std_n.is_some() || r.backward_std_n.is_some())
        .collect();
    let best = |f: fn(&OrderScanTableRow) -> Option<f64>| {
        rows.iter()
            .filter_map(|r| f(r).map(|v| (v, r.order)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, o)| o)
    };
    Ok(OrderScanTable {
        best_order_forward: best(|r| r.forward_std_n),
        best_order_backward: best(|r| r.backward_std_n),
        forward_strokes: scans
            .iter()
            .filter(|s| s.direction == Direction::Forward)
            .count(),
        backward_strokes: scans
            .iter()
            .filter(|s| s.direction == Direction::Backward)
            .count(),
        rows,
    })
}
