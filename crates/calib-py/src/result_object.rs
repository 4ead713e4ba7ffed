//! What every result object of the package shares.

/// The methods every result object shares, as a second `#[pymethods]` block (pyo3's
/// `multiple-pymethods`): `warnings`, `report`, `elapsed`, `summary`, `to_json`, and the tuple
/// protocol (`len`, indexing, unpacking) over the type's `tuple()` of `$len` items. `$ty` has
/// `inner` with `warnings`, `elapsed`, `summary()` and `to_json()`.
macro_rules! result_object_methods {
    ($ty:ident, $inner:ty, $len:literal, $json_doc:literal) => {
        #[pyo3::pymethods]
        impl $ty {
            /// The result of ``to_json()`` text (or a result file of the ``calib`` command) as a
            /// result object again. Raises ``ValueError`` when the text is not such a result.
            #[staticmethod]
            fn from_json(text: &str) -> pyo3::PyResult<Self> {
                let value: serde_json::Value = serde_json::from_str(text).map_err(|e| {
                    pyo3::exceptions::PyValueError::new_err(format!("text: not JSON: {e}"))
                })?;
                let inner = <$inner>::from_json(value)
                    .map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("text: {e}")))?;
                Ok(Self { inner })
            }

            /// Pickling (and ``copy``) through the JSON form, which holds every number exactly.
            fn __reduce__<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<(pyo3::Bound<'py, pyo3::PyAny>, (String,))> {
                use pyo3::types::PyAnyMethods;
                let from_json = py.get_type::<Self>().getattr("from_json")?;
                Ok((from_json, (self.to_json()?,)))
            }

            /// What deserves attention (list of :class:`CalibrationWarning`).
            #[getter]
            fn warnings<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::types::PyList>> {
                $crate::warnings_out(py, &self.inner.warnings)
            }

            /// The Levenberg-Marquardt report as a dict (termination, costs, iterations, timings).
            #[getter]
            fn report<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                $crate::convert::json_to_py(py, &self.inner.to_json()["solver"])
            }

            /// Wall time of the calibration in seconds.
            #[getter]
            fn elapsed(&self) -> f64 {
                self.inner.elapsed.as_secs_f64()
            }

            /// A human summary: every parameter with +- 3 sigma, the RMS, the worst views,
            /// warnings.
            fn summary(&self) -> String {
                self.inner.summary()
            }

            #[doc = $json_doc]
            fn to_json(&self) -> pyo3::PyResult<String> {
                serde_json::to_string_pretty(&self.inner.to_json())
                    .map_err($crate::calibration_error)
            }

            fn __len__(&self) -> usize {
                $len
            }

            /// Like a tuple: an index, or a slice (``r[:3]``) giving a tuple.
            fn __getitem__<'py>(
                &self,
                py: pyo3::Python<'py>,
                index: &pyo3::Bound<'py, pyo3::PyAny>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                use pyo3::types::{PyAnyMethods, PyTupleMethods};
                if index.is_instance_of::<pyo3::types::PySlice>() {
                    return self.tuple(py)?.as_any().get_item(index);
                }
                let index: isize = index
                    .call_method0("__index__")
                    .and_then(|i| i.extract())
                    .map_err(|_| {
                        pyo3::exceptions::PyTypeError::new_err(format!(
                            concat!(
                                stringify!($ty),
                                " indices must be integers or slices, not {}"
                            ),
                            $crate::convert::type_name(index)
                        ))
                    })?;
                let i = if index < 0 { index + $len } else { index };
                if !(0..$len).contains(&i) {
                    return Err(pyo3::exceptions::PyIndexError::new_err(concat!(
                        stringify!($ty),
                        " index out of range"
                    )));
                }
                self.tuple(py)?.get_item(i as usize)
            }

            fn __iter__<'py>(
                &self,
                py: pyo3::Python<'py>,
            ) -> pyo3::PyResult<pyo3::Bound<'py, pyo3::PyAny>> {
                use pyo3::types::PyAnyMethods;
                Ok(self.tuple(py)?.try_iter()?.into_any())
            }
        }
    };
}
