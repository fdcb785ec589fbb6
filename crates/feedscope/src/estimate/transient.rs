//! Feed changes inside a stroke that the position smoothing does not resolve.
//!
//! With a position cut-off f_c the table acceleration z'' is seen through the smoother
//! H(f) = 1/(1 + (f/f_c)⁴): a change of the feed by Δv that takes less than about 1/f_c (an
//! override turned, a feed changed between blocks without a stop) appears as an acceleration
//! pulse of height about Δv · f_c · π/√2 (the integral of H over all frequencies) however
//! short the real change was, while the effort shows the real, taller and shorter pulse. Eq. 5
//! then removes the inertia m_eq·z'' in the wrong shape, and the friction within about 1/f_c of
//! the change is off by a large part of m_eq·Δv·f_c. A change slower than that is resolved and
//! its pulse is lower than Δv·f_c, which is how the two are told apart.
//!
//! The scan runs over the output grid as it is produced (a long stroke is emitted in pieces):
//! a region is a run of points whose inertia m_eq·|z''| exceeds 3 × the predicted noise floor;
//! it is a feed change when the speed differs across it by at least 5 % of the feed (noise
//! never moves the smoothed speed that much), and an unresolved one when its acceleration peak
//! is at least a tenth of what a step of that size shows through the smoother
//! ([`RESOLVED_SHARE`]): a change over more than about 4.5/f_c, such as a modulated feed, is
//! resolved.

/// The acceleration peak of a velocity step Δv seen through H, per (Δv · f_c): ∫H df = π/√2.
const STEP_PEAK_PER_DV_FC: f64 = std::f64::consts::PI / std::f64::consts::SQRT_2;

/// A change whose acceleration peak stays below this share of a step's through the smoother
/// took longer than about 1/(0.1 · π/√2 · f_c) ≈ 4.5/f_c, and only then is the smoothed
/// acceleration close to the real one over the whole change. A constant acceleration's
/// corners are what the smoother rounds: on the twin a bell-shaped override change behind a
/// servo without feed-forward (≈ 30 ms) peaks at 0.34 of a step's height at f_c = 33 Hz and
/// leaves 4.4 N RMS of error over the 4 mm around it against a floor of 0.3 N.
const RESOLVED_SHARE: f64 = 0.1;

/// A feed change this small a share of the feed is not reported (servo wobble, noise).
const MIN_CHANGE_FRACTION: f64 = 0.05;

/// A feed change inside a stroke faster than the position cut-off resolves.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FeedChange {
    /// Position at the acceleration peak (m).
    pub position_m: f64,
    /// Speed after minus speed before, in the direction of travel (m/s).
    pub delta_v_m_s: f64,
    /// The largest inertia m_eq·|z''| in the region (N).
    pub peak_inertia_n: f64,
}

/// Scans grid points in order for [`FeedChange`]s.
#[derive(Debug)]
pub(crate) struct TransientScan {
    m_eq: f64,
    threshold_n: f64,
    cutoff_hz: f64,
    feed_m_s: f64,
    open: Option<Region>,
    /// The changes found, in order of travel.
    pub found: Vec<FeedChange>,
}

#[derive(Debug, Clone, Copy)]
struct Region {
    v_start: f64,
    v_last: f64,
    peak_a: f64,
    peak_z: f64,
}

impl TransientScan {
    /// A scan for a stroke of equivalent mass `m_eq` (kg), noise floor `floor_n` (N RMS),
    /// position cut-off `cutoff_hz` (Hz) and feed `feed_m_s` (m/s).
    pub fn new(m_eq: f64, floor_n: f64, cutoff_hz: f64, feed_m_s: f64) -> Self {
        Self {
            m_eq,
            threshold_n: 3.0 * floor_n,
            cutoff_hz,
            feed_m_s,
            open: None,
            found: Vec::new(),
        }
    }

    /// Take the next points: positions (m), speeds along the direction of travel (m/s) and
    /// accelerations (m/s²), in grid order.
    pub fn push(&mut self, z: &[f64], v: &[f64], a: &[f64]) {
        for ((&z, &v), &a) in z.iter().zip(v).zip(a) {
            let above = self.m_eq * a.abs() > self.threshold_n;
            match (&mut self.open, above) {
                (Some(r), true) => {
                    r.v_last = v;
                    if a.abs() > r.peak_a {
                        r.peak_a = a.abs();
                        r.peak_z = z;
                    }
                }
                (Some(_), false) => {
                    let r = self.open.take().unwrap();
                    self.close(Region { v_last: v, ..r });
                }
                (None, true) => {
                    self.open = Some(Region {
                        v_start: v,
                        v_last: v,
                        peak_a: a.abs(),
                        peak_z: z,
                    });
                }
                (None, false) => {}
            }
        }
    }

    /// End of the stroke: a region still open is left out (it runs into the stroke's end,
    /// where the settling window already accounts for the ramp).
    pub fn finish(mut self) -> Vec<FeedChange> {
        self.open = None;
        self.found
    }

    fn close(&mut self, r: Region) {
        let dv = r.v_last - r.v_start;
        if dv.abs() < MIN_CHANGE_FRACTION * self.feed_m_s {
            return;
        }
        if r.peak_a >= RESOLVED_SHARE * STEP_PEAK_PER_DV_FC * dv.abs() * self.cutoff_hz {
            self.found.push(FeedChange {
                position_m: r.peak_z,
                delta_v_m_s: dv,
                peak_inertia_n: self.m_eq * r.peak_a,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A velocity step smoothed by H: the analytic acceleration pulse of a step through a
    /// fourth-order low-pass is approximated by a Gaussian of the same area and peak.
    fn pulse(dv: f64, fc: f64, t: f64, t0: f64, width_scale: f64) -> (f64, f64) {
        let peak = STEP_PEAK_PER_DV_FC * dv * fc / width_scale;
        let sigma = 1.0 / (peak / dv * (2.0 * std::f64::consts::PI).sqrt());
        let x = (t - t0) / sigma;
        let a = peak * (-0.5 * x * x).exp();
        let v = 0.01 + dv * 0.5 * (1.0 + libm_erf(x / std::f64::consts::SQRT_2));
        (v, a)
    }

    fn libm_erf(x: f64) -> f64 {
        // Abramowitz-Stegun 7.1.26, enough for a test signal.
        let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
        let y = 1.0
            - (((((1.061_405_429 * t - 1.453_152_027) * t) + 1.421_413_741) * t - 0.284_496_736)
                * t
                + 0.254_829_592)
                * t
                * (-x * x).exp();
        y.copysign(x)
    }

    fn scan(width_scale: f64, dv: f64) -> Vec<FeedChange> {
        let (fc, v0) = (15.0, 0.01);
        let mut s = TransientScan::new(745.0, 0.3, fc, v0);
        let (mut z, mut vv, mut aa) = (Vec::new(), Vec::new(), Vec::new());
        let mut pos = 0.0;
        for k in 0..20_000 {
            let t = k as f64 * 1e-4;
            let (v, a) = pulse(dv, fc, t, 1.0, width_scale);
            pos += v * 1e-4;
            z.push(pos);
            vv.push(v);
            aa.push(a);
        }
        s.push(&z, &vv, &aa);
        s.finish()
    }

    #[test]
    fn a_step_is_found_a_slow_change_and_a_small_one_are_not() {
        let step = scan(1.0, -0.0055);
        assert_eq!(step.len(), 1, "{step:?}");
        assert!((step[0].delta_v_m_s + 0.0055).abs() < 0.0006, "{step:?}");
        // three times slower than the smoother still is not resolved, thirty times is
        assert_eq!(scan(3.0, -0.0055).len(), 1);
        assert!(scan(30.0, -0.0055).is_empty());
        // 3 % of the feed: below what is reported
        assert!(scan(1.0, 0.0003).is_empty());
    }
}
