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
        Ok(())
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
        Ok(())
    }
}
