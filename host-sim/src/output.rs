//! Output files written whole or not at all.
//!
//! Each file is written to a temporary file beside its destination
//! (`.<stem>.<random>.<ext>`, same directory, so the rename cannot cross file
//! systems) and renamed over the destination once complete. An error or a
//! refusal part way drops the temporary file (it is removed), and Ctrl-C
//! removes every temporary file still open before the process exits
//! ([`remove_on_interrupt`]): no command leaves a partial output behind,
//! and an older output of the same name stays as it was until the new one
//! is complete.

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use anyhow::{Context, Result};
use tempfile::NamedTempFile;

/// Temporary files being written, removed on Ctrl-C.
static OPEN: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Exit status after Ctrl-C (128 + SIGINT, as shells report it).
pub const INTERRUPTED_EXIT: i32 = 130;

/// On Ctrl-C: remove the temporary files of outputs being written, say so,
/// exit with [`INTERRUPTED_EXIT`]. Called once by `main`.
pub fn remove_on_interrupt() -> Result<()> {
    ctrlc::set_handler(|| {
        if let Ok(open) = OPEN.lock() {
            for p in open.iter() {
                let _ = std::fs::remove_file(p);
            }
        }
        eprintln!("interrupted: no output file was left half-written");
        std::process::exit(INTERRUPTED_EXIT);
    })
    .context("installing the Ctrl-C handler")
}

fn register(p: &Path) {
    if let Ok(mut open) = OPEN.lock() {
        open.push(p.to_path_buf());
    }
}

fn unregister(p: &Path) {
    if let Ok(mut open) = OPEN.lock() {
        open.retain(|q| q != p);
    }
}

/// A temporary file beside `dest`, registered for removal on Ctrl-C.
fn temp_beside(dest: &Path) -> Result<NamedTempFile> {
    let dir = match dest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    // The extension kept last: libraries that write by path pick the
    // format from it.
    let stem = dest
        .file_stem()
        .map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let ext = dest
        .extension()
        .map_or_else(String::new, |e| format!(".{}", e.to_string_lossy()));
    let prefix = format!(".{stem}.");
    let mut b = tempfile::Builder::new();
    b.prefix(&prefix).suffix(&ext);
    // As a plain `File::create` would (the umask applies), not the
    // owner-only mode of temporary files.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        b.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let tmp = b
        .tempfile_in(dir)
        .with_context(|| format!("creating {}", dest.display()))?;
    register(tmp.path());
    Ok(tmp)
}

/// An output file being written: [`Write`] into it, then [`Output::finish`]
/// to put it in place. Dropped without `finish`, nothing is left.
pub struct Output {
    dest: PathBuf,
    tmp_path: PathBuf,
    w: Option<BufWriter<NamedTempFile>>,
}

impl Output {
    /// Start writing `dest`.
    pub fn create(dest: &Path) -> Result<Output> {
        let tmp = temp_beside(dest)?;
        Ok(Output {
            dest: dest.to_path_buf(),
            tmp_path: tmp.path().to_path_buf(),
            w: Some(BufWriter::new(tmp)),
        })
    }

    /// Flush and rename the file into place.
    pub fn finish(mut self) -> Result<()> {
        let dest = self.dest.clone();
        let w = self.w.take().context("output already finished")?;
        let tmp = w
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("writing {}", dest.display()))?;
        tmp.as_file()
            .sync_all()
            .with_context(|| format!("writing {}", dest.display()))?;
        tmp.persist(&dest)
            .map_err(|e| e.error)
            .with_context(|| format!("writing {}", dest.display()))?;
        unregister(&self.tmp_path);
        Ok(())
    }
}

impl Write for Output {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.w {
            Some(w) => w.write(buf),
            None => Err(std::io::Error::other("output already finished")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.w {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for Output {
    fn drop(&mut self) {
        // An unfinished output: the temporary file goes with `w`.
        if self.w.is_some() {
            unregister(&self.tmp_path);
        }
    }
}

/// An output file, or standard output when no file is named.
pub enum FileOrStdout {
    /// A file, put in place by [`FileOrStdout::finish`].
    File(Output),
    /// Standard output, buffered.
    Stdout(BufWriter<std::io::StdoutLock<'static>>),
}

impl FileOrStdout {
    /// `path`, or standard output.
    pub fn create(path: Option<&Path>) -> Result<FileOrStdout> {
        Ok(match path {
            Some(p) => FileOrStdout::File(Output::create(p)?),
            None => FileOrStdout::Stdout(BufWriter::new(std::io::stdout().lock())),
        })
    }

    /// Put the file in place (or flush standard output).
    pub fn finish(self) -> Result<()> {
        match self {
            FileOrStdout::File(o) => o.finish(),
            FileOrStdout::Stdout(mut w) => Ok(w.flush()?),
        }
    }
}

impl Write for FileOrStdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match self {
            FileOrStdout::File(o) => o.write(buf),
            FileOrStdout::Stdout(w) => w.write(buf),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match self {
            FileOrStdout::File(o) => o.flush(),
            FileOrStdout::Stdout(w) => w.flush(),
        }
    }
}

/// Write `dest` whole, or not at all.
pub fn write(dest: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> Result<()> {
    let dest = dest.as_ref();
    let mut o = Output::create(dest)?;
    o.write_all(contents.as_ref())
        .with_context(|| format!("writing {}", dest.display()))?;
    o.finish()
}

/// A file another library writes by path (a plot): `draw` writes the
/// temporary path given to it, which is then renamed to `dest`.
pub fn write_by_path(dest: &Path, draw: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_beside(dest)?;
    let tmp_path = tmp.path().to_path_buf();
    let r = draw(&tmp_path).and_then(|()| {
        tmp.persist(dest)
            .map_err(|e| e.error)
            .with_context(|| format!("writing {}", dest.display()))
            .map(|_| ())
    });
    unregister(&tmp_path);
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_finished_output_replaces_the_old_one_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        std::fs::write(&p, "old").unwrap();
        let mut o = Output::create(&p).unwrap();
        o.write_all(b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        o.finish().unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn an_unfinished_output_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.csv");
        {
            let mut o = Output::create(&p).unwrap();
            o.write_all(b"partial").unwrap();
        }
        assert!(!p.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        assert!(!OPEN
            .lock()
            .unwrap()
            .iter()
            .any(|q| q.starts_with(dir.path())));
    }

    #[test]
    fn a_failed_draw_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("plot.svg");
        let r = write_by_path(&p, |t| {
            std::fs::write(t, "half")?;
            anyhow::bail!("drawing failed")
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        write_by_path(&p, |t| Ok(std::fs::write(t, "ok")?)).unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "ok");
    }
}
