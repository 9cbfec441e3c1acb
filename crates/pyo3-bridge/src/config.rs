//! The one path from Python keyword arguments to a core crate's typed config struct.
//!
//! Every config derives serde's `Deserialize` with defaults and `deny_unknown_fields`.
//! A dict (or dataclass) of keywords is read by serde-pyobject into a generic serde
//! value (which keeps NaN and infinities), then deserialised into the config through
//! `serde_path_to_error`, so every message names the field (`appearance.bins`), and no
//! binding has code per field. The caller then runs the config's `validate()`.

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::de::DeserializeOwned;

use rperc_core::{QUOTE_LIMIT, clip};

use crate::errors::{Error, Result, guarded};

/// Reads `obj` (a dict of keywords, a dataclass, or `None` for all defaults) as `T`.
/// Unknown or mistyped fields are a `TypeError`, bad values a `ValueError`, and each
/// message names the config and the field.
pub fn from_python<T: DeserializeOwned + Default>(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
) -> Result<T> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(T::default());
    };
    let obj = plain(obj, what)?;
    // serde-pyobject panics on Python types it does not know; `plain` refuses those
    // first, and the guard stays for anything it missed.
    let value = guarded(|| {
        serde_pyobject::from_pyobject::<serde_value::Value, _>(obj.clone()).map_err(|e| {
            let msg = e.0.value(obj.py()).to_string();
            Error::Type(format!("{what}: {}", clip(&msg, 4 * QUOTE_LIMIT)))
        })
    })?;
    serde_path_to_error::deserialize::<_, T>(value).map_err(|e| {
        let (field, msg) = (e.path().to_string(), e.inner().to_string());
        // serde quotes the value it refused: never a whole 5 MB string (issue 38).
        let text = format!(
            "{what}: {}: {}",
            clip(&field, QUOTE_LIMIT),
            clip(&msg, 4 * QUOTE_LIMIT)
        );
        let lower = msg.to_lowercase();
        if lower.starts_with("unknown field") || lower.starts_with("invalid type") {
            Error::Type(text)
        } else {
            Error::Value(text)
        }
    })
}

/// `obj` with numpy scalars (`np.float32(0.5)`, `np.int64(3)`) turned into Python
/// numbers, inside dicts, lists and tuples; a leaf of any other type serde-pyobject
/// cannot read (a complex, bytes, a set) is a `TypeError`, an int beyond i64 a
/// `ValueError`, each naming its field. Objects
/// with attributes (dataclasses) pass through: serde-pyobject reads those.
fn plain<'py>(obj: &Bound<'py, PyAny>, path: &str) -> Result<Bound<'py, PyAny>> {
    let py = obj.py();
    // serde-pyobject reads ints as i64 and its overflow error names no field.
    // The size, not the digits: repr refuses ints over 4300 digits, and a message
    // quotes no more than a few dozen characters of its input.
    if obj.is_instance_of::<PyInt>() && obj.extract::<i64>().is_err() {
        let bits: u64 = obj.call_method0("bit_length")?.extract()?;
        return Err(Error::Value(format!(
            "{}: an integer of {bits} bits is out of range (a signed 64-bit integer: \
             -2^63 to 2^63 - 1)",
            clip(path, QUOTE_LIMIT)
        )));
    }
    if obj.is_none()
        || obj.is_instance_of::<PyBool>()
        || obj.is_instance_of::<PyInt>()
        || obj.is_instance_of::<PyFloat>()
        || obj.is_instance_of::<PyString>()
    {
        return Ok(obj.clone());
    }
    if let Ok(dict) = obj.cast::<PyDict>() {
        let out = PyDict::new(py);
        for (key, value) in dict.iter() {
            out.set_item(&key, plain(&value, &format!("{path}.{key}"))?)?;
        }
        return Ok(out.into_any());
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = obj
            .try_iter()?
            .enumerate()
            .map(|(k, item)| plain(&item?, &format!("{path}[{k}]")))
            .collect::<Result<Vec<_>>>()?;
        return Ok(PyList::new(py, items)?.into_any());
    }
    if obj.hasattr("dtype")? && obj.hasattr("item")? && obj.getattr("ndim")?.extract::<i64>()? == 0
    {
        let item = obj.call_method0("item")?;
        if !item.is_instance_of::<PyInt>()
            && !item.is_instance_of::<PyFloat>()
            && !item.is_instance_of::<PyBool>()
        {
            return Err(Error::Type(format!(
                "{}: expected a number, got {}",
                clip(path, QUOTE_LIMIT),
                obj.repr()?
            )));
        }
        return Ok(item);
    }
    if obj.hasattr("__dict__")? || obj.hasattr("__slots__")? {
        return Ok(obj.clone());
    }
    Err(Error::Type(format!(
        "{}: unsupported type {}",
        clip(path, QUOTE_LIMIT),
        obj.get_type().name()?
    )))
}

/// The default config `T`, as a dict: what the typed Python layer shows as defaults.
pub fn defaults<'py, T: serde::Serialize + Default>(
    py: Python<'py>,
) -> PyResult<Bound<'py, PyAny>> {
    serde_pyobject::to_pyobject(py, &T::default()).map_err(PyErr::from)
}

/// The configs the Python layer generates its classes from, by name.
const SCHEMA_NAMES: &[&str] = &[
    "color_histogram",
    "color_shape",
    "color_template",
    "laser",
    "laser_scan",
    "monobot",
    "particle_color",
    "pattern",
    "pattern_sequence",
    "planar",
    "planar_sim",
    "scan_params",
    "smoother",
    "ceiling",
    "ceiling_camera",
    "ceiling_render",
    "odometry_noise",
    "memory_learn",
    "memory_replay",
];

/// Calls the generic function `$f::<T>($args)` with `T` the config named `$name`: the
/// one place a config's name is tied to its Rust type.
macro_rules! with_config {
    ($name:expr, $f:ident($($arg:expr),*)) => {
        match $name {
            "color_histogram" => $f::<tracking::ColorTrackerParams>($($arg),*),
            "color_shape" => $f::<tracking::ColorShapeParams>($($arg),*),
            "color_template" => $f::<tracking::ColorTemplateParams>($($arg),*),
            "particle_color" => $f::<tracking::ParticleTrackerParams>($($arg),*),
            "pattern" => $f::<tracking::PatternTrackerParams>($($arg),*),
            "pattern_sequence" => $f::<tracking::SequenceParams>($($arg),*),
            "laser" => $f::<laser::LaserConfig>($($arg),*),
            "laser_scan" => $f::<laser::ScanConfig>($($arg),*),
            "monobot" => $f::<slam::monobot::MonobotConfig>($($arg),*),
            "planar" => $f::<slam::PlanarConfig>($($arg),*),
            "planar_sim" => $f::<slam::planar::sim::SimConfig>($($arg),*),
            "scan_params" => $f::<linesimp::ScanParams>($($arg),*),
            "smoother" => $f::<slam::planar::smooth::SmootherConfig>($($arg),*),
            "ceiling" => $f::<navigation::ceiling::CeilingParams>($($arg),*),
            "ceiling_camera" => $f::<navigation::ceiling::CeilingCamera>($($arg),*),
            "ceiling_render" => $f::<navigation::ceiling::RenderParams>($($arg),*),
            "odometry_noise" => $f::<navigation::ceiling::OdometryNoise>($($arg),*),
            "memory_learn" => $f::<navigation::memory::LearnParams>($($arg),*),
            "memory_replay" => $f::<navigation::memory::ReplayParams>($($arg),*),
            _ => Err(unknown_config($name)),
        }
    };
}

/// A config's own check (`validate()`), for the generic functions below.
trait Validated {
    fn check(&self) -> Result<()>;
}

macro_rules! validated {
    ($($t:ty),+) => {
        $(impl Validated for $t {
            fn check(&self) -> Result<()> {
                // Some validate() answer a count too (the colour models' bins).
                self.validate()?;
                Ok(())
            }
        })+
    };
}

validated!(
    tracking::ColorTrackerParams,
    tracking::ColorShapeParams,
    tracking::ColorTemplateParams,
    tracking::ParticleTrackerParams,
    tracking::PatternTrackerParams,
    tracking::SequenceParams,
    laser::LaserConfig,
    laser::ScanConfig,
    slam::monobot::MonobotConfig,
    slam::PlanarConfig,
    slam::planar::sim::SimConfig,
    linesimp::ScanParams,
    slam::planar::smooth::SmootherConfig,
    navigation::ceiling::CeilingParams,
    navigation::ceiling::CeilingCamera,
    navigation::ceiling::RenderParams,
    navigation::ceiling::OdometryNoise,
    navigation::memory::LearnParams,
    navigation::memory::ReplayParams
);

fn unknown_config(name: &str) -> Error {
    Error::Value(format!(
        "unknown config '{}'; expected one of {}",
        clip(name, QUOTE_LIMIT),
        SCHEMA_NAMES.join(", ")
    ))
}

fn json<T: serde::Serialize>(value: &T, name: &str) -> Result<String> {
    serde_json::to_string(value).map_err(|e| Error::Value(format!("config '{name}': {e}")))
}

fn schema_of<T: schemars::JsonSchema>(name: &str) -> Result<String> {
    json(&schemars::schema_for!(T), name)
}

fn defaults_of<'py, T: serde::Serialize + Default>(py: Python<'py>) -> Result<Bound<'py, PyAny>> {
    Ok(defaults::<T>(py)?)
}

fn check_of<T: DeserializeOwned + Default + Validated>(
    config: &Bound<'_, PyAny>,
    name: &str,
) -> Result<()> {
    from_python::<T>(Some(config), name)?.check()
}

/// The JSON Schema (draft 2020-12) of the config `name`: every field's name, type,
/// default and doc comment, as the Rust struct declares them. The Python layer's
/// config classes (`rperc.config`) are generated from it, and a test checks that they
/// still match, so a config is defined once, here.
#[pyfunction]
pub fn config_schema(name: &str) -> Result<String> {
    with_config!(name, schema_of(name))
}

/// The default config `name` as a dict (serde's serialisation of `Default`, which
/// keeps infinities): a second path to the defaults, independent of the schema.
#[pyfunction]
pub fn config_defaults<'py>(py: Python<'py>, name: &str) -> Result<Bound<'py, PyAny>> {
    with_config!(name, defaults_of(py))
}

/// Reads `config` (a dict) as the config `name` and runs its `validate()`: the one
/// check of a config, which the Python config classes call when they are made.
#[pyfunction]
pub fn config_check(name: &str, config: &Bound<'_, PyAny>) -> Result<()> {
    with_config!(name, check_of(config, name))
}

/// The names `config_schema` knows.
#[pyfunction]
pub fn config_names() -> Vec<&'static str> {
    SCHEMA_NAMES.to_vec()
}
