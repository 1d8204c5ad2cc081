//! The per-sample rows: which columns a scene has, their types, and the
//! rows of a batch, column-major at their native width (an f32 run keeps
//! f32 values, integers their narrowest exact type). The batch bodies fill
//! them (`engine`'s contact blocks and drop walks). [`super::parquet`] writes them.

use crate::config::{Placement, Precision, Sampling, Scene};

/// The width of an integer column: every value the column can take fits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntWidth {
    U8,
    U16,
}

/// An integer column after `sample`.
#[derive(Debug, Clone, PartialEq)]
pub struct IntColumn {
    pub name: String,
    pub width: IntWidth,
}

impl IntColumn {
    fn new(name: impl Into<String>, width: IntWidth) -> Self {
        Self {
            name: name.into(),
            width,
        }
    }
}

/// Which per-sample columns to write.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// All float column names and all integer columns, in engine order.
    floats: Vec<String>,
    ints: Vec<IntColumn>,
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
        floats: Vec<String>,
        ints: Vec<IntColumn>,
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
                if name != "sample"
                    && !floats.contains(name)
                    && !ints.iter().any(|c| &c.name == name)
                {
                    let mut all = vec!["sample".to_string()];
                    all.extend(floats.iter().cloned());
                    all.extend(ints.iter().map(|c| c.name.clone()));
                    return Err(format!(
                        "unknown per-sample column {name:?}; available: {}",
                        all.join(", ")
                    ));
                }
            }
        }
        Ok(Self {
            keep_float: keep(&mut floats.iter()),
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

    /// The kept float columns: (index in the rows, name).
    pub fn floats(&self) -> impl Iterator<Item = (usize, &str)> {
        self.floats
            .iter()
            .zip(&self.keep_float)
            .enumerate()
            .filter(|(_, (_, k))| **k)
            .map(|(i, (n, _))| (i, n.as_str()))
    }

    /// The kept integer columns: (index in the rows, column).
    pub fn ints(&self) -> impl Iterator<Item = (usize, &IntColumn)> {
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

/// The shape of a scene's per-sample rows, by the batch body its placement
/// chooses: at contact one row per sample with columns per law, in the
/// kernel's precision; in a drop one row per impact keyed by `sample`,
/// `law` and `bounce`, in f64 (the drop body runs the f64 reference).
#[derive(Debug, Clone, PartialEq)]
pub struct RowLayout {
    /// Float column names and integer columns after the keys, in row order.
    pub floats: Vec<String>,
    pub ints: Vec<IntColumn>,
    /// The float columns' type.
    pub precision: Precision,
    /// Rows per law: the names the `law` key takes (empty: one row per
    /// sample).
    pub laws: Vec<String>,
}

impl RowLayout {
    pub fn of(scene: &Scene) -> Self {
        match scene.placement() {
            Placement::Contact(_) => {
                let (floats, ints) = contact_columns(scene);
                Self {
                    floats,
                    ints,
                    precision: scene.precision(),
                    laws: Vec::new(),
                }
            }
            Placement::Drop(_) => {
                let (floats, ints) = drop_columns(scene);
                Self {
                    floats,
                    ints,
                    precision: Precision::F64,
                    laws: scene.laws().iter().map(|l| l.name()).collect(),
                }
            }
        }
    }
}

/// The unit of a per-sample float column, from its name (the key-value
/// metadata `impactmc.units` of `samples.parquet`).
pub fn unit_of(column: &str) -> &'static str {
    const UNITS: [(&str, &str); 13] = [
        ("tangential_impulse_", "N·s"),
        ("sliding_speed_", "m/s"),
        ("q_", "1"),
        ("energy_ratio", "1"),
        ("energy_", "J"),
        ("omega_", "rad/s"),
        ("vn_", "m/s"),
        ("v_", "m/s"),
        ("impulse_", "N·s"),
        ("time", "s"),
        ("interval", "s"),
        ("centre_", "m"),
        ("distance_", "m"),
    ];
    UNITS
        .iter()
        .find(|(prefix, _)| column.starts_with(prefix))
        .map_or("", |(_, unit)| unit)
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

/// Fills float columns one after the other, in the order of the
/// [`RowLayout`] (those not filled are skipped, their values never
/// computed): what a batch body writes its rows with.
pub struct Columns<'a> {
    floats: &'a mut Floats,
    filled: &'a [bool],
    next: usize,
}

impl Columns<'_> {
    /// Appends `values` to the next float column.
    pub fn put(&mut self, values: impl Iterator<Item = f64>) {
        if self.filled[self.next] {
            self.floats.extend(self.next, values);
        }
        self.next += 1;
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
    /// Integer columns; each value fits its column's [`IntWidth`].
    pub ints: Vec<Vec<u16>>,
    /// Which float columns are filled (the others stay empty: a selection
    /// that leaves them out costs nothing for them).
    filled: std::sync::Arc<[bool]>,
}

impl SampleRows {
    pub fn new(precision: Precision, floats: usize, ints: usize) -> Self {
        Self {
            index: Vec::new(),
            law: Vec::new(),
            floats: Floats::new(precision, floats),
            ints: vec![Vec::new(); ints],
            filled: vec![true; floats].into(),
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
        let l = RowLayout::of(scene);
        Self::new(l.precision, l.floats.len(), l.ints.len())
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

    /// The float columns, to be filled in order with [`Columns::put`].
    pub fn columns(&mut self) -> Columns<'_> {
        Columns {
            floats: &mut self.floats,
            filled: &self.filled,
            next: 0,
        }
    }

    /// Whether float column `k` is filled.
    pub fn is_filled(&self, k: usize) -> bool {
        self.filled[k]
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

/// The per-sample columns after `sample` (u64): the float columns, then the
/// integer columns. Units: m/s, rad/s, J, N·s; `active_LAW` (u8) is the
/// active-set bitmask over the touching planes in scene order, `flags_LAW`
/// (u16) the kernel status bits (see the reference). A scene with friction
/// adds per law and touching plane `tangential_impulse_LAW_PLANE` (|f_i|,
/// N·s) and `sliding_speed_LAW_PLANE` (|c⁺_t,i|, m/s), and per law
/// `sticking_LAW` (u8, bit i: the i-th touching plane ended sticking) and
/// `friction_flags_LAW` (u8: bit 0 ambiguous, bit 1 unconverged).
fn contact_columns(scene: &Scene) -> (Vec<String>, Vec<IntColumn>) {
    let planes: Vec<&str> = scene
        .touching()
        .iter()
        .map(|&i| scene.planes()[i].name.as_str())
        .collect();
    let mut f: Vec<String> = [
        "q_w",
        "q_x",
        "q_y",
        "q_z",
        "v_x",
        "v_y",
        "v_z",
        "omega_x",
        "omega_y",
        "omega_z",
        "energy_before",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    f.extend(planes.iter().map(|p| format!("vn_before_{p}")));
    let mut ints = Vec::new();
    let friction = scene.effects().friction;
    for law in scene.laws() {
        let l = law.name();
        f.push(format!("energy_after_{l}"));
        f.push(format!("energy_ratio_{l}"));
        for c in ["x", "y", "z"] {
            f.push(format!("v_after_{c}_{l}"));
        }
        for c in ["x", "y", "z"] {
            f.push(format!("omega_after_{c}_{l}"));
        }
        f.extend(planes.iter().map(|p| format!("impulse_{l}_{p}")));
        f.extend(planes.iter().map(|p| format!("vn_after_{l}_{p}")));
        if friction {
            f.extend(planes.iter().map(|p| format!("tangential_impulse_{l}_{p}")));
            f.extend(planes.iter().map(|p| format!("sliding_speed_{l}_{p}")));
        }
        ints.push(IntColumn::new(format!("active_{l}"), IntWidth::U8));
        ints.push(IntColumn::new(format!("flags_{l}"), IntWidth::U16));
        if friction {
            ints.push(IntColumn::new(format!("sticking_{l}"), IntWidth::U8));
            ints.push(IntColumn::new(format!("friction_flags_{l}"), IntWidth::U8));
        }
    }
    (f, ints)
}

/// A drop scene's per-impact columns after `sample` (u64) and `law` (str):
/// the f64 columns, then the integer columns. At the moment of impact: `time`
/// since release and `interval` since the previous impact (s), the centre
/// (m), the orientation (unit quaternion body → world, w ≥ 0), v (world,
/// m/s) and ω (body, rad/s) before and after, the energies (J), and per
/// plane its distance (m), normal velocity before and after (m/s) and
/// impulse (N·s). `bounce` (u16) counts impacts from 1, `planes` (u8) is the
/// bitmask of the planes that took an impulse (scene order, at most six),
/// `flags` (u16) the kernel's status bits for energy_gain, degenerate,
/// jammed and unsolved.
pub fn drop_columns(scene: &Scene) -> (Vec<String>, Vec<IntColumn>) {
    let mut f: Vec<String> = [
        "time",
        "interval",
        "centre_x",
        "centre_y",
        "centre_z",
        "q_w",
        "q_x",
        "q_y",
        "q_z",
        "v_x",
        "v_y",
        "v_z",
        "omega_x",
        "omega_y",
        "omega_z",
        "energy_before",
        "energy_after",
        "energy_ratio",
        "v_after_x",
        "v_after_y",
        "v_after_z",
        "omega_after_x",
        "omega_after_y",
        "omega_after_z",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    for p in scene.planes() {
        for c in ["distance", "vn_before", "vn_after", "impulse"] {
            f.push(format!("{c}_{}", p.name));
        }
    }
    let ints = vec![
        IntColumn::new("bounce", IntWidth::U16),
        IntColumn::new("planes", IntWidth::U8),
        IntColumn::new("flags", IntWidth::U16),
    ];
    (f, ints)
}
