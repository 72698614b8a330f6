//! Parameter rows as `Model.max_error` takes them: which of the model's inputs the columns
//! are, and the rows as offsets from the model's values in internal units.

use super::unit;
use crate::errors::value_error;
use gpu_amcs_core::engine::MAX_ANGLE_OFFSET;
use gpu_amcs_core::kinematics::{InputSpace, MAX_LENGTH_MM};
use gpu_amcs_core::number::fmt_plain;
use pyo3::prelude::*;
use rayon::prelude::*;

/// Which of the inputs of `space` the columns of a `params` matrix hold,
/// as `cols` names them (indices or names); `None` when not given (the matrix's width then
/// decides: all `5n + 3` in order, or the `5n` parameters with the tool at the model's value).
pub(super) fn columns(
    cols: Option<&Bound<'_, PyAny>>,
    space: InputSpace,
) -> PyResult<Option<Vec<usize>>> {
    let nu = space.len();
    let Some(cols) = cols else {
        return Ok(None);
    };
    let mut out = Vec::new();
    for (c, item) in cols.try_iter()?.enumerate() {
        let item = item?;
        let i = if let Ok(i) = item.extract::<usize>() {
            i
        } else if let Ok(s) = item.extract::<String>() {
            space.find(&s).ok_or_else(|| {
                value_error(format!(
                    "columns[{c}]: unknown input '{s}' (expected theta1 … beta{}, tool_x, \
                     tool_y or tool_z)",
                    space.joints()
                ))
            })?
        } else {
            return Err(value_error(format!(
                "columns[{c}]: expected an input index 0…{} or a name such as 'theta1' or \
                 'tool_x'",
                nu - 1
            )));
        };
        if i >= nu {
            return Err(value_error(format!(
                "columns[{c}]: input index {i} is out of range 0…{}",
                nu - 1
            )));
        }
        if out.contains(&i) {
            return Err(value_error(format!(
                "columns[{c}]: input {} appears twice",
                space.name(i)
            )));
        }
        out.push(i);
    }
    if out.is_empty() {
        return Err(value_error("columns: at least one input is needed"));
    }
    Ok(Some(out))
}

/// Fills `buf` (`rows × space.len()`, internal units) with the offsets from the mean
/// of rows `first .. first + rows` of `params`; entries of inputs not in `cols` are 0. Rows are
/// converted in parallel; an error names the first bad row.
pub(super) fn offsets_of(
    space: InputSpace,
    params: &numpy::ndarray::ArrayView2<'_, f64>,
    cols: &[usize],
    mean_file: &[f64],
    are_offsets: bool,
    first: usize,
    buf: &mut [f64],
) -> Result<(), String> {
    let row = |r: usize, out: &mut [f64]| -> Result<(), String> {
        out.fill(0.0);
        let row = params.row(first + r);
        for (c, &p) in cols.iter().enumerate() {
            let v = row[c];
            let here = || format!("params: row {}, column {c} ({})", first + r, space.name(p));
            if !v.is_finite() {
                return Err(format!("{}: {v} is not a finite number", here()));
            }
            let off = if are_offsets { v } else { v - mean_file[p] };
            if space.is_angle(p) && off.abs() > MAX_ANGLE_OFFSET.to_degrees() {
                return Err(format!(
                    "{}: {v} deg is {off:.4} deg from the model's value {}; the evaluator \
                     accepts angular offsets up to {:.0} deg",
                    here(),
                    mean_file[p],
                    MAX_ANGLE_OFFSET.to_degrees()
                ));
            }
            // Lengths within the bound every model file is checked against: beyond it the
            // forward kinematics overflows to inf, never an answer.
            if !space.is_angle(p) && off.abs() > MAX_LENGTH_MM {
                return Err(format!(
                    "{}: {} mm is {} mm from the model's value {}; lengths may move at \
                     most {} mm",
                    here(),
                    fmt_plain(v),
                    fmt_plain(off),
                    fmt_plain(mean_file[p]),
                    fmt_plain(MAX_LENGTH_MM),
                ));
            }
            out[p] = off * unit(space, p);
        }
        Ok(())
    };
    let nu = space.len();
    let parallel = buf
        .par_chunks_exact_mut(nu)
        .enumerate()
        .try_for_each(|(r, out)| row(r, out));
    match parallel {
        Ok(()) => Ok(()),
        // Another thread may have stopped at a later bad row: name the first one.
        Err(_) => buf
            .chunks_exact_mut(nu)
            .enumerate()
            .try_for_each(|(r, out)| row(r, out)),
    }
}
