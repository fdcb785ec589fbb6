//! Friction-compensation tables of `feedscope map`: the friction map F(z, v) tabulated at
//! chosen positions and feeds, for a controller's compensation table.
//!
//! Two shapes, each preceded by the same `#` comment lines (what the table is, its units, its
//! sign convention and where it is valid, [`CompensationTable::header`]):
//! - **long** ([`CompensationTable::write_long`]): `direction,position_mm,feed_mm_min,friction_n`,
//!   one row per (direction, feed, position), feeds outermost;
//! - **matrix** ([`CompensationTable::write_matrix`], one file per direction): a header row
//!   `position_mm,<feed>,<feed>,…`, then one row per position with the friction at each feed.
//!
//! Positions and feeds are written with 6 decimals (mm, mm/min), friction in N with 6
//! decimals, signed as paper 000 Eq. 5 (positive moving forward).

use std::fmt::Write as _;
use std::io::Write;

use feedscope::estimate::Direction;
use feedscope::map::{DirectionMap, FrictionMap, MapError};
use feedscope::profile::PiecewisePoly;

/// One direction of a compensation table: the map's section at each feed, tabulated at the
/// positions.
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionTable {
    /// Direction of travel.
    pub direction: Direction,
    /// Start of the mapped span (mm).
    pub start_mm: f64,
    /// End of the mapped span (mm).
    pub end_mm: f64,
    /// Slowest measured feed (mm/min).
    pub measured_feed_min_mm_min: f64,
    /// Fastest measured feed (mm/min).
    pub measured_feed_max_mm_min: f64,
    /// Feeds of the table (mm/min), in the order written.
    pub feeds_mm_min: Vec<f64>,
    /// Positions of the table (mm), in the order written.
    pub positions_mm: Vec<f64>,
    /// Whether feeds outside the measured ones were allowed (the header then says when a
    /// table feed is extrapolated).
    pub extrapolate: bool,
    /// The map's section at each feed, in the order of `feeds_mm_min`.
    sections: Vec<PiecewisePoly>,
}

impl DirectionTable {
    /// The table of one direction of a map at `feeds_mm_min` and `positions_mm`.
    ///
    /// # Errors
    /// [`MapError::FeedOutside`] for a feed outside the measured feeds unless `extrapolate`.
    pub fn new(
        map: &DirectionMap,
        feeds_mm_min: Vec<f64>,
        positions_mm: Vec<f64>,
        extrapolate: bool,
    ) -> Result<Self, MapError> {
        let sections = feeds_mm_min
            .iter()
            .map(|&f| map.poly_at(f, extrapolate))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            direction: map.direction,
            start_mm: map.start_mm,
            end_mm: map.end_mm,
            measured_feed_min_mm_min: map.feed_model.feed_min_mm_min,
            measured_feed_max_mm_min: map.feed_model.feed_max_mm_min,
            feeds_mm_min,
            positions_mm,
            extrapolate,
            sections,
        })
    }

    /// Friction (N, signed) at feed `feed` and position `position` (indices into
    /// [`DirectionTable::feeds_mm_min`] and [`DirectionTable::positions_mm`]).
    ///
    /// # Panics
    /// When an index is out of range.
    pub fn friction_n(&self, feed: usize, position: usize) -> f64 {
        self.sections[feed].value_n(self.positions_mm[position] * 1e-3)
    }
}

/// A compensation table: one [`DirectionTable`] per direction of the map.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensationTable {
    /// The directions, in the map's order.
    pub directions: Vec<DirectionTable>,
}

impl CompensationTable {
    /// Tabulate every direction of `map` at the feeds and positions `grid` gives for it
    /// (`(feeds_mm_min, positions_mm)`).
    ///
    /// # Errors
    /// As [`DirectionTable::new`].
    pub fn new(
        map: &FrictionMap,
        extrapolate: bool,
        grid: impl Fn(&DirectionMap) -> (Vec<f64>, Vec<f64>),
    ) -> Result<Self, MapError> {
        let directions = map
            .directions
            .iter()
            .map(|d| {
                let (feeds, positions) = grid(d);
                DirectionTable::new(d, feeds, positions, extrapolate)
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { directions })
    }

    /// The `#` comment lines above both shapes (each ending in a line end): what the table
    /// is, units, sign, and per direction the positions and feeds where it is valid.
    pub fn header(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "# feedscope friction-compensation table (paper 000 Eq. 6 and 8: PPOCM coefficients polynomial in feed)");
        let _ = writeln!(s, "# units: position_mm = table position in mm (machine coordinates); feed_mm_min = feed in mm/min; friction_n = friction force in N");
        let _ = writeln!(s, "# sign: friction_n is signed as paper 000 Eq. 5: positive while moving forward (position increasing), negative backward; add it to the axial force command (torque = friction_n * lead / (2*pi)) to compensate");
        for d in &self.directions {
            let (lo, hi) = d
                .feeds_mm_min
                .iter()
                .fold((f64::INFINITY, 0.0f64), |(l, h), &x| (l.min(x), h.max(x)));
            let _ = writeln!(
                s,
                "# valid {}: positions {:.3} to {:.3} mm; measured feeds {} to {} mm/min; table feeds {} to {} mm/min{}",
                d.direction.as_str(),
                d.start_mm,
                d.end_mm,
                d.measured_feed_min_mm_min,
                d.measured_feed_max_mm_min,
                lo,
                hi,
                if d.extrapolate
                    && (lo < d.measured_feed_min_mm_min || hi > d.measured_feed_max_mm_min)
                {
                    " (EXTRAPOLATED beyond the measured feeds: --extrapolate)"
                } else {
                    ""
                }
            );
        }
        let _ = writeln!(s, "# no value is given outside these ranges");
        s
    }

    /// Write the long shape: [`CompensationTable::header`], then
    /// `direction,position_mm,feed_mm_min,friction_n` and one row per direction, feed and
    /// position.
    ///
    /// # Errors
    /// I/O errors of the writer.
    pub fn write_long<W: Write>(&self, mut w: W) -> std::io::Result<()> {
        w.write_all(self.header().as_bytes())?;
        writeln!(w, "direction,position_mm,feed_mm_min,friction_n")?;
        for d in &self.directions {
            for (k, x) in d.feeds_mm_min.iter().enumerate() {
                for (j, z) in d.positions_mm.iter().enumerate() {
                    writeln!(
                        w,
                        "{},{:.6},{:.6},{:.6}",
                        d.direction.as_str(),
                        z,
                        x,
                        d.friction_n(k, j)
                    )?;
                }
            }
        }
        w.flush()
    }

    /// Write the matrix shape of one direction: [`CompensationTable::header`], a comment on
    /// the shape, `position_mm` and the feeds, then one row per position. Nothing is written
    /// for a direction the table does not have.
    ///
    /// # Errors
    /// I/O errors of the writer.
    pub fn write_matrix<W: Write>(&self, mut w: W, direction: Direction) -> std::io::Result<()> {
        let Some(d) = self.directions.iter().find(|d| d.direction == direction) else {
            return Ok(());
        };
        w.write_all(self.header().as_bytes())?;
        writeln!(w, "# matrix: one row per position; first column position_mm, then friction_n (N) at the feed (mm/min) named in the header")?;
        write!(w, "position_mm")?;
        for x in &d.feeds_mm_min {
            write!(w, ",{x:.6}")?;
        }
        writeln!(w)?;
        for (j, z) in d.positions_mm.iter().enumerate() {
            write!(w, "{z:.6}")?;
            for k in 0..d.feeds_mm_min.len() {
                write!(w, ",{:.6}", d.friction_n(k, j))?;
            }
            writeln!(w)?;
        }
        w.flush()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use feedscope::estimate::{MoveKind, StrokeFriction, StrokeSummary};
    use feedscope::map::{build_map, MapParams, RunFriction, TestRun};
    use feedscope::units::feed_mm_min_to_m_s;

    const LEAD_M: f64 = 0.01;

    /// A forward stroke over [10, 50] mm on the grid p/1024 with friction
    /// 200 N + 0.5 N/mm · z + 10 N · ln(feed / 100 mm/min): linear in z and in ln(feed), which
    /// the map of three feeds (feed polynomial of order 1 in log feed) represents exactly.
    fn run(feed: f64) -> RunFriction {
        let step = LEAD_M / 1024.0;
        let z: Vec<f64> = (0..4097).map(|k| 0.01 + k as f64 * step).collect();
        let n = z.len();
        let friction_n = z
            .iter()
            .map(|&x| 200.0 + 0.5 * x * 1e3 + 10.0 * (feed / 100.0).ln())
            .collect();
        let summary = StrokeSummary {
            stroke: 0,
            direction: Direction::Forward,
            feed_mm_min: feed,
            feed_min_mm_min: None,
            feed_max_mm_min: None,
            start_mm: 10.0,
            end_mm: 50.0,
            length_mm: 40.0,
            start_time_s: 0.0,
            end_time_s: 1.0,
            mean_friction_n: 0.0,
            friction_std_n: 0.0,
            position_samples: n,
            effort_samples: n,
            points: n,
            raw_samples_per_lead: 100.0,
            max_order: 40.0,
            kind: MoveKind::Measuring,
            position_cutoff_order: None,
            position_cutoff_hz: None,
            settle_margin_s: 0.0,
            noise_floor: Default::default(),
            mean_friction_se_n: None,
            effort_quantum_n: 0.0,
            verdict: None,
            program_line: None,
            programmed_feed_mm_min: None,
            warnings: vec![],
        };
        RunFriction {
            run: TestRun {
                name: format!("f{feed}.csv"),
                file: format!("f{feed}.csv").into(),
                feed_mm_min: feed,
                repeat: 1,
            },
            strokes: vec![StrokeFriction {
                summary,
                time_s: vec![0.0; n],
                velocity_m_s: vec![feed_mm_min_to_m_s(feed); n],
                accel_m_s2: vec![0.0; n],
                effort: vec![0.0; n],
                position_m: z,
                friction_n,
            }],
            warnings: vec![],
        }
    }

    #[test]
    fn long_and_matrix_hold_the_map_at_every_position_and_feed() {
        let runs: Vec<RunFriction> = [100.0, 300.0, 900.0].into_iter().map(run).collect();
        let map = build_map(&runs, LEAD_M, &MapParams::default()).unwrap();
        let d = map.direction(Direction::Forward).unwrap();
        let positions = vec![d.start_mm, 20.0, 30.0, d.end_mm];
        let table =
            CompensationTable::new(&map, false, |d| (d.feeds_mm_min(), positions.clone())).unwrap();
        let mut long = Vec::new();
        table.write_long(&mut long).unwrap();
        let long = String::from_utf8(long).unwrap();
        let header = table.header();
        assert!(long.starts_with(&header));
        assert!(header.contains("# valid forward: positions "));
        assert!(!header.contains("EXTRAPOLATED"));
        let rows: Vec<&str> = long[header.len()..].lines().collect();
        assert_eq!(rows[0], "direction,position_mm,feed_mm_min,friction_n");
        assert_eq!(rows.len(), 1 + 3 * positions.len());
        // Row of feed 300 at 20 mm: the map's value, written to 1 µN.
        let want = d.friction_n(20.0, 300.0, false).unwrap();
        assert_eq!(
            rows[1 + positions.len() + 1],
            format!("forward,20.000000,300.000000,{want:.6}")
        );
        // The truth comes back: exact data, so only rounding in the least-squares fits
        // (≈ 1e-12 relative on 200 N) separates them.
        let truth = 200.0 + 10.0 + 10.0 * 3f64.ln();
        assert!((want - truth).abs() < 1e-8, "{want} vs {truth}");

        let mut matrix = Vec::new();
        table.write_matrix(&mut matrix, Direction::Forward).unwrap();
        let matrix = String::from_utf8(matrix).unwrap();
        let rows: Vec<&str> = matrix[header.len()..].lines().collect();
        assert!(rows[0].starts_with("# matrix:"));
        assert_eq!(rows[1], "position_mm,100.000000,300.000000,900.000000");
        assert_eq!(rows.len(), 2 + positions.len());
        assert!(rows[3].starts_with(&format!(
            "20.000000,{:.6},{want:.6},",
            table.directions[0].friction_n(0, 1)
        )));
        // No backward strokes: nothing to write for that direction.
        let mut none = Vec::new();
        table.write_matrix(&mut none, Direction::Backward).unwrap();
        assert!(none.is_empty());
        // A feed outside the measured ones needs `extrapolate`, and the header says so.
        assert!(CompensationTable::new(&map, false, |d| (vec![50.0], vec![d.start_mm])).is_err());
        let t = CompensationTable::new(&map, true, |d| (vec![50.0], vec![d.start_mm])).unwrap();
        assert!(t
            .header()
            .contains("(EXTRAPOLATED beyond the measured feeds: --extrapolate)"));
    }
}
