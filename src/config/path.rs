//! Dotted field paths into a scene's TOML, one set of rules for every
//! front end (a sweep's axes, the Python package's `Scene.replace`):
//! `body.mass`; `planes.floor.restitution`, an element of an array of
//! tables by its `name`; `body.semi_axes[2]` and `planes[1].offset`, by
//! index.

/// One segment: a key, and an index into the array it names.
fn segment(seg: &str) -> Result<(&str, Option<usize>), String> {
    if seg.is_empty() {
        return Err("an empty segment".into());
    }
    match seg.find('[') {
        Some(b) if seg.ends_with(']') => {
            let i = seg[b + 1..seg.len() - 1]
                .parse()
                .map_err(|_| format!("bad index in {seg:?}"))?;
            Ok((&seg[..b], Some(i)))
        }
        _ => Ok((seg, None)),
    }
}

/// The value under `key` of a table, or the element of an array of tables
/// whose `name` is `key`; `None` where a table has no such key.
fn child<'a>(cur: &'a mut toml::Value, key: &str) -> Result<Option<&'a mut toml::Value>, String> {
    match cur {
        toml::Value::Table(t) => Ok(t.get_mut(key)),
        toml::Value::Array(a) => a
            .iter_mut()
            .find(|v| v.get("name").and_then(|n| n.as_str()) == Some(key))
            .map(Some)
            .ok_or_else(|| format!("no element named {key:?}")),
        _ => Err(format!("{key:?} is not a table")),
    }
}

/// Element `i` of an array.
fn element<'a>(v: &'a mut toml::Value, key: &str, i: usize) -> Result<&'a mut toml::Value, String> {
    v.as_array_mut()
        .ok_or_else(|| format!("{key:?} is not an array"))?
        .get_mut(i)
        .ok_or_else(|| format!("index {i} out of range in {key:?}"))
}

/// The value at `path`, if it is there.
pub fn get<'a>(
    root: &'a mut toml::Value,
    path: &str,
) -> Result<Option<&'a mut toml::Value>, String> {
    let mut cur = root;
    for seg in path.split('.') {
        let (key, index) = segment(seg)?;
        let Some(next) = child(cur, key)? else {
            return Ok(None);
        };
        cur = match index {
            Some(i) => element(next, key, i)?,
            None => next,
        };
    }
    Ok(Some(cur))
}

/// Sets `value` at `path`. Tables on the way that are absent are made; a
/// table given where a table is merges into it key by key (each key by
/// these rules), anything else replaces. An element of an array must be
/// there (by name or index).
pub fn set(root: &mut toml::Value, path: &str, value: toml::Value) -> Result<(), String> {
    let segments: Vec<&str> = path.split('.').collect();
    let mut cur = root;
    for (si, seg) in segments.iter().enumerate() {
        let (key, index) = segment(seg)?;
        let last = si + 1 == segments.len();
        if child(cur, key)?.is_none() {
            let toml::Value::Table(t) = cur else {
                unreachable!("only a table lacks a key")
            };
            if last && index.is_none() {
                t.insert(key.into(), value);
                return Ok(());
            }
            if index.is_some() {
                return Err(format!("no field {key:?}"));
            }
            t.insert(key.into(), toml::Value::Table(toml::Table::new()));
        }
        let next = child(cur, key)?.expect("present");
        let next = match index {
            Some(i) => element(next, key, i)?,
            None => next,
        };
        if last {
            match value {
                toml::Value::Table(new) if next.is_table() => {
                    for (k, v) in new {
                        set(next, &k, v)?;
                    }
                }
                value => *next = value,
            }
            return Ok(());
        }
        cur = next;
    }
    Err(format!("empty path {path:?}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> toml::Value {
        toml::from_str(
            r#"
            samples = 10
            [body]
            semi_axes = [1.0, 2.0, 3.0]
            mass = 2
            [[planes]]
            name = "floor"
            restitution = 0.5
            [[planes]]
            name = "wall"
            restitution = 0.7
            "#,
        )
        .unwrap()
    }

    #[test]
    fn paths_reach_keys_names_and_indices() {
        let mut v = scene();
        set(&mut v, "planes.floor.restitution", 0.2.into()).unwrap();
        set(&mut v, "planes[1].restitution", 0.3.into()).unwrap();
        set(&mut v, "body.semi_axes[2]", 4.0.into()).unwrap();
        set(&mut v, "output.per_sample", true.into()).unwrap();
        assert_eq!(v["planes"][0]["restitution"].as_float(), Some(0.2));
        assert_eq!(v["planes"][1]["restitution"].as_float(), Some(0.3));
        assert_eq!(v["body"]["semi_axes"][2].as_float(), Some(4.0));
        assert_eq!(v["output"]["per_sample"].as_bool(), Some(true));
        assert_eq!(
            get(&mut v, "planes.wall.name").unwrap().unwrap().as_str(),
            Some("wall")
        );
        assert!(get(&mut v, "body.colour").unwrap().is_none());
    }

    #[test]
    fn tables_merge_and_elements_must_exist() {
        let mut v = scene();
        let new: toml::Value = toml::from_str("mass = 3.0").unwrap();
        set(&mut v, "body", new).unwrap();
        assert_eq!(v["body"]["mass"].as_float(), Some(3.0));
        assert_eq!(v["body"]["semi_axes"][0].as_float(), Some(1.0));
        assert!(set(&mut v, "planes.ceiling.restitution", 0.1.into()).is_err());
        assert!(set(&mut v, "planes[5].restitution", 0.1.into()).is_err());
        assert!(set(&mut v, "samples.x", 1.into()).is_err());
        assert!(set(&mut v, "body..mass", 1.into()).is_err());
    }
}
