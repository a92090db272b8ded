//! Output safety: a run never writes over anything the user did not ask to be written.
//!
//! [`check_outputs`] runs at plan time ([`Plan::new`](crate::Plan::new)), before any file is
//! read or created. It refuses a scene when
//!
//! - an output (its final path, its `<path>.partial` temporary, an archive directory, a bus's
//!   `stats` file) resolves to an input: a sensor's source file (CSV, NumPy and its
//!   timestamps, Arrow IPC), a layout CSV, the dos model, a bus's candump log, or the scene
//!   file itself;
//! - two outputs resolve to the same file, or one lies inside another's archive directory, or
//!   an input lies inside an archive directory;
//! - an output path exists and is not a regular file (a device such as `/dev/null`, a FIFO, a
//!   socket, a directory where a file is expected), or an archive path exists and is not a
//!   directory.
//!
//! "Resolves" means: existing paths are canonicalised (symlinks and `..` followed); for a path
//! that does not exist yet, its nearest existing ancestor is canonicalised and the rest
//! appended. Existing files are also compared by device and inode, so a hard link to an input
//! is caught too. The sinks re-check just before the final rename
//! ([`gradtac_io::ParquetSink::finish`]) and never replace a non-regular file, which closes
//! most of the window between this check and the end of a run (a check-then-rename on a
//! shared directory cannot close it entirely).

use crate::scene::{BusSource, Scene, SourceSpec};
use crate::Error;
use gradtac_io::parquet_sink::partial_path;
use std::fs;
use std::path::{Component, Path, PathBuf};

/// A path the run reads or writes, with what it is (for error messages).
struct Named {
    what: String,
    path: PathBuf,
    key: PathBuf,
    id: Option<(u64, u64)>,
}

impl Named {
    fn new(what: String, path: PathBuf) -> Named {
        let key = resolve(&path);
        let id = file_id(&path);
        Named { what, path, key, id }
    }

    fn same_file(&self, other: &Named) -> bool {
        self.key == other.key || (self.id.is_some() && self.id == other.id)
    }
}

/// `(device, inode)` of an existing file (following symlinks), on Unix.
fn file_id(p: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = p;
        None
    }
}

/// The canonical form of `p`: canonicalised if it exists; otherwise its nearest existing
/// ancestor canonicalised with the remaining components appended (`.` dropped, `..` popped).
pub fn resolve(p: &Path) -> PathBuf {
    let abs = if p.is_absolute() {
        p.to_path_buf()
    } else {
        std::env::current_dir().map(|d| d.join(p)).unwrap_or_else(|_| p.to_path_buf())
    };
    if let Ok(c) = fs::canonicalize(&abs) {
        return c;
    }
    let comps: Vec<Component<'_>> = abs.components().collect();
    for split in (0..comps.len()).rev() {
        let head: PathBuf = comps[..split].iter().collect();
        let Ok(mut base) = fs::canonicalize(&head) else { continue };
        for c in &comps[split..] {
            match c {
                Component::CurDir => {}
                Component::ParentDir => {
                    base.pop();
                }
                other => base.push(other.as_os_str()),
            }
        }
        return base;
    }
    abs
}

/// What kind of non-regular file `m` is, for error messages.
fn kind(m: &fs::Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Refuse an existing `path` that is not a regular file (following symlinks).
fn must_be_file_if_present(what: &str, path: &Path) -> Result<(), String> {
    match fs::metadata(path) {
        Ok(m) if !m.is_file() => Err(format!(
            "{what} {} exists and is {}; gradtac writes only regular files and never replaces anything else",
            path.display(),
            kind(&m)
        )),
        _ => match fs::symlink_metadata(path) {
            // a dangling symlink: the rename would replace the link, writing somewhere unexpected
            Ok(m) if m.file_type().is_symlink() && fs::metadata(path).is_err() => {
                Err(format!("{what} {} is a dangling symbolic link", path.display()))
            }
            _ => Ok(()),
        },
    }
}

/// Every file the scene reads, resolved against the scene's directory.
fn inputs(scene: &Scene) -> Vec<Named> {
    let mut v = Vec::new();
    if !scene.origin.as_os_str().is_empty() {
        v.push(Named::new("the scene file".into(), scene.origin.clone()));
    }
    for s in &scene.sensors {
        let name = &s.name;
        match &s.source {
            SourceSpec::Bus { .. } => {}
            SourceSpec::Npy(c) => {
                v.push(Named::new(format!("the source of sensor {name:?}"), scene.resolve(&c.path)));
                if let Some(t) = &c.timestamps {
                    v.push(Named::new(format!("the timestamps of sensor {name:?}"), scene.resolve(t)));
                }
            }
            other => v.push(Named::new(format!("the source of sensor {name:?}"), scene.resolve(other.path()))),
        }
        if !gradtac_stream::layout::BUILTIN_LAYOUTS.contains(&s.layout.as_str()) {
            v.push(Named::new(format!("the layout of sensor {name:?}"), scene.resolve(Path::new(&s.layout))));
        }
    }
    for b in &scene.buses {
        #[allow(irrefutable_let_patterns)]
        if let BusSource::Candump(c) = &b.source {
            v.push(Named::new(format!("the candump log of bus {:?}", b.name), scene.resolve(&c.path)));
        }
    }
    if let Some(d) = &scene.stages.dos {
        v.push(Named::new("the dos model".into(), scene.resolve(&d.model)));
    }
    v
}

/// Check every output of `scene` against its inputs, each other and the file system (see
/// the [module docs](self)). Reads no file's contents and creates nothing.
pub fn check_outputs(scene: &Scene) -> Result<(), Error> {
    let bad = |reason: String| Error::Scene { path: scene.origin.clone(), reason };
    let inputs = inputs(scene);
    // outputs that are single files (final and temporary names), and archive directories
    let mut files: Vec<Named> = Vec::new();
    let mut dirs: Vec<Named> = Vec::new();
    for (i, o) in scene.outputs.iter().enumerate() {
        let path = scene.resolve(&o.path);
        let what = format!("output #{} ({})", i + 1, o.path.display());
        if o.archive.is_some() {
            if let Ok(m) = fs::metadata(&path) {
                if !m.is_dir() {
                    return Err(bad(format!(
                        "{what}: the archive path {} exists and is {}, not a directory",
                        path.display(),
                        if m.is_file() { "a regular file" } else { kind(&m) }
                    )));
                }
            }
            dirs.push(Named::new(what, path));
        } else {
            must_be_file_if_present(&what, &path).map_err(bad)?;
            if let Some(partial) = partial_path(&path) {
                must_be_file_if_present(&format!("{what}: its temporary file"), &partial).map_err(bad)?;
                files.push(Named::new(format!("{what} (its temporary file {})", partial.display()), partial));
            }
            files.push(Named::new(what, path));
        }
    }
    for b in &scene.buses {
        if let Some(p) = &b.stats {
            let what = format!("the stats file of bus {:?} ({})", b.name, p.display());
            let path = scene.resolve(p);
            must_be_file_if_present(&what, &path).map_err(bad)?;
            files.push(Named::new(what, path));
        }
    }
    let outputs: Vec<&Named> = files.iter().chain(&dirs).collect();
    for (k, out) in outputs.iter().enumerate() {
        if let Some(inp) = inputs.iter().find(|i| out.same_file(i) || (k >= files.len() && i.key.starts_with(&out.key)))
        {
            let how = if out.same_file(inp) { "is the same file as" } else { "is a directory holding" };
            return Err(bad(format!(
                "{} would write {}, which {how} {} ({}); refusing to replace an input",
                out.what,
                out.path.display(),
                inp.what,
                inp.path.display()
            )));
        }
        for other in &outputs[..k] {
            let nested = |a: &Named, b: &Named| dirs.iter().any(|d| std::ptr::eq(d, b)) && a.key.starts_with(&b.key);
            if out.same_file(other) || nested(out, other) || nested(other, out) {
                return Err(bad(format!(
                    "{} and {} both write {}{}",
                    other.what,
                    out.what,
                    out.path.display(),
                    if out.same_file(other) { "" } else { " (one lies inside the other's archive directory)" }
                )));
            }
        }
    }
    Ok(())
}

/// For a file a run writes besides its outputs (`gradtac run --view-save`): refuse it when it
/// resolves to one of the scene's inputs (the scene file included) or outputs, or exists and is
/// not a regular file. Call it before reading anything.
pub fn check_side_output(scene: &Scene, out: &Path) -> Result<(), Error> {
    let named = inputs(scene);
    let outs: Vec<(String, PathBuf)> = scene
        .outputs
        .iter()
        .enumerate()
        .map(|(i, o)| (format!("output #{} ({})", i + 1, o.path.display()), scene.resolve(&o.path)))
        .collect();
    let mut all: Vec<(&str, &Path)> = named.iter().map(|n| (n.what.as_str(), n.path.as_path())).collect();
    all.extend(outs.iter().map(|(w, p)| (w.as_str(), p.as_path())));
    check_output_file(out, &all)
}

/// For the commands that write one file (`gradtac plot --out`, `gradtac calibrate --out`):
/// refuse `out` when it resolves to one of `inputs` (a file, or any file inside an input
/// directory) or exists and is not a regular file. Call it before reading anything.
pub fn check_output_file(out: &Path, inputs: &[(&str, &Path)]) -> Result<(), Error> {
    let bad = |reason: String| Error::Scene { path: out.to_path_buf(), reason };
    must_be_file_if_present("the output", out).map_err(bad)?;
    let o = Named::new("the output".into(), out.to_path_buf());
    for (what, p) in inputs {
        let i = Named::new(what.to_string(), p.to_path_buf());
        let inside = fs::metadata(p).is_ok_and(|m| m.is_dir()) && o.key.starts_with(&i.key);
        if o.same_file(&i) || inside {
            return Err(bad(format!(
                "the output would {} {what} ({}); refusing to replace an input",
                if inside { "be written inside" } else { "replace" },
                p.display()
            )));
        }
    }
    Ok(())
}

/// Largest scene file read (bytes): 16 MiB.
pub const MAX_SCENE_BYTES: u64 = 16 << 20;
/// Largest model file read (bytes): 64 MiB.
pub const MAX_MODEL_BYTES: u64 = 64 << 20;

/// Read a text file of at most `max` bytes: a larger (or endless, `/dev/zero`) input fails
/// after reading `max + 1` bytes instead of growing memory without bound.
pub fn read_text_capped(path: &Path, max: u64) -> Result<String, Error> {
    use std::io::Read as _;
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let mut bytes = Vec::new();
    fs::File::open(path).map_err(io)?.take(max + 1).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        let reason = format!("larger than {max} bytes; refusing to read it whole");
        return Err(Error::Scene { path: path.to_path_buf(), reason });
    }
    String::from_utf8(bytes).map_err(|e| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_that_do_not_exist_resolve_through_their_nearest_existing_ancestor() {
        let dir = tempfile::tempdir().unwrap();
        let base = fs::canonicalize(dir.path()).unwrap();
        fs::create_dir(dir.path().join("a")).unwrap();
        assert_eq!(resolve(&dir.path().join("a/./b/../c.parquet")), base.join("a/c.parquet"));
        assert_eq!(resolve(&dir.path().join("x/y/../z")), base.join("x/z"));
        assert_eq!(resolve(&dir.path().join("a/../a")), base.join("a"));
    }

    #[test]
    fn a_single_output_file_may_not_replace_or_enter_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("in.parquet");
        fs::write(&input, "x").unwrap();
        let e = check_output_file(&input, &[("the plotted input", &input)]).unwrap_err().to_string();
        assert!(e.contains("would replace the plotted input"), "{e}");
        let data = dir.path().join("data");
        fs::create_dir(&data).unwrap();
        let e = check_output_file(&data.join("m.json"), &[("the data directory", &data)]).unwrap_err().to_string();
        assert!(e.contains("inside the data directory"), "{e}");
        let e = check_output_file(&data, &[]).unwrap_err().to_string();
        assert!(e.contains("is a directory"), "{e}");
        assert!(check_output_file(&dir.path().join("in.png"), &[("the plotted input", &input)]).is_ok());
    }

    #[test]
    fn text_reads_are_capped() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.toml");
        fs::write(&p, "x".repeat(11)).unwrap();
        assert_eq!(read_text_capped(&p, 11).unwrap().len(), 11);
        assert!(read_text_capped(&p, 10).unwrap_err().to_string().contains("larger than 10 bytes"));
        if Path::new("/dev/zero").exists() {
            assert!(read_text_capped(Path::new("/dev/zero"), 1 << 20).is_err());
        }
    }
}
