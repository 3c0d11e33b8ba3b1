//! Toolpath files by kind: G-code (`.nc .ngc .gcode .tap .cnc .g`) or CSV
//! point lists (`.csv`, see [`crate::path_csv`]).

use std::path::Path;

use anyhow::{bail, Result};

use crate::path_csv;
use crate::toolpath::Toolpath;
use crate::GcodeSettings;

/// Load a toolpath; the extension picks the reader.
pub fn load(path: &Path, settings: &GcodeSettings) -> Result<Toolpath> {
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
                .map_err(|e| anyhow::anyhow!("in {}: {e:#}", path.display()))
        }
        "nc" | "ngc" | "gcode" | "tap" | "cnc" | "g" => crate::read(path, settings),
        _ => bail!(
            "{}: unknown toolpath kind (use .csv or a G-code extension: .nc .ngc .gcode .tap .cnc .g)",
            path.display()
        ),
    }
}
