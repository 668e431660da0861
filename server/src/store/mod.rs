//! The coordinator's durable state, under `--data DIR`:
//!
//! ```text
//! tessera.redb                     redb: table `jobs` (job id → JSON JobRecord), `meta` (boot count)
//! jobs/<job id>/t<tile>-b<n>.sums  a tile's merged f64 sums after its batches 0..n (tile_file.rs)
//! jobs/<job id>.exr                an ended job's image (`<job id>.f<frame>.exr` per frame of an
//!                                  animation, written as each completes); once an image is
//!                                  written its sums leave memory and their files go
//! scenes/<sha256>                  uploaded scenes, content-addressed (crate::scenes)
//! ```
//!
//! A checkpoint writes the new tile files first (temp file, fsync, rename, then one fsync of the
//! directory), then commits one redb transaction with the job records that name them, and only
//! then deletes the files they supersede. A crash at any point leaves either the old records with
//! their old files or the new records with their new files; files no record names are deleted
//! when the coordinator starts. redb commits are crash-safe (copy-on-write with checksums).
pub mod tile_file;

use crate::scheduler::{JobRecord, RestoredTile, TileCheckpoint, TileMark};
use anyhow::Context;
use redb::{Database, ReadableDatabase, ReadableTable, TableDefinition};
use std::io::Write;
use std::path::{Path, PathBuf};

const JOBS: TableDefinition<&str, &[u8]> = TableDefinition::new("jobs");
const META: TableDefinition<&str, u64> = TableDefinition::new("meta");

pub struct Store {
    /// None after a failed reopen. redb refuses all work after an I/O error (e.g. a full disk)
    /// until the database is closed and opened again, which `with_db` does.
    db: std::sync::Mutex<Option<Database>>,
    path: PathBuf,
    jobs_dir: PathBuf,
}

impl Store {
    pub fn open(data_dir: &Path) -> anyhow::Result<Store> {
        let jobs_dir = data_dir.join("jobs");
        std::fs::create_dir_all(&jobs_dir)
            .with_context(|| format!("creating {}", jobs_dir.display()))?;
        let path = data_dir.join("tessera.redb");
        let db = Database::create(&path)
            .with_context(|| format!("opening the job store {}", path.display()))?;
        Ok(Store { db: std::sync::Mutex::new(Some(db)), path, jobs_dir })
    }

    /// Runs `f` on the database; after a failure, closes and reopens it so the next call works
    /// once the cause (a full disk) is gone.
    fn with_db<T>(&self, f: impl FnOnce(&Database) -> anyhow::Result<T>) -> anyhow::Result<T> {
        let mut guard = self.db.lock().expect("lock");
        if guard.is_none() {
            *guard = Some(
                Database::create(&self.path)
                    .with_context(|| format!("reopening the job store {}", self.path.display()))?,
            );
        }
        let outcome = f(guard.as_ref().expect("opened"));
        if outcome.is_err() {
            *guard = None;
        }
        outcome
    }

    /// Counts coordinator starts; the count makes ids unique across restarts.
    pub fn next_boot(&self) -> anyhow::Result<u64> {
        self.with_db(|db| {
            let tx = db.begin_write()?;
            let boot = {
                let mut meta = tx.open_table(META)?;
                let boot = meta.get("boot")?.map(|v| v.value()).unwrap_or(0) + 1;
                meta.insert("boot", boot)?;
                boot
            };
            tx.commit()?;
            Ok(boot)
        })
    }

    /// Every stored job, oldest first.
    pub fn load_jobs(&self) -> anyhow::Result<Vec<JobRecord>> {
        self.with_db(Self::read_jobs)
    }

    fn read_jobs(db: &Database) -> anyhow::Result<Vec<JobRecord>> {
        let tx = db.begin_read()?;
        let table = match tx.open_table(JOBS) {
            Ok(t) => t,
            Err(redb::TableError::TableDoesNotExist(_)) => return Ok(Vec::new()),
            Err(e) => return Err(e.into()),
        };
        let mut jobs = Vec::new();
        for row in table.iter()? {
            let (key, value) = row?;
            match serde_json::from_slice::<JobRecord>(value.value()) {
                Ok(r) => jobs.push(r),
                Err(e) => {
                    tracing::error!(job = key.value(), "skipping an unreadable job record: {e}")
                }
            }
        }
        jobs.sort_by_key(|r| r.seq);
        Ok(jobs)
    }

    /// Records jobs (one transaction; on return they are durable).
    pub fn commit(&self, records: &[&JobRecord]) -> anyhow::Result<()> {
        self.with_db(|db| {
            let tx = db.begin_write()?;
            {
                let mut table = tx.open_table(JOBS)?;
                for r in records {
                    table.insert(r.cfg.id.as_str(), serde_json::to_vec(r)?.as_slice())?;
                }
            }
            tx.commit()?;
            Ok(())
        })
    }

    /// Deletes a job's record (one transaction; a restart no longer sees the job), then its
    /// checkpoint files.
    pub fn delete_job(&self, job_id: &str) -> anyhow::Result<()> {
        self.with_db(|db| {
            let tx = db.begin_write()?;
            tx.open_table(JOBS)?.remove(job_id)?;
            tx.commit()?;
            Ok(())
        })?;
        match std::fs::remove_dir_all(self.job_dir(job_id)) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                tracing::warn!(job = job_id, "removing its checkpoint files: {e}")
            }
            _ => {}
        }
        Ok(())
    }

    fn job_dir(&self, job_id: &str) -> PathBuf {
        self.jobs_dir.join(job_id)
    }

    /// Writes tile checkpoints durably (before the records naming them are committed).
    pub fn write_tiles(&self, job_id: &str, tiles: &[TileCheckpoint]) -> anyhow::Result<()> {
        if tiles.is_empty() {
            return Ok(());
        }
        let dir = self.job_dir(job_id);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        for t in tiles {
            let bytes = tile_file::encode(t.tile, t.upto, t.dropped, t.max_weight, &t.sums);
            let path = dir.join(tile_file::file_name(t.tile, t.upto));
            let tmp = dir.join(format!(".{}.tmp", tile_file::file_name(t.tile, t.upto)));
            let mut f = std::fs::File::create(&tmp)
                .with_context(|| format!("writing {}", tmp.display()))?;
            f.write_all(&bytes)
                .and_then(|_| f.sync_all())
                .with_context(|| format!("writing {}", tmp.display()))?;
            std::fs::rename(&tmp, &path).with_context(|| format!("renaming {}", tmp.display()))?;
        }
        std::fs::File::open(&dir)
            .and_then(|d| d.sync_all())
            .with_context(|| format!("syncing {}", dir.display()))?;
        Ok(())
    }

    /// Deletes checkpoint files superseded by a committed checkpoint.
    pub fn remove_superseded(&self, job_id: &str, tiles: &[TileCheckpoint]) {
        for t in tiles.iter().filter(|t| t.previous_upto > 0 && t.previous_upto != t.upto) {
            self.remove_tile_file(job_id, t.tile, t.previous_upto);
        }
    }

    fn remove_tile_file(&self, job_id: &str, tile: u32, upto: u32) {
        let _ = std::fs::remove_file(self.job_dir(job_id).join(tile_file::file_name(tile, upto)));
    }

    /// Deletes the checkpoint files `(tile, batches)` of tiles whose image is written (their
    /// records, committed, no longer name them).
    pub fn remove_tile_files(&self, job_id: &str, files: &[(u32, u32)]) {
        for &(tile, upto) in files {
            self.remove_tile_file(job_id, tile, upto);
        }
        if !files.is_empty() {
            // Gone once the job's last file is: an ended job keeps only its record and images.
            let _ = std::fs::remove_dir(self.job_dir(job_id));
        }
    }

    /// Reads a tile's checkpoint back, checking it is the one the record names.
    pub fn read_tile(
        &self,
        job_id: &str,
        tile: u32,
        mark: TileMark,
        pixels: usize,
    ) -> Result<RestoredTile, String> {
        let path = self.job_dir(job_id).join(tile_file::file_name(tile, mark.upto));
        let bytes = std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?;
        let f = tile_file::decode(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        if (f.tile, f.upto, f.sums.len()) != (tile, mark.upto, pixels) {
            return Err(format!(
                "{}: holds tile {} batches {} ({} px), not the recorded one",
                path.display(),
                f.tile,
                f.upto,
                f.sums.len()
            ));
        }
        Ok(RestoredTile { sums: f.sums, dropped: f.dropped, max_weight: f.max_weight })
    }

    /// Deletes files of a job's directory that its record does not name (a checkpoint that
    /// crashed before its commit, temp files).
    pub fn remove_orphans(&self, job_id: &str, marks: &[TileMark]) {
        let Ok(entries) = std::fs::read_dir(self.job_dir(job_id)) else { return };
        let keep: std::collections::HashSet<String> = marks
            .iter()
            .enumerate()
            .filter_map(|(i, m)| m.file_upto().map(|upto| tile_file::file_name(i as u32, upto)))
            .collect();
        for e in entries.flatten() {
            if !e.file_name().to_str().is_some_and(|n| keep.contains(n)) {
                tracing::debug!(file = %e.path().display(), "removing an orphaned checkpoint file");
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

#[cfg(test)]
mod tests;
