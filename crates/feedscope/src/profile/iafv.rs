//! The instantaneous average friction value (IAFV): the C¹ piecewise polynomial of the mean
//! friction over position, fitted jointly with the dominant fluctuation (Eq. 6; how it is kept
//! from absorbing the fluctuation is in the [module docs](super)), and the FFS it leaves.

use serde::{Deserialize, Serialize};

use super::piecewise::{
    solve, validate_layout, ContinuityDefect, Layout, PiecewisePoly, MAX_INTERVAL_ORDER,
};
use super::prepare::{prepare, Prepared};
use super::select::{order_cap, select, SelectParams};
use super::ProfileError;
use crate::order::{find_peaks, PeakParams, SpectrumAnalyzer, Window};
use crate::stroke::{Direction, StrokeView};

/// Options of the IAFV fit. Defaults are documented per field; `breaks_mm` / `orders` override
/// the automatic choice.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ProfileParams {
    /// Interior breakpoints (mm, machine coordinates, strictly increasing, strictly inside the
    /// stroke). `None` (default): chosen automatically by BIC.
    pub breaks_mm: Option<Vec<f64>>,
    /// Order per interval (`breaks_mm.len() + 1` values; a single value without `breaks_mm`
    /// fits one polynomial, like the paper's Table 2 choice). `None` (default): by BIC, capped
    /// by `leads_per_order`.
    pub orders: Option<Vec<usize>>,
    /// Highest order of the automatic choice (default 8).
    pub max_order: usize,
    /// Shortest automatic interval in leads (default 4).
    pub min_interval_leads: f64,
    /// Leads of interval length per order of the automatic choice (default 2).
    pub leads_per_order: f64,
    /// Number of equal candidate cells whose edges may become breakpoints (default 32).
    pub candidate_cells: usize,
    /// Fit the dominant fluctuation jointly as sinusoids (default true).
    pub joint_sinusoids: bool,
    /// Lowest order treated as fluctuation in the joint fit (default 0.3 cycles per lead).
    pub fluctuation_min_order: f64,
    /// Most sinusoids in the joint fit (default 16, strongest first).
    pub max_sinusoids: usize,
}

impl Default for ProfileParams {
    fn default() -> Self {
        Self {
            breaks_mm: None,
            orders: None,
            max_order: 8,
            min_interval_leads: 4.0,
            leads_per_order: 2.0,
            candidate_cells: 32,
            joint_sinusoids: true,
            fluctuation_min_order: 0.3,
            max_sinusoids: 16,
        }
    }
}

impl ProfileParams {
    fn validate(&self) -> Result<(), ProfileError> {
        let bad = |name, value: f64, reason| {
            Err(ProfileError::InvalidParameter {
                name,
                value,
                reason,
            })
        };
        if self.max_order > MAX_INTERVAL_ORDER {
            return bad("max_order", self.max_order as f64, "must be <= 20");
        }
        if !(self.min_interval_leads.is_finite() && self.min_interval_leads > 0.0) {
            return bad("min_interval_leads", self.min_interval_leads, "must be > 0");
        }
        if !(self.leads_per_order.is_finite() && self.leads_per_order > 0.0) {
            return bad("leads_per_order", self.leads_per_order, "must be > 0");
        }
        if self.candidate_cells == 0 || self.candidate_cells > 10_000 {
            return bad(
                "candidate_cells",
                self.candidate_cells as f64,
                "must be in 1..=10000",
            );
        }
        if !(self.fluctuation_min_order.is_finite() && self.fluctuation_min_order > 0.0) {
            return bad(
                "fluctuation_min_order",
                self.fluctuation_min_order,
                "must be > 0",
            );
        }
        Ok(())
    }
}

/// Straight-line least-squares fit over the stroke: the paper's linear IAFV trend (Fig. 7,
/// dashed), attributed to the torsional stiffness of the screw segment between motor and nut.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinearTrend {
    /// Slope (N per mm of position).
    pub slope_n_per_mm: f64,
    /// Stroke start (mm).
    pub start_mm: f64,
    /// Stroke end (mm).
    pub end_mm: f64,
    /// Trend value at the start (N).
    pub value_at_start_n: f64,
    /// Trend value at the end (N).
    pub value_at_end_n: f64,
    /// Residual standard deviation about the line (N).
    pub residual_std_n: f64,
}

fn linear_trend(p: &Prepared) -> (LinearTrend, f64, f64) {
    let n = p.y.len() as f64;
    let um = p.u.iter().sum::<f64>() / n;
    let ym = p.y.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (u, y) in p.u.iter().zip(&p.y) {
        sxy += (u - um) * (y - ym);
        sxx += (u - um) * (u - um);
    }
    let b = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    let a = ym - b * um;
    let rss: f64 =
        p.u.iter()
            .zip(&p.y)
            .map(|(u, y)| (y - a - b * u).powi(2))
            .sum();
    let uend = p.u[p.u.len() - 1];
    (
        LinearTrend {
            slope_n_per_mm: b / p.lead_mm,
            start_mm: p.x0_mm,
            end_mm: p.x1_mm,
            value_at_start_n: a,
            value_at_end_n: a + b * uend,
            residual_std_n: (rss / (n - 2.0).max(1.0)).sqrt(),
        },
        a,
        b,
    )
}

/// How the IAFV layout was chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LayoutSelection {
    /// `true` when breakpoints (and orders) were chosen automatically.
    pub automatic: bool,
    /// The rule in words.
    pub rule: String,
    /// BIC of the chosen partition (automatic breakpoints only).
    pub bic: Option<f64>,
    /// Per-sample noise σ (N) used by the BIC (automatic choices only).
    pub noise_sigma_n: Option<f64>,
    /// Candidate intervals evaluated.
    pub intervals_evaluated: usize,
}

/// A fluctuation component fitted jointly with the IAFV (kept in the FFS).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NuisanceSinusoid {
    /// Order (cycles per lead).
    pub order: f64,
    /// Amplitude (N) from the joint fit.
    pub amplitude_n: f64,
}

/// The fitted IAFV of one stroke.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IafvFit {
    /// Direction of the stroke.
    pub direction: Direction,
    /// The IAFV: C¹ piecewise polynomial (Eq. 6 per interval).
    pub poly: PiecewisePoly,
    /// Straight-line trend over the stroke.
    pub linear: LinearTrend,
    /// How breakpoints and orders were chosen.
    pub selection: LayoutSelection,
    /// Sinusoids fitted jointly (empty if disabled or none significant).
    pub nuisance_sinusoids: Vec<NuisanceSinusoid>,
    /// Residual standard deviation (N) of friction − IAFV − sinusoids, estimated on the block
    /// means scaled to one sample.
    pub residual_std_n: f64,
    /// Samples per block of the final fit.
    pub block_size: usize,
    /// Conditioning indicator of the final least-squares problem.
    pub condition_estimate: f64,
    /// Relative continuity defects at the breakpoints (should be at rounding level).
    pub continuity: Vec<ContinuityDefect>,
}

impl IafvFit {
    /// IAFV (N) at each of `position_m`.
    pub fn evaluate(&self, position_m: &[f64]) -> Vec<f64> {
        position_m.iter().map(|&x| self.poly.value_n(x)).collect()
    }
}

/// Fit the IAFV of one stroke (see the module docs for the method).
///
/// # Reference
/// Paper 000, Eq. 6, Table 2, Figs 6-7 (section 4.1.1).
///
/// # Errors
/// [`ProfileError::LengthMismatch`], [`ProfileError::TooFewPoints`] (< 16),
/// [`ProfileError::NonFinite`], [`ProfileError::NotMonotonic`],
/// [`ProfileError::NonUniformGrid`], [`ProfileError::InvalidParameter`] on bad input;
/// breakpoint/order errors for bad overrides; [`ProfileError::RankDeficient`] if the data
/// cannot determine the layout's coefficients.
pub fn fit_iafv(
    stroke: &StrokeView<'_>,
    params: &ProfileParams,
    analyzer: &mut SpectrumAnalyzer,
) -> Result<IafvFit, ProfileError> {
    params.validate()?;
    let p = prepare(stroke)?;
    let n = p.y.len();
    let (linear, a, b) = linear_trend(&p);
    let u_end = p.u[n - 1];

    // Fine blocks for the final fit (≈ 2048 block means).
    let fine_block = n.div_ceil(2048).max(1);
    // Dominant fluctuation: peaks of the detrended friction's spectrum.
    let mut nuisance: Vec<(f64, f64, f64)> = Vec::new();
    if params.joint_sinusoids && params.max_sinusoids > 0 {
        let r0: Vec<f64> = p.u.iter().zip(&p.y).map(|(u, y)| y - a - b * u).collect();
        let mut amp = Vec::new();
        analyzer.amplitude_spectrum(&r0, Window::Hann, &mut amp)?;
        let pk = PeakParams {
            min_order: params.fluctuation_min_order,
            ..PeakParams::default()
        };
        // Orders whose block means are attenuated by more than ~10 % carry no leakage risk.
        let max_order = 0.25 / (fine_block as f64 * p.du);
        let mut peaks: Vec<_> = find_peaks(analyzer, Window::Hann, &r0, &amp, p.du, &pk)
            .into_iter()
            .filter(|q| q.order <= stroke.max_trusted_order && q.order <= max_order)
            .collect();
        peaks.sort_by(|x, y| y.amplitude_n.total_cmp(&x.amplitude_n));
        peaks.truncate(params.max_sinusoids);
        nuisance = peaks.iter().map(|q| (q.order, q.cos_n, q.sin_n)).collect();
    }
    let sp = SelectParams {
        cells: params.candidate_cells,
        min_interval_leads: params.min_interval_leads,
        leads_per_order: params.leads_per_order,
        max_order: params.max_order,
    };
    // Selection data: ≈ 256 block means with the estimated sinusoids removed.
    let selection_data = || {
        let block = n.div_ceil(256).max(1);
        let nb = n.div_ceil(block);
        let mut uc = Vec::with_capacity(nb);
        let mut r = Vec::with_capacity(nb);
        let mut w = Vec::with_capacity(nb);
        for bi in 0..nb {
            let (lo, hi) = (bi * block, ((bi + 1) * block).min(n));
            let cnt = (hi - lo) as f64;
            let centre = 0.5 * (p.u[lo] + p.u[hi - 1]);
            let mut mean = p.y[lo..hi].iter().sum::<f64>() / cnt;
            for &(f, c, s) in &nuisance {
                let half = std::f64::consts::PI * f * p.du;
                let dir = if cnt > 1.0 && half.sin().abs() > 1e-12 {
                    (cnt * half).sin() / (cnt * half.sin())
                } else {
                    1.0
                };
                let (sn, cs) = (2.0 * std::f64::consts::PI * f * centre).sin_cos();
                mean -= dir * (c * cs + s * sn);
            }
            uc.push(centre);
            r.push(mean);
            w.push(cnt);
        }
        (uc, r, w)
    };
    let (breaks, orders, selection) = match (&params.breaks_mm, &params.orders) {
        (None, None) => {
            let (uc, r, w) = selection_data();
            let s = select(&uc, &r, &w, 0.0, u_end, n, &sp);
            let mut breaks = vec![0.0];
            breaks.extend_from_slice(&s.interior_breaks);
            breaks.push(u_end);
            let sel = LayoutSelection {
                automatic: true,
                rule: format!(
                    "exact DP minimising BIC = sum(RSS_k/sigma^2 + (m_k+1) ln n) + (K-1) ln n over \
                     breakpoints on {} equal cells, intervals >= {} leads, order <= min({}, \
                     floor(len_leads / {}))",
                    sp.cells, sp.min_interval_leads, sp.max_order, sp.leads_per_order
                ),
                bic: Some(s.bic),
                noise_sigma_n: Some(s.sigma),
                intervals_evaluated: s.intervals_evaluated,
            };
            (breaks, s.orders, sel)
        }
        (bk, ord) => {
            let interior: Vec<f64> = bk
                .as_deref()
                .unwrap_or(&[])
                .iter()
                .map(|&m| p.to_u(m))
                .collect();
            let user_orders = ord.clone();
            let provisional: Vec<usize> = user_orders
                .clone()
                .unwrap_or_else(|| vec![0; interior.len() + 1]);
            let breaks = validate_layout(&p.u, &interior, &provisional, |u| p.to_mm(u))?;
            match user_orders {
                Some(o) => (
                    breaks,
                    o,
                    LayoutSelection {
                        automatic: false,
                        rule: "user breakpoints and orders".into(),
                        bic: None,
                        noise_sigma_n: None,
                        intervals_evaluated: 0,
                    },
                ),
                None => {
                    // Orders by the same BIC, interval by interval.
                    let (uc, r, w) = selection_data();
                    let mut orders = Vec::new();
                    let mut sigma = 0.0;
                    for win in breaks.windows(2) {
                        let lo = uc.partition_point(|&v| v < win[0]);
                        let hi = uc.partition_point(|&v| v < win[1]).max(lo);
                        let s = select(
                            &uc[lo..hi],
                            &r[lo..hi],
                            &w[lo..hi],
                            win[0],
                            win[1],
                            n,
                            &SelectParams {
                                cells: 1,
                                ..sp.clone()
                            },
                        );
                        sigma = s.sigma;
                        orders.push(
                            s.orders
                                .first()
                                .copied()
                                .unwrap_or(0)
                                .min(order_cap(win[1] - win[0], &sp)),
                        );
                    }
                    (
                        breaks,
                        orders,
                        LayoutSelection {
                            automatic: true,
                            rule: "user breakpoints; order per interval by BIC (RSS/sigma^2 + (m+1) ln n)".into(),
                            bic: None,
                            noise_sigma_n: Some(sigma),
                            intervals_evaluated: 0,
                        },
                    )
                }
            }
        }
    };
    // Every interval needs enough block means for its order.
    let mut block = fine_block;
    for (k, m) in orders.iter().enumerate() {
        let pts = (((breaks[k + 1] - breaks[k]) / p.du).floor() as usize).max(1);
        block = block.min((pts / (2 * (m + 1) + 2)).max(1));
    }
    let layout = Layout::new(breaks, orders);
    let sin_orders: Vec<f64> = nuisance.iter().map(|q| q.0).collect();
    let sol = match solve(&layout, &p.u, &p.y, block, &sin_orders) {
        Ok(s) => s,
        Err(ProfileError::RankDeficient { .. }) if !sin_orders.is_empty() => {
            solve(&layout, &p.u, &p.y, block, &[])?
        }
        Err(e) => return Err(e),
    };
    let poly = layout.to_poly(&sol.coef, |u| p.to_mm(u));
    let nb = n.div_ceil(block);
    let dof = nb.saturating_sub(sol.free_parameters).max(1);
    let nuisance_sinusoids = sin_orders
        .iter()
        .zip(&sol.sinusoids)
        .map(|(&order, (c, s))| NuisanceSinusoid {
            order,
            amplitude_n: c.hypot(*s),
        })
        .collect();
    Ok(IafvFit {
        direction: stroke.direction,
        continuity: poly.continuity_defects(),
        poly,
        linear,
        selection,
        nuisance_sinusoids,
        residual_std_n: (sol.rss / dof as f64).sqrt(),
        block_size: block,
        condition_estimate: sol.condition_estimate,
    })
}

/// IAFV and FFS (friction − IAFV) at every sample of the stroke, aligned with its positions.
pub fn iafv_and_ffs(stroke: &StrokeView<'_>, fit: &IafvFit) -> (Vec<f64>, Vec<f64>) {
    let iafv = fit.evaluate(stroke.position_m);
    let ffs = stroke
        .friction_n
        .iter()
        .zip(&iafv)
        .map(|(f, m)| f - m)
        .collect();
    (iafv, ffs)
}
