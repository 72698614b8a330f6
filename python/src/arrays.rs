//! NumPy input: any array-like of numbers (float64 or float32, C or Fortran order, strided
//! views, nested lists) becomes a float64 view; wrong shapes and non-finite values are refused
//! naming the argument, the row and the column. Where NumPy users pass a scalar or a single
//! row, it is taken: one configuration as a 1-D array, one threshold as a number.

use crate::errors::value_error;
use gpu_amcs_core::kinematics::Joints;
use numpy::ndarray::ArrayView2;
use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};

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

/// `obj` as a float64 NumPy array (`numpy.asarray`), or a `ValueError` naming `name`.
fn float_array<'py>(obj: &Bound<'py, PyAny>, name: &str) -> PyResult<Bound<'py, PyArrayDyn<f64>>> {
    let py = obj.py();
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    py.import("numpy")?
        .call_method("asarray", (obj,), Some(&kwargs))
        .and_then(|a| Ok(a.cast_into::<PyArrayDyn<f64>>()?))
        .map_err(|e| value_error(format!("{name}: not an array of numbers ({e})")))
}

/// A shape as Python writes it: `(6,)`, `(3, 6)`.
fn shape_text(shape: &[usize]) -> String {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    format!(
        "({}{})",
        dims.join(", "),
        if shape.len() == 1 { "," } else { "" }
    )
}

/// Reads `obj` as a 2-D array of numbers whose column count is one of `cols` (any count when
/// `cols` is empty); `what` describes the expected shape for the message (e.g. "(m, 6) joint
/// angles in degrees" for a six-joint model). With `one_row`, a 1-D array of one of those
/// lengths is taken as a single row (the flag in the answer says it was).
pub fn read<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    cols: &[usize],
    what: &str,
    one_row: bool,
) -> PyResult<(Matrix<'py>, bool)> {
    let mut arr = float_array(obj, name)?;
    let shape = arr.shape().to_vec();
    let fits = |c: usize| cols.is_empty() || cols.contains(&c);
    let single = one_row && shape.len() == 1 && fits(shape[0]);
    if single {
        arr = arr
            .call_method1("reshape", ((1usize, shape[0]),))?
            .cast_into::<PyArrayDyn<f64>>()?;
    } else if !(shape.len() == 2 && fits(shape[1])) {
        let alone = match (one_row, cols) {
            (true, [c]) => format!(", or a 1-D array of shape ({c},) for one row"),
            _ => String::new(),
        };
        return Err(value_error(format!(
            "{name}: expected a 2-D array of shape {what}{alone}, got shape {}",
            shape_text(&shape)
        )));
    }
    Ok((
        Matrix {
            array: arr.readonly(),
        },
        single,
    ))
}

/// Numbers from a number or a 1-D sequence or array of numbers (`unit` names their unit in
/// the message); `None` (or Python's `None`) when not given.
pub fn numbers(
    obj: Option<&Bound<'_, PyAny>>,
    name: &str,
    unit: &str,
) -> PyResult<Option<Vec<f64>>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    let refused = |got: String| {
        value_error(format!(
            "{name}: expected a number or a 1-D sequence of numbers ({unit}), got {got}"
        ))
    };
    // NumPy would read a string of digits as a number.
    if obj.is_instance_of::<PyString>() {
        return Err(refused(format!("the string {}", obj.repr()?)));
    }
    let arr = float_array(obj, name)?;
    let shape = arr.shape().to_vec();
    if shape.len() > 1 {
        return Err(refused(format!("shape {}", shape_text(&shape))));
    }
    Ok(Some(arr.readonly().as_array().iter().copied().collect()))
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

/// Joint configurations `q_deg` (m × `joints`, degrees: one column per joint of the model; or
/// one configuration of `joints` angles), finite, as rows, and whether it was one 1-D
/// configuration.
pub fn joint_rows(
    obj: &Bound<'_, PyAny>,
    name: &str,
    joints: usize,
) -> PyResult<(Vec<Joints>, bool)> {
    let (m, single) = read(
        obj,
        name,
        &[joints],
        &format!("(m, {joints}) joint angles in degrees"),
        true,
    )?;
    let v = m.view();
    check_finite(&v, name, |c| format!("q{}", c + 1))?;
    let rows = v
        .rows()
        .into_iter()
        .map(|r| Joints::from_fn(joints, |j| r[j]))
        .collect();
    Ok((rows, single))
}
