//! Toolpath files by kind: G-code (`.nc .ngc .gcode .tap .cnc .g`) or CSV
//! point lists (`.csv`, see [`crate::path_csv`]).

use std::path::Path;

use anyhow::{bail, Result};

use crate::path_csv;
use crate::toolpath::Toolpath;
use crate::GcodeSettings;

/// Load a toolpath; the extension picks the reader.
pub fn load(path: &Path, settings: &GcodeSettings) -> Result<Toolpath> {
    load_with_warnings(path, settings).map(|(t, _)| t)
}

/// [`load`], with the G-code reader's warnings (source line, text).
pub fn load_with_warnings(
    path: &Path,
    settings: &GcodeSettings,
) -> Result<(Toolpath, Vec<(u32, String)>)> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match ext.as_str() {
        "csv" => {
            let pts = path_csv::read(path)?;
            let name = path
                .file_stem()
                .map_or("path".into(), |s| s.to_string_lossy().into_owned());
            Toolpath::from_path_points(name, &pts)
                .map(|t| (t, Vec::new()))
                .map_err(|e| anyhow::anyhow!("in {}: {e:#}", path.display()))
        }
        "nc" | "ngc" | "gcode" | "tap" | "cnc" | "g" => crate::read_with_warnings(path, settings),
        _ => bail!(
            "{}: unknown toolpath kind (use .csv or a G-code extension: .nc .ngc .gcode .tap .cnc .g)",
            path.display()
        ),
    }
}
