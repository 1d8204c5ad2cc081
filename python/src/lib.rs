//! impactmc's Python extension module, `impactmc._impactmc`: scenes, runs
//! and their tables as Python objects. Planning, validation, the engine and
//! every error's words are the library's; this crate converts between the
//! two languages and keeps Python responsive while a run goes on (the run
//! works on its own threads, the calling thread waits without the GIL and
//! wakes every 100 ms for Ctrl-C and the progress callback).

use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc};
use std::time::Duration;

use arrow_array::ffi_stream::FFI_ArrowArrayStream;
use arrow_array::RecordBatchIterator;
use pyo3::create_exception;
use pyo3::exceptions::{PyFileExistsError, PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyCapsule;

use impactmc::accuracy::{LadderError, Steps};
use impactmc::config::case::solve_text;
use impactmc::config::sweep::plan_text;
use impactmc::config::{Overrides, SceneError, SceneText};
use impactmc::engine::{RunError, RunOptions, Watch};
use impactmc::output::arrow::ArrowTable;
use impactmc::output::{prepare_dir, OutputError};
use impactmc::stats::tree::Shard;
use impactmc::study::{self, message_chain, Study, StudyError};

create_exception!(
    _impactmc,
    InputError,
    PyValueError,
    "Input impactmc refuses, with the command line's message: `.field`, \
     `.file` and `.line` say where (each None when it does not apply)."
);
create_exception!(
    _impactmc,
    OutputExistsError,
    PyFileExistsError,
    "The output folder already holds a run (pass force=True to overwrite it)."
);

/// An `InputError` with its message and where it points.
fn input_error(
    message: String,
    field: Option<&str>,
    file: Option<&str>,
    line: Option<usize>,
) -> PyErr {
    Python::attach(|py| {
        let err = InputError::new_err(message);
        let value = err.value(py);
        let set = || -> PyResult<()> {
            value.setattr("field", field)?;
            value.setattr("file", file)?;
            value.setattr("line", line)?;
            Ok(())
        };
        match set() {
            Ok(()) => err,
            Err(e) => e,
        }
    })
}

fn scene_error(e: SceneError) -> PyErr {
    let message = e.to_string();
    input_error(message, Some(&e.field), Some(&e.file), e.line)
}

fn output_error(e: OutputError, field: &str) -> PyErr {
    match e {
        OutputError::Exists(_) => OutputExistsError::new_err(message_chain(&e)),
        _ => input_error(message_chain(&e), Some(field), None, None),
    }
}

fn study_error(e: StudyError) -> PyErr {
    match e {
        StudyError::Scene(e) => scene_error(e),
        StudyError::Run(RunError::Cancelled) => PyRuntimeError::new_err("the run was cancelled"),
        StudyError::Output(OutputError::Exists(_)) => OutputExistsError::new_err(message_chain(&e)),
        e if e.is_bad_input() => input_error(message_chain(&e), None, None, None),
        e => PyRuntimeError::new_err(message_chain(&e)),
    }
}

/// One impact case solved, as the JSON text `impactmc solve` prints.
/// `json`: the text's format (None: JSON when it starts with `{`).
#[pyfunction]
#[pyo3(signature = (name, text, json=None))]
fn _solve(py: Python<'_>, name: &str, text: &str, json: Option<bool>) -> PyResult<String> {
    let out = py
        .detach(|| solve_text(name, text, json))
        .map_err(|e| input_error(e.to_string(), e.field.as_deref(), Some(&e.name), None))?;
    serde_json::to_string(&out).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// A finished run folder read back, as `impactmc inspect` reads it:
/// (manifest JSON, summary JSON, text).
#[pyfunction]
fn _inspect(py: Python<'_>, folder: PathBuf) -> PyResult<(String, String, String)> {
    let seen = py
        .detach(|| impactmc::output::manifest::inspect(&folder))
        .map_err(|m| input_error(m, None, Some(&folder.display().to_string()), None))?;
    Ok((
        seen.manifest.to_string(),
        seen.summary.to_string(),
        seen.text,
    ))
}

/// Runs `work` on its own thread while this thread waits without the GIL,
/// waking about every 100 ms to check for Ctrl-C and to call
/// `callback(done, total)` with the watch's counts (once the work has said
/// its total, and once more at the end). Ctrl-C, or an exception in the callback, cancels the work
/// through the watch; this waits for it to stop, then raises that.
fn watched<T: Send + 'static>(
    py: Python<'_>,
    watch: &Watch,
    callback: Option<&Py<PyAny>>,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let (tx, rx) = mpsc::channel();
    // Waited on without the GIL, which asks for Sync.
    let rx = std::sync::Mutex::new(rx);
    let wait = |timeout: Option<Duration>| {
        let rx = rx.lock().expect("one waiter");
        match timeout {
            Some(t) => rx.recv_timeout(t),
            None => rx.recv().map_err(|_| mpsc::RecvTimeoutError::Disconnected),
        }
    };
    let worker = std::thread::Builder::new()
        .name("impactmc-work".into())
        .spawn(move || {
            let _ = tx.send(work());
        })
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    let finish = |py: Python<'_>| {
        let _ = py.detach(|| worker.join());
    };
    loop {
        match py.detach(|| wait(Some(Duration::from_millis(100)))) {
            Ok(out) => {
                finish(py);
                // The last count, so that a bar ends where the work did.
                if let Some(cb) = callback.filter(|_| watch.total() > 0) {
                    cb.call1(py, (watch.done(), watch.total()))?;
                }
                return Ok(out);
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                finish(py);
                return Err(PyRuntimeError::new_err(
                    "the work's thread ended without a result",
                ));
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
        }
        let checked = py.check_signals().and_then(|()| match callback {
            Some(cb) if watch.total() > 0 => {
                cb.call1(py, (watch.done(), watch.total())).map(|_| ())
            }
            _ => Ok(()),
        });
        if let Err(e) = checked {
            watch.cancel();
            // The work stops at its next check; nothing is written.
            let _ = py.detach(|| wait(None));
            finish(py);
            return Err(e);
        }
    }
}

/// Shard folders merged into the run folder `out`, as `impactmc merge`.
/// `callback(done, total)` counts the shards read.
#[pyfunction]
#[pyo3(signature = (shards, out, force=false, allow_partial=false, callback=None))]
fn _merge(
    py: Python<'_>,
    shards: Vec<PathBuf>,
    out: PathBuf,
    force: bool,
    allow_partial: bool,
    callback: Option<Py<PyAny>>,
) -> PyResult<PyResult_> {
    prepare_dir(&out, force).map_err(|e| output_error(e, "out"))?;
    let watch = Watch::new();
    let w = watch.clone();
    let study = watched(py, &watch, callback.as_ref(), move || {
        let mut s = study::merge_study(&shards, allow_partial, &out, Some(&w))?;
        s.write()?;
        Ok::<_, StudyError>(s)
    })?
    .map_err(study_error)?;
    Ok(PyResult_::whole(study))
}

/// The accuracy ladder of a scene (its `[accuracy]` knobs), written as a
/// folder as `impactmc accuracy` writes it; returns the markdown.
/// `callback(done, total)` counts the ladder's steps.
#[pyfunction]
#[pyo3(signature = (scene, out, force=false, callback=None))]
fn _accuracy(
    py: Python<'_>,
    scene: &PyScene,
    out: PathBuf,
    force: bool,
    callback: Option<Py<PyAny>>,
) -> PyResult<String> {
    let src = scene.src.clone();
    let base = src.scene(&Overrides::default()).map_err(scene_error)?;
    impactmc::accuracy::Knobs::from_raw(&src.file, base.raw()).map_err(scene_error)?;
    prepare_dir(&out, force).map_err(|e| output_error(e, "out"))?;
    let watch = Watch::new();
    let w = watch.clone();
    watched(py, &watch, callback.as_ref(), move || {
        let mut quiet = |_: &str| {};
        let ladder =
            match impactmc::accuracy::ladder_of(&src, &mut Steps::new(&mut quiet, Some(&w))) {
                Ok(l) => l,
                Err(LadderError::Scene(e)) => return Err(scene_error(e)),
                Err(LadderError::Cancelled) => {
                    return Err(PyRuntimeError::new_err("the accuracy ladder was cancelled"))
                }
            };
        impactmc::accuracy::write_folder(&ladder, Path::new(&src.file), &out)
            .map_err(|e| PyRuntimeError::new_err(message_chain(&e)))
    })?
}

/// A scene: its TOML text, validated (every sweep point) when made.
#[pyclass(module = "impactmc._impactmc", frozen, name = "Scene")]
struct PyScene {
    src: SceneText,
    name: String,
    effects: String,
    kernel: String,
}

impl PyScene {
    fn new(src: SceneText) -> PyResult<Self> {
        let prepared = study::prepare(&src, &Overrides::default(), &RunOptions::default())
            .map_err(study_error)?;
        Ok(Self {
            src,
            name: prepared.name,
            effects: prepared.effects_line,
            kernel: prepared.kernel_line,
        })
    }
}

/// A JSON value as a TOML value. TOML has no null; a non-finite float,
/// which JSON cannot hold, comes as `{"$float": "nan" | "inf" | "-inf"}`
/// (the Python layer's encoding).
fn toml_value(v: serde_json::Value) -> Result<toml::Value, String> {
    use serde_json::Value as J;
    Ok(match v {
        J::Null => return Err("None has no TOML form".into()),
        J::Bool(b) => toml::Value::Boolean(b),
        J::Number(n) => match (n.as_i64(), n.as_f64()) {
            (Some(i), _) => toml::Value::Integer(i),
            (None, Some(x)) => toml::Value::Float(x),
            _ => return Err(format!("{n} is out of range")),
        },
        J::String(s) => toml::Value::String(s),
        J::Array(a) => toml::Value::Array(a.into_iter().map(toml_value).collect::<Result<_, _>>()?),
        J::Object(o) => {
            if let (1, Some(J::String(x))) = (o.len(), o.get("$float")) {
                let x = match x.as_str() {
                    "nan" => f64::NAN,
                    "inf" => f64::INFINITY,
                    "-inf" => f64::NEG_INFINITY,
                    _ => return Err(format!("{x:?} is not a float")),
                };
                return Ok(toml::Value::Float(x));
            }
            let mut t = toml::Table::new();
            for (k, v) in o {
                t.insert(k, toml_value(v)?);
            }
            toml::Value::Table(t)
        }
    })
}

/// A JSON object as a TOML table.
fn toml_of_json(json: &str, what: &str) -> PyResult<toml::Table> {
    let value: serde_json::Value = serde_json::from_str(json)
        .map_err(|e| input_error(format!("{what}: {e}"), None, None, None))?;
    match toml_value(value) {
        Ok(toml::Value::Table(t)) => Ok(t),
        Ok(_) => Err(input_error(
            format!("{what}: not a table"),
            None,
            None,
            None,
        )),
        Err(m) => Err(input_error(format!("{what}: {m}"), None, None, None)),
    }
}

#[pymethods]
impl PyScene {
    /// A scene file.
    #[staticmethod]
    fn from_toml(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let src = py.detach(|| SceneText::read(&path)).map_err(scene_error)?;
        Self::new(src)
    }

    /// Scene TOML text; errors name it `<string>`.
    #[staticmethod]
    fn from_str(text: &str) -> PyResult<Self> {
        Self::new(SceneText::new("<string>", text))
    }

    /// A scene given as JSON text of the TOML's tables (the Python layer's
    /// `from_dict`); errors name it `<dict>`.
    #[staticmethod]
    fn _from_json(json: &str) -> PyResult<Self> {
        let table = toml_of_json(json, "<dict>")?;
        let text = toml::to_string(&table).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Self::new(SceneText::new("<dict>", text))
    }

    /// The scene with fields replaced: a JSON object of dotted field paths
    /// (`samples`, `body.mass`, `planes.floor.restitution`, `planes`) and
    /// values, by the rules of a sweep's paths (`config::path`); tables
    /// merge into tables. Errors name the scene `<replaced>`.
    fn _replace(&self, json: &str) -> PyResult<Self> {
        let table: toml::Table = self
            .src
            .text
            .parse()
            .map_err(|e: toml::de::Error| PyRuntimeError::new_err(e.to_string()))?;
        let mut table = toml::Value::Table(table);
        for (path, value) in toml_of_json(json, "replace")? {
            impactmc::config::path::set(&mut table, &path, value)
                .map_err(|m| input_error(m.clone(), Some(&path), None, None))?;
        }
        let text = toml::to_string(&table).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Self::new(SceneText::new("<replaced>", text))
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> &str {
        &self.name
    }

    /// The effects it computes, as the CLI's first line says them.
    #[getter]
    fn effects(&self) -> &str {
        &self.effects
    }

    /// The kernel it runs, as the CLI's second line says it.
    #[getter]
    fn kernel(&self) -> &str {
        &self.kernel
    }

    /// The scene's TOML text.
    #[getter]
    fn toml(&self) -> &str {
        &self.src.text
    }

    /// The scene's tables as JSON text (the Python layer's `to_dict`).
    fn _to_json(&self) -> PyResult<String> {
        let table: toml::Table = self
            .src
            .text
            .parse()
            .map_err(|e: toml::de::Error| PyRuntimeError::new_err(e.to_string()))?;
        serde_json::to_string(&table).map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    /// Where the scene came from (a path, `<string>`, `<dict>`,
    /// `<replaced>`).
    #[getter]
    fn source(&self) -> &str {
        &self.src.file
    }

    /// Runs the scene (every sweep point). Without `out` nothing is written
    /// to disk. `callback(done, total)` is called on this thread about
    /// every 100 ms; Ctrl-C (or an exception in the callback) cancels the
    /// run between batches.
    #[pyo3(signature = (samples=None, seed=None, threads=0, per_sample=false, columns=None, out=None, force=false, shard=None, callback=None))]
    #[allow(clippy::too_many_arguments)]
    fn _run(
        &self,
        py: Python<'_>,
        samples: Option<u64>,
        seed: Option<u64>,
        threads: usize,
        per_sample: bool,
        columns: Option<Vec<String>>,
        out: Option<PathBuf>,
        force: bool,
        shard: Option<String>,
        callback: Option<Py<PyAny>>,
    ) -> PyResult<PyResult_> {
        let shard: Option<Shard> = shard
            .map(|s| s.parse())
            .transpose()
            .map_err(|m: String| input_error(format!("shard: {m}"), Some("shard"), None, None))?;
        let overrides = Overrides {
            per_sample,
            columns,
            samples,
            seed,
            ..Default::default()
        };
        let watch = Watch::new();
        let opts = RunOptions {
            threads,
            progress: false,
            shard,
            watch: Some(watch.clone()),
            ..Default::default()
        };
        // Bad input fails here, before any work or any folder.
        plan_text(&self.src, &overrides).map_err(scene_error)?;
        if let Some(dir) = &out {
            prepare_dir(dir, force).map_err(|e| output_error(e, "out"))?;
        }
        let src = self.src.clone();
        let study = watched(py, &watch, callback.as_ref(), move || {
            let mut s = study::run(&src, &overrides, &opts, out.as_deref())?;
            if s.dir().is_some() {
                s.write()?;
            }
            Ok(s)
        })?
        .map_err(study_error)?;
        Ok(PyResult_::whole(study))
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(name={:?}, source={:?}, {}, {})",
            self.name, self.src.file, self.effects, self.kernel
        )
    }
}

/// A finished run, or one grid point of it: its summary, tables and
/// per-sample rows.
#[pyclass(module = "impactmc._impactmc", frozen, name = "Result")]
struct PyResult_ {
    study: Arc<Study>,
    /// The grid point this is, or None for the whole run.
    point: Option<usize>,
}

impl PyResult_ {
    fn whole(study: Study) -> Self {
        Self {
            study: Arc::new(study),
            point: None,
        }
    }

    /// A table's rows of this point (all of them for the whole run).
    fn rows_of(&self, table: ArrowTable) -> ArrowTable {
        match self.point {
            Some(i) => table.point(i as u32),
            None => table,
        }
    }
}

#[pymethods]
impl PyResult_ {
    /// `summary.json`'s text (what `run --format json` prints); for a grid
    /// point, its `summary` there.
    fn _summary_json(&self) -> PyResult<String> {
        Ok(match self.point {
            Some(i) => serde_json::to_string(&self.study.points[i].summary)
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?,
            None => self.study.summary_json().to_string(),
        })
    }

    /// The terminal summary (of this point: headed by its swept values).
    #[getter]
    fn text(&self) -> String {
        match self.point {
            Some(i) => self.study.point_text(i).trim_start().to_string(),
            None => self.study.text(),
        }
    }

    /// The swept values of a grid point (field path to value); empty for a
    /// run without a sweep, None for the whole of a sweep.
    #[getter]
    fn values(&self) -> Option<Vec<(String, f64)>> {
        match self.point {
            Some(i) => Some(self.study.points[i].values.clone()),
            None if self.study.is_sweep() => None,
            None => Some(Vec::new()),
        }
    }

    /// One result per grid point (a run without a sweep has one).
    fn _points(&self) -> Vec<Self> {
        let points = match self.point {
            Some(i) => i..i + 1,
            None => 0..self.study.points.len(),
        };
        points
            .map(|i| Self {
                study: self.study.clone(),
                point: Some(i),
            })
            .collect()
    }

    /// The run folder, or None for a run kept in memory.
    #[getter]
    fn out(&self) -> Option<PathBuf> {
        self.study.dir().map(Path::to_path_buf)
    }

    /// The names of the run's tables (`summary`, `histograms`, and a drop
    /// scene's bounce tables).
    #[getter]
    fn table_names(&self) -> PyResult<Vec<String>> {
        let tables = self
            .study
            .tables()
            .map_err(|(name, e)| PyRuntimeError::new_err(format!("{name}: {e}")))?;
        Ok(tables
            .into_iter()
            .map(|(n, _)| n.trim_end_matches(".parquet").to_string())
            .collect())
    }

    /// A table by name, as its Parquet file in the run folder holds it (a
    /// grid point's rows of it for a point).
    fn table(&self, py: Python<'_>, name: &str) -> PyResult<Table> {
        let file = format!("{}.parquet", name.trim_end_matches(".parquet"));
        let tables = py
            .detach(|| self.study.tables())
            .map_err(|(name, e)| PyRuntimeError::new_err(format!("{name}: {e}")))?;
        let names: Vec<&str> = tables
            .iter()
            .map(|(n, _)| n.trim_end_matches(".parquet"))
            .collect();
        let names = names.join(", ");
        let mut df = tables
            .into_iter()
            .find(|(n, _)| *n == file)
            .map(|(_, df)| df)
            .ok_or_else(|| {
                PyKeyError::new_err(format!("no table {name:?}; the run has {names}"))
            })?;
        let table = py
            .detach(|| ArrowTable::of_frame(&mut df))
            .map_err(|e| PyRuntimeError::new_err(format!("{file}: {e}")))?;
        Ok(Table {
            table: self.rows_of(table),
        })
    }

    /// The per-sample rows (a run with `per_sample=True`; a grid point's
    /// rows for a point): from memory, or read from the run folder's
    /// `samples.parquet`.
    fn samples(&self, py: Python<'_>) -> PyResult<Table> {
        if let Some(t) = &self.study.samples {
            return Ok(Table {
                table: self.rows_of(t.clone()),
            });
        }
        match (&self.study.per_sample, self.study.dir()) {
            (Some(_), Some(dir)) => {
                let path = dir.join("samples.parquet");
                let table = py
                    .detach(|| ArrowTable::read(&path))
                    .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", path.display())))?;
                Ok(Table {
                    table: self.rows_of(table),
                })
            }
            _ => Err(PyValueError::new_err(
                "the run kept no per-sample rows: run with per_sample=True",
            )),
        }
    }

    /// `manifest.json`'s text, or None for a run kept in memory.
    fn _manifest_json(&self, py: Python<'_>) -> PyResult<Option<String>> {
        let Some(dir) = self.study.dir() else {
            return Ok(None);
        };
        let path = dir.join("manifest.json");
        py.detach(|| std::fs::read_to_string(&path))
            .map(Some)
            .map_err(|e| PyRuntimeError::new_err(format!("{}: {e}", path.display())))
    }

    fn __repr__(&self) -> String {
        let place = match self.study.dir() {
            Some(d) => format!("out={:?}", d.display().to_string()),
            None => "in memory".into(),
        };
        let name = &self.study.raw.name;
        match self.point {
            Some(i) => {
                let p = &self.study.points[i];
                let values: Vec<String> =
                    p.values.iter().map(|(k, x)| format!("{k}={x}")).collect();
                format!(
                    "Result(scene={name:?}, point={i}, values={{{}}}, samples={}, {place})",
                    values.join(", "),
                    p.scene.samples()
                )
            }
            None => {
                let points = self.study.points.len();
                let samples: u64 = self.study.points.iter().map(|p| p.scene.samples()).sum();
                format!("Result(scene={name:?}, points={points}, samples={samples}, {place})")
            }
        }
    }
}

/// An Arrow table: record batches shared with the run (not copied), read
/// by polars, pyarrow and DuckDB through `__arrow_c_stream__`.
#[pyclass(module = "impactmc._impactmc", frozen)]
struct Table {
    table: ArrowTable,
}

#[pymethods]
impl Table {
    /// The Arrow PyCapsule stream interface. A requested schema is not
    /// honoured: the table has one schema.
    #[pyo3(signature = (requested_schema=None))]
    fn __arrow_c_stream__<'py>(
        &self,
        py: Python<'py>,
        requested_schema: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyCapsule>> {
        let _ = requested_schema;
        let t = &self.table;
        let reader =
            RecordBatchIterator::new(t.batches.clone().into_iter().map(Ok), t.schema.clone());
        let stream = FFI_ArrowArrayStream::new(Box::new(reader));
        PyCapsule::new_with_value(py, stream, c"arrow_array_stream")
    }

    #[getter]
    fn num_rows(&self) -> usize {
        self.table.rows()
    }

    #[getter]
    fn column_names(&self) -> Vec<String> {
        self.table
            .schema
            .fields()
            .iter()
            .map(|f| f.name().clone())
            .collect()
    }

    fn __len__(&self) -> usize {
        self.table.rows()
    }

    fn __repr__(&self) -> String {
        const SHOWN: usize = 6;
        let fields = self.table.schema.fields();
        let mut cols: Vec<String> = fields
            .iter()
            .take(SHOWN)
            .map(|f| format!("{}: {}", f.name(), f.data_type()))
            .collect();
        if fields.len() > SHOWN {
            cols.push(format!("… {} more", fields.len() - SHOWN));
        }
        format!(
            "Table(rows={}, columns=[{}])",
            self.table.rows(),
            cols.join(", ")
        )
    }
}

#[pymodule]
fn _impactmc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("InputError", m.py().get_type::<InputError>())?;
    m.add("OutputExistsError", m.py().get_type::<OutputExistsError>())?;
    m.add_class::<PyScene>()?;
    m.add_class::<PyResult_>()?;
    m.add_class::<Table>()?;
    m.add_function(wrap_pyfunction!(_solve, m)?)?;
    m.add_function(wrap_pyfunction!(_inspect, m)?)?;
    m.add_function(wrap_pyfunction!(_merge, m)?)?;
    m.add_function(wrap_pyfunction!(_accuracy, m)?)?;
    Ok(())
}
