//! The per-sample rows: which columns a scene has, their types, and the
//! rows of a batch, column-major at their native width (an f32 run keeps
//! f32 values, integers their narrowest exact type). The batch bodies fill
//! them (`engine`'s contact blocks and drop walks). [`super::parquet`] writes them.

use std::sync::Arc;

use super::columns::{Column, Field, RowLayout};
use crate::config::{Precision, Sampling, Scene};

/// Which per-sample columns to write.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// All float and all integer columns, in row order.
    floats: Vec<Column>,
    ints: Vec<Column>,
    keep_float: Vec<bool>,
    keep_int: Vec<bool>,
    /// A drop scene's law names, for its `law` column.
    laws: Vec<String>,
    /// The float columns' type.
    precision: Precision,
    /// An RQMC run's points per replicate, as a power of two: its rows
    /// have a `replicate` key (`sample >> log2`).
    replicate_log2: Option<u32>,
}

impl Selection {
    /// `wanted = None` keeps every column; otherwise only the named ones
    /// (`sample`, the key, is always kept). Unknown names are an error that
    /// lists the available columns.
    pub fn new(
        floats: Vec<Column>,
        ints: Vec<Column>,
        precision: Precision,
        wanted: Option<&[String]>,
    ) -> Result<Self, String> {
        let keep = |names: &mut dyn Iterator<Item = &String>| -> Vec<bool> {
            names
                .map(|n| wanted.is_none_or(|w| w.iter().any(|x| x == n)))
                .collect()
        };
        if let Some(w) = wanted {
            for name in w {
                if name != "sample" && !floats.iter().chain(&ints).any(|c| &c.name == name) {
                    let mut all = vec!["sample".to_string()];
                    all.extend(floats.iter().chain(&ints).map(|c| c.name.clone()));
                    return Err(format!(
                        "unknown per-sample column {name:?}; available: {}",
                        all.join(", ")
                    ));
                }
            }
        }
        Ok(Self {
            keep_float: keep(&mut floats.iter().map(|c| &c.name)),
            keep_int: keep(&mut ints.iter().map(|c| &c.name)),
            floats,
            ints,
            laws: Vec::new(),
            precision,
            replicate_log2: None,
        })
    }

    /// The per-sample selection of a scene: the columns of its
    /// [`RowLayout`], with its `law` key where rows are per law.
    pub fn of_scene(scene: &Scene, wanted: Option<&[String]>) -> Result<Self, String> {
        let RowLayout {
            floats,
            ints,
            precision,
            laws,
        } = RowLayout::of(scene);
        let replicate_log2 = match scene.sampling() {
            Sampling::Mc => None,
            Sampling::Rqmc { log2_points, .. } => Some(log2_points),
        };
        // `law`, like `sample`, is a key of rows per law, and `replicate`
        // of an RQMC run's rows: always kept.
        let wanted: Option<Vec<String>> = wanted.map(|w| {
            w.iter()
                .filter(|c| laws.is_empty() || *c != "law")
                .filter(|c| replicate_log2.is_none() || *c != "replicate")
                .cloned()
                .collect()
        });
        let mut s = Self::new(floats, ints, precision, wanted.as_deref())?;
        s.laws = laws;
        s.replicate_log2 = replicate_log2;
        Ok(s)
    }

    /// The kept float columns: (index in the rows, column).
    pub fn floats(&self) -> impl Iterator<Item = (usize, &Column)> {
        self.floats
            .iter()
            .zip(&self.keep_float)
            .enumerate()
            .filter(|(_, (_, k))| **k)
            .map(|(i, (c, _))| (i, c))
    }

    /// The kept integer columns: (index in the rows, column).
    pub fn ints(&self) -> impl Iterator<Item = (usize, &Column)> {
        self.ints
            .iter()
            .zip(&self.keep_int)
            .enumerate()
            .filter(|(_, (_, k))| **k)
            .map(|(i, (c, _))| (i, c))
    }

    /// Per float column of [`RowLayout`], whether it is kept (for
    /// [`SampleRows::fill_only`]).
    pub fn float_mask(&self) -> &[bool] {
        &self.keep_float
    }

    /// An RQMC run's points per replicate as a power of two: its rows'
    /// `replicate` is `sample >> log2`.
    pub fn replicate_log2(&self) -> Option<u32> {
        self.replicate_log2
    }

    /// A drop scene's law names (empty for a contact scene).
    pub fn laws(&self) -> &[String] {
        &self.laws
    }

    /// The float columns' type.
    pub fn precision(&self) -> Precision {
        self.precision
    }
}

/// Float columns at one precision.
#[derive(Debug, Clone)]
pub enum Floats {
    F32(Vec<Vec<f32>>),
    F64(Vec<Vec<f64>>),
}

impl Floats {
    fn new(precision: Precision, columns: usize) -> Self {
        match precision {
            Precision::F32 => Floats::F32(vec![Vec::new(); columns]),
            Precision::F64 => Floats::F64(vec![Vec::new(); columns]),
        }
    }

    /// Appends to column `k`. An f32 column stores the values rounded to
    /// f32: the engine's f32 values come back exactly, and a quotient of
    /// two of them, formed in f64 and rounded once, is their f32 quotient.
    fn extend(&mut self, k: usize, values: impl Iterator<Item = f64>) {
        match self {
            Floats::F32(c) => c[k].extend(values.map(|v| v as f32)),
            Floats::F64(c) => c[k].extend(values),
        }
    }
}

/// Per-sample rows of one batch, column-major, in sample order (the columns
/// of the [`RowLayout`]).
#[derive(Debug, Clone)]
pub struct SampleRows {
    pub index: Vec<u64>,
    /// A drop scene's law per row (index into the scene's laws); empty for
    /// a contact scene.
    pub law: Vec<u32>,
    pub floats: Floats,
    /// Integer columns; each value fits its column's [`Kind`](super::columns::Kind).
    pub ints: Vec<Vec<u16>>,
    /// Which float columns are filled (the others stay empty: a selection
    /// that leaves them out costs nothing for them).
    filled: Arc<[bool]>,
    /// What each float and each integer column holds, from the layout.
    float_fields: Arc<[Field]>,
    int_fields: Arc<[Field]>,
}

impl SampleRows {
    /// Empty rows for the columns of a layout.
    pub fn of_layout(l: &RowLayout) -> Self {
        Self {
            index: Vec::new(),
            law: Vec::new(),
            floats: Floats::new(l.precision, l.floats.len()),
            ints: vec![Vec::new(); l.ints.len()],
            filled: vec![true; l.floats.len()].into(),
            float_fields: l.floats.iter().map(|c| c.field).collect(),
            int_fields: l.ints.iter().map(|c| c.field).collect(),
        }
    }

    /// Fills only the float columns marked true (by position in
    /// [`RowLayout`]).
    pub fn fill_only(&mut self, filled: &[bool]) {
        assert_eq!(filled.len(), self.filled.len(), "one flag per float column");
        self.filled = filled.into();
    }

    /// Empty rows for a scene's columns.
    pub fn of_scene(scene: &Scene) -> Self {
        Self::of_layout(&RowLayout::of(scene))
    }

    /// Reserves room for `rows` more rows in every column (one allocation
    /// per column instead of a doubling series of copies).
    pub fn reserve(&mut self, rows: usize) {
        self.index.reserve(rows);
        let filled = self.filled.iter();
        match &mut self.floats {
            Floats::F32(c) => c
                .iter_mut()
                .zip(filled)
                .for_each(|(c, f)| c.reserve(rows * *f as usize)),
            Floats::F64(c) => c
                .iter_mut()
                .zip(filled)
                .for_each(|(c, f)| c.reserve(rows * *f as usize)),
        }
        self.ints.iter_mut().for_each(|c| c.reserve(rows));
    }

    pub fn len(&self) -> usize {
        self.index.len()
    }

    /// What each float column holds, in row order: what a batch body
    /// fills them with (see [`SampleRows::put`]).
    pub fn float_fields(&self) -> Arc<[Field]> {
        self.float_fields.clone()
    }

    /// What each integer column holds, in row order.
    pub fn int_fields(&self) -> Arc<[Field]> {
        self.int_fields.clone()
    }

    /// Appends `values` to float column `k`, if it is filled (otherwise the
    /// values are never computed).
    #[inline]
    pub fn put(&mut self, k: usize, values: impl Iterator<Item = f64>) {
        if self.filled[k] {
            self.floats.extend(k, values);
        }
    }

    /// Whether any of the float columns holding one of `fields` is filled.
    pub fn fills_any(&self, fields: impl Fn(Field) -> bool) -> bool {
        self.float_fields
            .iter()
            .zip(self.filled.iter())
            .any(|(f, on)| *on && fields(*f))
    }

    pub fn is_empty(&self) -> bool {
        self.index.is_empty()
    }

    /// Fills every column with `n` made-up values (for the writer's tests).
    #[cfg(test)]
    pub(crate) fn push_test_columns(&mut self, n: usize) {
        let k = match &self.floats {
            Floats::F32(c) => c.len(),
            Floats::F64(c) => c.len(),
        };
        for c in 0..k {
            self.floats
                .extend(c, (0..n).map(|i| (i * (c + 1)) as f64 * 0.5));
        }
        for c in &mut self.ints {
            c.extend((0..n).map(|i| (i % 7) as u16));
        }
    }
}
