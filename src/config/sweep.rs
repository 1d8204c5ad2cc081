//! Parameter sweeps: a grid over numeric scene fields, run as one study with
//! the same seed at every point (common random numbers, so differences
//! between points are not noise).

use std::path::Path;

use crate::config::path as field_path;
use crate::config::RawScene;
use crate::config::{Overrides, Scene, SceneError, SceneText};

/// One axis of the grid: a field path and its values.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub path: String,
    pub values: Vec<f64>,
}

/// One grid point: the swept values (in axis order) and its scene.
#[derive(Debug, Clone)]
pub struct Point {
    pub values: Vec<(String, f64)>,
    pub scene: Scene,
}

/// Largest number of grid points accepted.
pub const MAX_POINTS: usize = 100_000;

fn err(file: &str, field: &str, message: String) -> SceneError {
    SceneError {
        file: file.to_string(),
        line: None,
        field: field.to_string(),
        message,
    }
}

/// Sets the number at `path` (rules of [`super::path`]) in a TOML value.
/// The field must be there and be a number (an integer stays one where
/// the value is whole), except a plane's `friction`, which may be absent
/// (μ = 0).
pub fn set_path(root: &mut toml::Value, path: &str, value: f64) -> Result<(), String> {
    let number = match field_path::get(root, path)? {
        Some(toml::Value::Integer(_)) if value.fract() == 0.0 && value.abs() < 9e15 => {
            toml::Value::Integer(value as i64)
        }
        Some(toml::Value::Float(_) | toml::Value::Integer(_)) => toml::Value::Float(value),
        None if path.rsplit('.').next() == Some("friction") => toml::Value::Float(value),
        None => {
            let key = path.rsplit('.').next().unwrap_or(path);
            return Err(format!("no field {key:?}"));
        }
        Some(other) => {
            return Err(format!(
                "{path:?} is not a number (it is {})",
                other.type_str()
            ))
        }
    };
    field_path::set(root, path, number)
}

/// Reads the sweep axes of a raw scene, in file order.
pub fn axes(file: &str, raw: &RawScene) -> Result<Vec<Axis>, SceneError> {
    let Some(table) = &raw.sweep else {
        return Ok(Vec::new());
    };
    let mut out = Vec::new();
    for (path, v) in table {
        let field = format!("sweep.{path:?}");
        let arr = v.as_array().ok_or_else(|| {
            err(
                file,
                &field,
                format!("must be an array of numbers, got {v}"),
            )
        })?;
        let values: Vec<f64> = arr
            .iter()
            .map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64)))
            .collect::<Option<_>>()
            .ok_or_else(|| {
                err(
                    file,
                    &field,
                    format!("must be an array of numbers, got {v}"),
                )
            })?;
        if values.is_empty() {
            return Err(err(file, &field, "must list at least one value".into()));
        }
        out.push(Axis {
            path: path.clone(),
            values,
        });
    }
    Ok(out)
}

/// Expands a scene file into its grid points (one point without a sweep).
pub fn plan(path: &Path, overrides: &Overrides) -> Result<(Vec<Axis>, Vec<Point>), SceneError> {
    plan_text(&SceneText::read(path)?, overrides)
}

/// Expands scene text into its grid points (one point without a sweep).
pub fn plan_text(
    src: &SceneText,
    overrides: &Overrides,
) -> Result<(Vec<Axis>, Vec<Point>), SceneError> {
    let (file, text) = (src.file.as_str(), src.text.as_str());
    let raw = src.raw(overrides)?;
    let axes = axes(file, &raw)?;
    let total: usize = axes.iter().map(|a| a.values.len()).product();
    if total > MAX_POINTS {
        return Err(err(
            file,
            "sweep",
            format!("{total} grid points; at most {MAX_POINTS}"),
        ));
    }
    let mut base = raw.clone();
    base.sweep = None;
    // TOML integers are i64: a u64 seed above i64::MAX (from `--seed`)
    // goes around the TOML form of the points, unless a sweep sets it.
    let seed_swept = axes.iter().any(|a| a.path == "seed");
    if !seed_swept {
        base.seed = 0;
    }
    let base_value =
        toml::Value::try_from(&base).map_err(|e| err(file, "(scene)", e.to_string()))?;
    let mut points = Vec::with_capacity(total);
    for flat in 0..total {
        let mut rem = flat;
        let mut values = Vec::new();
        // Last axis fastest.
        let mut idx = vec![0; axes.len()];
        for (k, a) in axes.iter().enumerate().rev() {
            idx[k] = rem % a.values.len();
            rem /= a.values.len();
        }
        let mut doc = base_value.clone();
        for (a, &i) in axes.iter().zip(&idx) {
            let x = a.values[i];
            set_path(&mut doc, &a.path, x)
                .map_err(|m| err(file, &format!("sweep.{:?}", a.path), m))?;
            values.push((a.path.clone(), x));
        }
        let mut point_raw: RawScene = doc
            .try_into()
            .map_err(|e: toml::de::Error| err(file, "sweep", e.message().to_string()))?;
        if !seed_swept {
            point_raw.seed = raw.seed;
        }
        let scene = Scene::validate(file, text, point_raw).map_err(|mut e| {
            if !values.is_empty() {
                e.message = format!("{} (at sweep point {values:?})", e.message);
            }
            overrides.blame(e)
        })?;
        points.push(Point { values, scene });
    }
    Ok((axes, points))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_by_index_and_by_name() {
        let mut v: toml::Value = toml::from_str(
            "[body]\nsemi_axes = [1.0, 1.0, 2.0]\n[[planes]]\nname = \"floor\"\nrestitution = 0.8\n",
        )
        .unwrap();
        set_path(&mut v, "body.semi_axes[2]", 4.0).unwrap();
        set_path(&mut v, "planes[0].restitution", 0.3).unwrap();
        assert_eq!(v["planes"][0]["restitution"].as_float(), Some(0.3));
        set_path(&mut v, "planes.floor.friction", 0.4).unwrap();
        assert_eq!(v["planes"][0]["friction"].as_float(), Some(0.4));
        assert!(set_path(&mut v, "planes.floor.frction", 0.4).is_err());
        set_path(&mut v, "planes.floor.restitution", 0.2).unwrap();
        assert_eq!(v["body"]["semi_axes"][2].as_float(), Some(4.0));
        assert_eq!(v["planes"][0]["restitution"].as_float(), Some(0.2));
        assert!(set_path(&mut v, "body.colour", 1.0).is_err());
        assert!(set_path(&mut v, "planes.floor.name", 1.0).is_err());
    }
}
