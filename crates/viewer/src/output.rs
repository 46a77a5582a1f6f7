//! Outputs never overwrite inputs, and files appear whole or not at all.
//!
//! - [`refuse_inputs`]: an output that is the same file as one of the
//!   command's inputs (compared by device and inode where they exist, so
//!   `./a.gzrec`, `a.gzrec` and a hard link are all caught; by canonical
//!   path otherwise) is an error before anything is opened for writing.
//! - [`AtomicFile`]: whole-file outputs (pictures, CSV, JSON, calibration
//!   files) are written to a temporary file beside the target and renamed
//!   over it only when complete, so an error or a kill never leaves a
//!   truncated or half-written file, and an existing file is replaced only
//!   by a finished one.
//!
//! Recordings are the exception: a recording is written as it happens so
//! that a killed session keeps what it had; it is still refused when it
//! names an input.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Whether `a` and `b` name the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
    }
}

/// Refuses any output (`(flag, path)`) that is the same file as an input,
/// or as another output.
pub fn refuse_inputs(outputs: &[(&str, &Path)], inputs: &[(&str, &Path)]) -> Result<(), String> {
    for (k, (out_flag, out)) in outputs.iter().enumerate() {
        for (in_flag, input) in inputs {
            if same_file(out, input) {
                return Err(format!(
                    "{out_flag} {}: that is the {in_flag} file; refusing to overwrite an input",
                    out.display()
                ));
            }
        }
        for (other_flag, other) in &outputs[k + 1..] {
            if same_file(out, other) || (out == other) {
                return Err(format!(
                    "{out_flag} and {other_flag} both name {}; give each output its own file",
                    out.display()
                ));
            }
        }
    }
    Ok(())
}

/// A command's inputs, by flag: what [`Inputs::refuse`] keeps outputs
/// from replacing. A scene brings its OBJ meshes with it (`--scene
/// meshes.NAME`), so `render --out mesh.obj` is refused like
/// `render --out scene.ron`.
#[derive(Debug, Default, Clone)]
pub struct Inputs {
    list: Vec<(String, PathBuf)>,
}

impl Inputs {
    /// No input paths yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one input file.
    pub fn file(mut self, flag: &str, path: &Path) -> Self {
        self.list.push((flag.to_string(), path.to_path_buf()));
        self
    }

    /// Adds an optional input file.
    pub fn maybe(self, flag: &str, path: Option<&Path>) -> Self {
        match path {
            Some(p) => self.file(flag, p),
            None => self,
        }
    }

    /// Adds a scene file and the meshes it loads. A scene that does not
    /// parse adds itself only: loading it fails later, before any output.
    pub fn scene(mut self, flag: &str, path: &Path) -> Self {
        self.list.push((flag.to_string(), path.to_path_buf()));
        if let Ok((file, _)) = crate::config::load::<raycast::SceneFile>(path) {
            let dir = path.parent().unwrap_or(Path::new("."));
            for (field, mesh) in raycast::Scene::mesh_files(&file, dir) {
                self.list
                    .push((format!("{flag} {}'s {field}", path.display()), mesh));
            }
        }
        self
    }

    /// Refuses files `names` in the output folder `dir` (given as `flag`)
    /// that are inputs.
    pub fn refuse_in(&self, flag: &str, dir: &Path, names: &[&str]) -> Result<(), String> {
        let paths: Vec<(String, PathBuf)> = names
            .iter()
            .map(|n| (format!("{flag} {}'s {n}", dir.display()), dir.join(n)))
            .collect();
        let outputs: Vec<(&str, &Path)> = paths
            .iter()
            .map(|(f, p)| (f.as_str(), p.as_path()))
            .collect();
        self.refuse(&outputs)
    }

    /// Refuses any output that is one of these inputs or another output
    /// (see [`refuse_inputs`]).
    pub fn refuse(&self, outputs: &[(&str, &Path)]) -> Result<(), String> {
        let inputs: Vec<(&str, &Path)> = self
            .list
            .iter()
            .map(|(f, p)| (f.as_str(), p.as_path()))
            .collect();
        refuse_inputs(outputs, &inputs)
    }
}

/// A file written under a temporary name and renamed over its target by
/// [`AtomicFile::commit`]; dropped uncommitted, it is removed and the
/// target is untouched.
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Creates the temporary file beside `target` (same directory, so the
    /// rename cannot cross file systems).
    pub fn create(target: &Path) -> std::io::Result<Self> {
        let name = target
            .file_name()
            .ok_or_else(|| std::io::Error::other("an output needs a file name"))?;
        let mut temp_name = std::ffi::OsString::from(".");
        temp_name.push(name);
        temp_name.push(format!(".tmp-{}", std::process::id()));
        let temp = target.with_file_name(temp_name);
        let file = File::create(&temp)?;
        Ok(Self {
            target: target.to_path_buf(),
            temp,
            writer: Some(BufWriter::new(file)),
        })
    }

    /// Flushes, syncs and renames the file into place.
    pub fn commit(mut self) -> std::io::Result<()> {
        if let Some(w) = self.writer.take() {
            let file = w.into_inner().map_err(|e| e.into_error())?;
            file.sync_all()?;
        }
        std::fs::rename(&self.temp, &self.target)
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        match &mut self.writer {
            Some(w) => w.write(buf),
            None => Err(std::io::Error::other("already committed")),
        }
    }

    fn flush(&mut self) -> std::io::Result<()> {
        match &mut self.writer {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if self.writer.take().is_some() {
            let _ = std::fs::remove_file(&self.temp);
        }
    }
}

/// Writes `bytes` to `path` whole (through [`AtomicFile`]).
pub fn write_whole(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = AtomicFile::create(path)?;
    f.write_all(bytes)?;
    f.commit()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_is_refused_however_it_is_spelt() {
        let dir = tempfile::tempdir().expect("tempdir");
        let input = dir.path().join("in.gzrec");
        std::fs::write(&input, b"data").expect("write");
        let dotted = dir.path().join(".").join("in.gzrec");
        let link = dir.path().join("link.gzrec");
        std::fs::hard_link(&input, &link).expect("link");
        for out in [&input, &dotted, &link] {
            let e = refuse_inputs(&[("--csv", out)], &[("--input", &input)]).expect_err("refused");
            assert!(e.contains("--input"), "{e}");
        }
        let fresh = dir.path().join("out.csv");
        assert!(refuse_inputs(&[("--csv", &fresh)], &[("--input", &input)]).is_ok());
        let e = refuse_inputs(&[("--out", &fresh), ("--layers", &fresh)], &[]).expect_err("two");
        assert!(e.contains("--layers"), "{e}");
        assert_eq!(std::fs::read(&input).expect("read"), b"data");
    }

    #[test]
    fn an_unfinished_file_never_replaces_the_old_one() {
        let dir = tempfile::tempdir().expect("tempdir");
        let target = dir.path().join("a.csv");
        std::fs::write(&target, b"old").expect("write");
        {
            let mut f = AtomicFile::create(&target).expect("create");
            f.write_all(b"half").expect("write");
            // Dropped without commit: an error on the way.
        }
        assert_eq!(std::fs::read(&target).expect("read"), b"old");
        assert_eq!(
            std::fs::read_dir(dir.path()).expect("dir").count(),
            1,
            "no temp left"
        );
        write_whole(&target, b"new").expect("write");
        assert_eq!(std::fs::read(&target).expect("read"), b"new");
    }
}
