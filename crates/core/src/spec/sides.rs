//! The backlash sides a points file gives its configurations (docs/METHOD.md §19.5): read
//! with the points and fixed in the problem built from them.

use super::{SpecError, SpecErrorKind, SpecField};
use crate::engine::Problem;
use crate::points;

/// Fixes in `problem` the sides the points file `path` gives (its `s1..sn` columns), if any.
///
/// # Errors
///
/// Naming [`SpecField::PointsFile`]: the file's [`points::read_sides`] errors, and the
/// problem's refusal of the sides ([`Problem::set_known_sides`]: a model without backlash).
pub(super) fn apply_file_sides(
    problem: &mut Problem,
    path: &std::path::Path,
) -> Result<(), SpecError> {
    let Some(sides) = points::read_sides(path, problem.model.joints())
        .map_err(|e| SpecError::new(SpecField::PointsFile, e))?
    else {
        return Ok(());
    };
    problem.set_known_sides(&sides).map_err(|e| {
        SpecError::new(
            SpecField::PointsFile,
            SpecErrorKind::PointsFile {
                path: path.to_path_buf(),
                source: e,
            },
        )
    })
}
