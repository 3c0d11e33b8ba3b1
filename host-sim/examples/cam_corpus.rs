//! Writes host-sim's own CAM programs (`host_sim::cam_corpus`) into
//! `tests/data/cam/` (or the folder given as the first argument).

fn main() -> std::io::Result<()> {
    let dir = std::env::args()
        .nth(1)
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/cam")
        });
    std::fs::create_dir_all(&dir)?;
    for (name, text) in host_sim::cam_corpus::programs() {
        std::fs::write(dir.join(name), text)?;
        eprintln!("wrote {}", dir.join(name).display());
    }
    Ok(())
}
