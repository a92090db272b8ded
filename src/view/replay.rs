//! `gradtac view`: replay Parquet outputs (any schema, any version) into a view.

use super::ViewHandle;
use crate::Error;
use std::fmt;
use std::path::Path;

/// What [`replay`] read.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReplaySummary {
    /// Parquet files read.
    pub files: usize,
    /// Rows read (every row: nothing is decimated).
    pub rows: u64,
    /// Their schema ids (`frame/2`, `track/1`, …), in order of appearance.
    pub schemas: Vec<String>,
    /// Unfinished `.partial` files skipped.
    pub partial: usize,
}

impl fmt::Display for ReplaySummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "replayed {} rows from {} Parquet files ({})", self.rows, self.files, self.schemas.join(", "))?;
        if self.partial > 0 {
            writeln!(f, "  skipped {} unfinished `.partial` files", self.partial)?;
        }
        Ok(())
    }
}

/// Replay `input` into the view behind `handle`: one Parquet file written by a gradtac sink, or
/// a directory read recursively (a run's output directory, an archive with its `sensor=<name>/`
/// partitions; `.partial`, hidden and `_` files skipped). Every schema version
/// (`docs/schemas.md`) is read; each file is read one row group at a time (memory stays at a
/// row group's). Files of several schemas may be mixed: each goes to its own entities.
///
/// Records go through the handle like a live run's; a lossless view
/// ([`ViewOptions::lossless`](super::ViewOptions::lossless), what `gradtac view` uses) logs
/// them all.
///
/// # Errors
/// [`Error::View`] naming the file (and row group) that is unreadable, not a gradtac output, or
/// of an unknown schema; a directory without a finished Parquet file.
pub fn replay(input: &Path, handle: &ViewHandle) -> Result<ReplaySummary, Error> {
    if !input.exists() {
        return Err(Error::View(format!("{}: no such file or directory", input.display())));
    }
    let counts = crate::plot::view_read::replay_records(input, &mut |recs| {
        let (sensors, rest): (Vec<_>, Vec<_>) =
            recs.into_iter().partition(|r| matches!(r, super::rec::Rec::Sensor { .. }));
        for s in sensors {
            if let super::rec::Rec::Sensor { sensor, layout, clock } = s {
                handle.sensor(&sensor, layout.as_ref(), clock);
            }
        }
        handle.offer(rest);
    })?;
    Ok(ReplaySummary { files: counts.files, rows: counts.rows, schemas: counts.schemas, partial: counts.partial })
}
