//! NumPy input: any array-like of numbers (float64 or float32, C or Fortran order, strided
//! views, nested lists) becomes a float64 view; wrong shapes and non-finite values are refused
//! naming the argument, the row and the column.

use crate::errors::value_error;
use gpu_amcs_core::kinematics::Joints;
use numpy::ndarray::ArrayView2;
use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A 2-D float64 array taken from a Python argument (converted by `numpy.asarray` only when its
/// dtype is not float64; strides are kept, so views cost no copy).
pub struct Matrix<'py> {
    array: PyReadonlyArrayDyn<'py, f64>,
}

impl<'py> Matrix<'py> {
    /// The values as an `n × cols` view (any strides).
    pub fn view(&self) -> ArrayView2<'_, f64> {
        // `read` checked the dimension count.
        self.array
            .as_array()
            .into_dimensionality()
            .expect("checked 2-D")
    }
}

/// Reads `obj` as a 2-D array of numbers whose column count is one of `cols` (any count when
/// `cols` is empty); `what` describes the expected shape for the message (e.g. "(m, 6) joint
/// angles in degrees" for a six-joint model).
pub fn read<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    cols: &[usize],
    what: &str,
) -> PyResult<Matrix<'py>> {
    let py = obj.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    let arr = py
        .import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .map_err(|e| value_error(format!("{name}: not an array of numbers ({e})")))?;
    let arr = arr
        .cast_into::<PyArrayDyn<f64>>()
        .map_err(|e| value_error(format!("{name}: not an array of numbers ({e})")))?;
    let shape = arr.shape().to_vec();
    let shape_ok = shape.len() == 2 && (cols.is_empty() || cols.contains(&shape[1]));
    if !shape_ok {
        let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
        return Err(value_error(format!(
            "{name}: expected a 2-D array of shape {what}, got shape ({})",
            dims.join(", ") + if shape.len() == 1 { "," } else { "" }
        )));
    }
    Ok(Matrix {
        array: arr.readonly(),
    })
}

/// Checks that every entry of `m` is finite; the error names the argument, the 0-based row and
/// column and `label(column)`.
pub fn check_finite(
    m: &ArrayView2<'_, f64>,
    name: &str,
    label: impl Fn(usize) -> String,
) -> PyResult<()> {
    for ((r, c), v) in m.indexed_iter() {
        if !v.is_finite() {
            return Err(value_error(format!(
                "{name}: row {r}, column {c} ({}): {v} is not a finite number",
                label(c)
            )));
        }
    }
    Ok(())
}

/// Joint configurations `q_deg` (m × `joints`, degrees: one column per joint of the model),
/// finite, as rows.
pub fn joint_rows(obj: &Bound<'_, PyAny>, name: &str, joints: usize) -> PyResult<Vec<Joints>> {
    let m = read(
        obj,
        name,
        &[joints],
        &format!("(m, {joints}) joint angles in degrees"),
    )?;
    let v = m.view();
    check_finite(&v, name, |c| format!("q{}", c + 1))?;
    Ok(v.rows()
        .into_iter()
        .map(|r| Joints::from_fn(joints, |j| r[j]))
        .collect())
}
