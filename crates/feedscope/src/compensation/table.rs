//! The generic table: velocity → friction force, motor torque and current, per direction.

use super::{
    place_points, CompensationError, DriveConversion, FrictionCurve, PlacedTable, PlacementParams,
};

/// The most points of a [`VelocityTable`]: a quarter of the default placement grid.
pub const VELOCITY_TABLE_MAX_POINTS: usize = 512;

/// One direction of a [`VelocityTable`].
#[derive(Debug, Clone, PartialEq)]
pub struct DirectionVelocityTable {
    /// The curve the table was placed on.
    pub curve: FrictionCurve,
    /// The table (velocities, friction magnitudes) and its error against the curve.
    pub placed: PlacedTable,
}

/// A velocity → friction table per direction for any control: N points placed where the
/// curve bends ([`place_points`]), with the motor torque and current of each point
/// ([`DriveConversion`]).
#[derive(Debug, Clone, PartialEq)]
pub struct VelocityTable {
    /// One table per curve, in the order given.
    pub directions: Vec<DirectionVelocityTable>,
    /// Force → torque → current.
    pub drive: DriveConversion,
}

impl VelocityTable {
    /// Place `points` points on each curve.
    ///
    /// # Errors
    /// [`CompensationError::TooManyPoints`] above [`VELOCITY_TABLE_MAX_POINTS`] (or the
    /// placement grid's limit), else as [`place_points`].
    pub fn build(
        curves: &[FrictionCurve],
        drive: DriveConversion,
        points: usize,
        params: &PlacementParams,
    ) -> Result<Self, CompensationError> {
        if points > VELOCITY_TABLE_MAX_POINTS {
            return Err(CompensationError::TooManyPoints {
                points,
                max: VELOCITY_TABLE_MAX_POINTS,
                what: "the generic table",
            });
        }
        let directions = curves
            .iter()
            .map(|c| {
                Ok(DirectionVelocityTable {
                    curve: c.clone(),
                    placed: place_points(c, points, params)?,
                })
            })
            .collect::<Result<_, CompensationError>>()?;
        Ok(Self { directions, drive })
    }
}
