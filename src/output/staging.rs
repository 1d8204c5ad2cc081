//! Run outputs: one folder per run, every file written under a temporary
//! name and renamed when complete, so a file is either whole or absent
//! (cryo's export pattern).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use polars::prelude::PolarsError;

/// Why outputs could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// A file or folder could not be made, written or renamed.
    #[error("output folder {path}: {source}")]
    Io {
        /// The file or folder.
        path: String,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// The folder holds a run and overwriting was not asked for.
    #[error("output folder {0} already holds a run; pass --force to overwrite it")]
    Exists(String),
    /// A plot could not be drawn.
    #[error("drawing {path}: {message}")]
    Plot {
        /// The SVG file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// A Parquet table could not be written.
    #[error("writing {path}: {source}")]
    Parquet {
        /// The Parquet file.
        path: String,
        /// What polars said.
        #[source]
        source: PolarsError,
    },
    /// The run was kept in memory and has no folder to write.
    #[error("this run was kept in memory: it has no output folder to write")]
    NoFolder,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> OutputError + '_ {
    move |source| OutputError::Io {
        path: path.display().to_string(),
        source,
    }
}

/// Prepares the output folder: creates it, refuses one that already holds a
/// run unless `force`, and checks that it is writable before any work.
pub fn prepare_dir(dir: &Path, force: bool) -> Result<(), OutputError> {
    fs::create_dir_all(dir).map_err(io(dir))?;
    // manifest.json marks a finished run (it is written last); accuracy.md
    // a finished accuracy ladder.
    if !force
        && ["manifest.json", "accuracy.md"]
            .iter()
            .any(|f| dir.join(f).exists())
    {
        return Err(OutputError::Exists(dir.display().to_string()));
    }
    // Temporary files of killed runs (their process is gone) are removed,
    // in the folder and in its plots.
    for entries in [dir.to_path_buf(), dir.join("plots")]
        .iter()
        .filter_map(|d| fs::read_dir(d).ok())
    {
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(pid) = name
                .rsplit_once(".partial-")
                .and_then(|(_, p)| p.parse::<u32>().ok())
            {
                if name.starts_with('.') && !Path::new(&format!("/proc/{pid}")).exists() {
                    let _ = fs::remove_file(e.path());
                }
            }
        }
    }
    let probe = dir.join(".impactmc-write-probe");
    fs::write(&probe, b"").map_err(io(dir))?;
    fs::remove_file(&probe).map_err(io(dir))?;
    Ok(())
}

/// Files of a run folder written under temporary names (`.NAME.partial-PID`)
/// and renamed together by [`Staging::commit`], the manifest last. Until then
/// nothing in the folder looks complete; dropping an uncommitted staging area
/// (an error, a panic) removes its temporary files.
pub struct Staging {
    dir: PathBuf,
    files: Vec<(PathBuf, PathBuf)>,
    committed: bool,
}

impl Staging {
    pub fn new(dir: &Path) -> Self {
        Self {
            dir: dir.to_path_buf(),
            files: Vec::new(),
            committed: false,
        }
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Creates the temporary file for `name`, which may lie in a subfolder
    /// (`plots/energy_ratio.svg`: the subfolder is created, and the
    /// temporary file sits in it).
    pub fn create(&mut self, name: &str) -> Result<fs::File, OutputError> {
        let final_path = self.dir.join(name);
        let parent = final_path.parent().unwrap_or(&self.dir).to_path_buf();
        fs::create_dir_all(&parent).map_err(io(&parent))?;
        let file = final_path
            .file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        let tmp = parent.join(format!(".{file}.partial-{}", std::process::id()));
        let f = fs::File::create(&tmp).map_err(io(&tmp))?;
        self.files.push((tmp, final_path));
        Ok(f)
    }

    /// The temporary path of a file made by [`Staging::create`].
    pub fn temporary(&self, name: &str) -> Option<&Path> {
        let final_path = self.dir.join(name);
        self.files
            .iter()
            .find(|(_, f)| *f == final_path)
            .map(|(t, _)| t.as_path())
    }

    /// Writes `name` through `write` and syncs it.
    pub fn write(
        &mut self,
        name: &str,
        write: impl FnOnce(&mut fs::File) -> Result<(), OutputError>,
    ) -> Result<(), OutputError> {
        let mut f = self.create(name)?;
        write(&mut f)?;
        f.sync_all().map_err(io(&self.dir.join(name)))
    }

    /// Writes JSON.
    pub fn write_json<T: serde::Serialize>(
        &mut self,
        name: &str,
        value: &T,
    ) -> Result<(), OutputError> {
        let text = serde_json::to_string_pretty(value).expect("serialisable") + "\n";
        let path = self.dir.join(name);
        self.write(name, |f| f.write_all(text.as_bytes()).map_err(io(&path)))
    }

    /// Renames every file into place, in the order written (write the
    /// manifest last). Then the files an earlier run listed in its
    /// manifest and this one did not write are removed, so that a folder
    /// overwritten with `--force` holds one run (files it did not list,
    /// such as a user's own, stay).
    pub fn commit(mut self) -> Result<Vec<PathBuf>, OutputError> {
        let earlier = earlier_files(&self.dir);
        let mut done = Vec::new();
        for (tmp, final_path) in std::mem::take(&mut self.files) {
            fs::rename(&tmp, &final_path).map_err(io(&final_path))?;
            done.push(final_path);
        }
        self.committed = true;
        for path in earlier {
            if !done.contains(&path) {
                let _ = fs::remove_file(&path);
            }
        }
        Ok(done)
    }
}

/// The files the run in `dir` lists in its manifest, as paths in `dir`
/// (relative names without `..` only; none without a readable manifest).
fn earlier_files(dir: &Path) -> Vec<PathBuf> {
    let Ok(text) = fs::read_to_string(dir.join("manifest.json")) else {
        return Vec::new();
    };
    let Ok(manifest) = serde_json::from_str::<serde_json::Value>(&text) else {
        return Vec::new();
    };
    manifest["files"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|f| f.as_str())
        .map(Path::new)
        .filter(|p| {
            p.is_relative()
                && p.components()
                    .all(|c| matches!(c, std::path::Component::Normal(_)))
        })
        .map(|p| dir.join(p))
        .collect()
}

impl Drop for Staging {
    fn drop(&mut self) {
        if !self.committed {
            for (tmp, _) in &self.files {
                let _ = fs::remove_file(tmp);
            }
        }
    }
}
