//! Parameter sweeps: a grid over numeric scene fields, run as one study with
//! the same seed at every point (common random numbers, so differences
//! between points are not noise).

use std::path::Path;

use crate::config::path as field_path;
use crate::config::RawScene;
use crate::config::{Overrides, Scene, SceneError, SceneText};

/// One swept field: its path, its values, and the grid dimension it
/// varies along. A plain `[sweep]` entry is a dimension of its own; the
/// fields of one `[[sweep.zip]]` group share one (equal-length lists that
/// vary together).
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    pub path: String,
    pub values: Vec<f64>,
    pub dimension: usize,
}

/// One grid point: the swept values (in axis order) and its scene.
#[derive(Debug, Clone)]
pub struct Point {
    pub values: Vec<(String, f64)>,
    pub scene: Scene,
}

/// A scene expanded into its grid points.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The swept fields, in file order (none without a sweep).
    pub axes: Vec<Axis>,
    /// The grid points, the last dimension fastest (one without a sweep).
    pub points: Vec<Point>,
    /// The point the others' paired differences are taken against: the
    /// first, or `sweep.reference`.
    pub reference: usize,
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

/// A list of numbers, or why not.
fn numbers(file: &str, field: &str, v: &toml::Value) -> Result<Vec<f64>, SceneError> {
    let bad = || err(file, field, format!("must be an array of numbers, got {v}"));
    let values: Vec<f64> = v
        .as_array()
        .ok_or_else(bad)?
        .iter()
        .map(|x| x.as_float().or_else(|| x.as_integer().map(|i| i as f64)))
        .collect::<Option<_>>()
        .ok_or_else(bad)?;
    if values.is_empty() {
        return Err(err(file, field, "must list at least one value".into()));
    }
    Ok(values)
}

/// Reads the sweep of a raw scene: its fields (plain ones in path order,
/// then each zip group's in path order: a TOML table's keys are sorted), each with its
/// dimension, and the reference entry if any. Keys are field paths, except
/// `zip` (an array of tables of equal-length lists) and `reference`.
pub fn axes(file: &str, raw: &RawScene) -> Result<(Vec<Axis>, Option<toml::Value>), SceneError> {
    let Some(table) = &raw.sweep else {
        return Ok((Vec::new(), None));
    };
    let mut out: Vec<Axis> = Vec::new();
    let mut reference = None;
    let mut dimension = 0;
    for (key, v) in table {
        match key.as_str() {
            "reference" => reference = Some(v.clone()),
            "zip" => {
                let groups = v.as_array().filter(|g| g.iter().all(|t| t.is_table()));
                let Some(groups) = groups else {
                    return Err(err(
                        file,
                        "sweep.zip",
                        format!(
                            "must be tables of fields that vary together ([[sweep.zip]]), got {v}"
                        ),
                    ));
                };
                for (g, group) in groups.iter().enumerate() {
                    let group = group.as_table().expect("checked above");
                    if group.is_empty() {
                        return Err(err(
                            file,
                            &format!("sweep.zip[{g}]"),
                            "must list at least one field".into(),
                        ));
                    }
                    let mut length = None;
                    for (path, values) in group {
                        let field = format!("sweep.zip[{g}].{path:?}");
                        let values = numbers(file, &field, values)?;
                        match length {
                            None => length = Some((path.clone(), values.len())),
                            Some((ref first, n)) if n != values.len() => {
                                return Err(err(
                                    file,
                                    &field,
                                    format!(
                                        "has {} values, but {first:?} in the same group has {n}: fields that vary together need lists of one length",
                                        values.len()
                                    ),
                                ))
                            }
                            Some(_) => {}
                        }
                        out.push(Axis {
                            path: path.clone(),
                            values,
                            dimension,
                        });
                    }
                    dimension += 1;
                }
            }
            path => {
                let values = numbers(file, &format!("sweep.{path:?}"), v)?;
                out.push(Axis {
                    path: path.to_string(),
                    values,
                    dimension,
                });
                dimension += 1;
            }
        }
    }
    for (i, a) in out.iter().enumerate() {
        if out[..i].iter().any(|b| b.path == a.path) {
            return Err(err(file, "sweep", format!("{:?} is swept twice", a.path)));
        }
    }
    Ok((out, reference))
}

/// The grid point `sweep.reference` names: a point's index (as in the
/// `point` column), or a table of swept fields and values that matches
/// exactly one point.
fn reference_point(
    file: &str,
    reference: Option<&toml::Value>,
    points: &[Point],
) -> Result<usize, SceneError> {
    let Some(r) = reference else {
        return Ok(0);
    };
    let field = "sweep.reference";
    if let Some(i) = r.as_integer() {
        return usize::try_from(i)
            .ok()
            .filter(|&i| i < points.len())
            .ok_or_else(|| {
                err(
                    file,
                    field,
                    format!(
                        "point {i} is not a grid point: the grid has points 0 to {}",
                        points.len() - 1
                    ),
                )
            });
    }
    let Some(table) = r.as_table() else {
        return Err(err(
            file,
            field,
            format!("must be a point's index or a table of swept fields and values, got {r}"),
        ));
    };
    let mut wanted = Vec::new();
    for (path, v) in table {
        let x = v
            .as_float()
            .or_else(|| v.as_integer().map(|i| i as f64))
            .ok_or_else(|| {
                err(
                    file,
                    &format!("{field}.{path:?}"),
                    format!("must be a number, got {v}"),
                )
            })?;
        if !points[0].values.iter().any(|(p, _)| p == path) {
            return Err(err(
                file,
                &format!("{field}.{path:?}"),
                format!("{path:?} is not a swept field"),
            ));
        }
        wanted.push((path, x));
    }
    let matches: Vec<usize> = (0..points.len())
        .filter(|&i| {
            wanted
                .iter()
                .all(|(path, x)| points[i].values.iter().any(|(p, v)| p == *path && v == x))
        })
        .collect();
    match matches.as_slice() {
        [i] => Ok(*i),
        [] => Err(err(file, field, format!("no grid point has {r}"))),
        _ => Err(err(
            file,
            field,
            format!(
                "{} grid points have {r}: name a value for every dimension of the grid",
                matches.len()
            ),
        )),
    }
}

/// Expands a scene file into its grid points (one point without a sweep).
pub fn plan(path: &Path, overrides: &Overrides) -> Result<Plan, SceneError> {
    plan_text(&SceneText::read(path)?, overrides)
}

/// Expands scene text into its grid points (one point without a sweep).
pub fn plan_text(src: &SceneText, overrides: &Overrides) -> Result<Plan, SceneError> {
    let (file, text) = (src.file.as_str(), src.text.as_str());
    let raw = src.raw(overrides)?;
    let (axes, reference) = axes(file, &raw)?;
    // The length of each dimension: its fields' (equal) list length.
    let mut lengths: Vec<usize> = Vec::new();
    for a in &axes {
        if a.dimension == lengths.len() {
            lengths.push(a.values.len());
        }
    }
    let total = lengths
        .iter()
        .try_fold(1usize, |n, &k| n.checked_mul(k))
        .unwrap_or(usize::MAX);
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
        // Last dimension fastest.
        let mut idx = vec![0; lengths.len()];
        for (d, &n) in lengths.iter().enumerate().rev() {
            idx[d] = rem % n;
            rem /= n;
        }
        let mut doc = base_value.clone();
        for a in &axes {
            let x = a.values[idx[a.dimension]];
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
    let reference = reference_point(file, reference.as_ref(), &points)?;
    Ok(Plan {
        axes,
        points,
        reference,
    })
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
