//! `impactmc accuracy`: a scene's accuracy ladder, written as a folder.

use std::path::{Path, PathBuf};

use impactmc::accuracy::{ladder, write_folder, Knobs, Steps};
use impactmc::config::load_scene;
use impactmc::output::prepare_dir;

use super::{emit, Failure};

/// The scene `impactmc accuracy` uses when given none.
const DEFAULT_SCENE: &str = "configs/accuracy_corner3.toml";

pub fn run(scene: Option<&Path>, out: Option<&Path>, force: bool) -> Result<(), Failure> {
    let path = scene.map_or_else(|| PathBuf::from(DEFAULT_SCENE), Path::to_path_buf);
    let base = load_scene(&path, &Default::default()).map_err(Failure::bad_input)?;
    Knobs::from_raw(&path.display().to_string(), base.raw()).map_err(Failure::bad_input)?;
    let dir = out.map_or_else(
        || PathBuf::from("results").join(format!("{}-accuracy", base.name())),
        Path::to_path_buf,
    );
    prepare_dir(&dir, force).map_err(Failure::bad_input)?;
    let mut say = |line: &str| eprintln!("{line}");
    let ladder = ladder(&path, &mut Steps::new(&mut say, None)).map_err(Failure::bad_input)?;
    let md = write_folder(&ladder, &path, &dir)?;
    emit(&md);
    emit(&format!("\nwrote {}\n", dir.display()));
    Ok(())
}
