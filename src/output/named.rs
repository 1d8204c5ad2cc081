//! [`Named`]: values by name in insertion order, serialised as a JSON
//! object (keys that are data: plane names, active sets, laws), with typed
//! values; JSON's `null` reads back through [`FromNull`].

use serde::{Deserialize, Serialize};

/// What a null in a [`Named`] reads as: NaN for numbers, an error for
/// anything else.
pub trait FromNull: Sized {
    fn from_null() -> Option<Self> {
        None
    }
}
impl FromNull for f64 {
    fn from_null() -> Option<Self> {
        Some(f64::NAN)
    }
}
/// Values by name, in the order they were added: a JSON object whose keys
/// are data (plane names, active sets, laws), with typed values.
#[derive(Debug, Clone, PartialEq)]
pub struct Named<T>(pub Vec<(String, T)>);

impl<T> Default for Named<T> {
    fn default() -> Self {
        Self(Vec::new())
    }
}

impl<T> Named<T> {
    pub fn insert(&mut self, name: impl Into<String>, value: T) {
        self.0.push((name.into(), value));
    }
    /// Replaces `name`'s value, or inserts it last.
    pub fn set(&mut self, name: &str, value: T) {
        match self.0.iter_mut().find(|(k, _)| k == name) {
            Some((_, v)) => *v = value,
            None => self.insert(name, value),
        }
    }
    pub fn get(&self, name: &str) -> Option<&T> {
        self.0.iter().find(|(k, _)| k == name).map(|(_, v)| v)
    }
    pub fn contains_key(&self, name: &str) -> bool {
        self.get(name).is_some()
    }
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
    pub fn iter(&self) -> impl Iterator<Item = (&String, &T)> {
        self.0.iter().map(|(k, v)| (k, v))
    }
    pub fn keys(&self) -> impl Iterator<Item = &String> {
        self.0.iter().map(|(k, _)| k)
    }
}

impl<'de, T: Deserialize<'de> + FromNull> Deserialize<'de> for Named<T> {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Entries<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de> + FromNull> serde::de::Visitor<'de> for Entries<T> {
            type Value = Named<T>;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<Named<T>, A::Error> {
                let mut out = Vec::new();
                while let Some((k, v)) = m.next_entry::<String, Option<T>>()? {
                    let v = v.or_else(T::from_null).ok_or_else(|| {
                        serde::de::Error::custom(format!("{k}: null where a value is needed"))
                    })?;
                    out.push((k, v));
                }
                Ok(Named(out))
            }
        }
        d.deserialize_map(Entries(std::marker::PhantomData))
    }
}

impl<T> std::ops::Index<&str> for Named<T> {
    type Output = T;
    fn index(&self, name: &str) -> &T {
        self.get(name)
            .unwrap_or_else(|| panic!("no entry named {name:?}"))
    }
}

impl<T: Serialize> Serialize for Named<T> {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        for (k, v) in &self.0 {
            m.serialize_entry(k, v)?;
        }
        m.end()
    }
}
