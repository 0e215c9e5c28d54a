//! One writer per results folder: an OS lock on `FOLDER/.lock`, taken before a run touches
//! the folder (before `--force` removes anything) and held until the process ends, so a second
//! `run` on the same folder (fresh, `--resume` or `--force`) is refused in one line instead of
//! interleaving its rows with the first's. The OS releases the lock when the holder exits or is
//! killed, so a crashed run never leaves the folder locked.

use crate::Error;
use std::fs::{File, OpenOptions, TryLockError};
use std::io::Write;
use std::path::Path;

/// The lock file's name inside a results folder.
pub const LOCK_FILE: &str = ".lock";

/// A held folder lock (released when dropped or when the process ends).
#[derive(Debug)]
pub struct FolderLock {
    file: File,
}

impl FolderLock {
    /// Lock `dir` (created if missing) for this process, or say who holds it.
    pub fn acquire(dir: &Path) -> Result<FolderLock, Error> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let path = dir.join(LOCK_FILE);
        let mut file = OpenOptions::new()
            .create(true)
            .truncate(false)
            .read(true)
            .write(true)
            .open(&path)
            .map_err(|e| Error::io(&path, e))?;
        match file.try_lock() {
            Ok(()) => {
                // Who holds it, for the message of a refused second run.
                let _ = file.set_len(0);
                let _ = write!(
                    file,
                    "pid {}, since {}",
                    std::process::id(),
                    crate::meta::now_rfc3339()
                );
                let _ = file.flush();
                Ok(FolderLock { file })
            }
            Err(TryLockError::WouldBlock) => {
                let who = std::fs::read_to_string(&path).unwrap_or_default();
                let who = if who.trim().is_empty() {
                    String::new()
                } else {
                    format!(" ({})", who.trim())
                };
                Err(Error::io(
                    dir,
                    format!(
                        "another trace-bench run is writing to this folder{who}: wait for it to \
                         end, or choose another --out"
                    ),
                ))
            }
            Err(TryLockError::Error(e)) => Err(Error::io(&path, e)),
        }
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let _ = self.file.set_len(0);
        let _ = self.file.unlock();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_on_a_held_folder_is_refused_and_released_on_drop() {
        let dir = tempfile::tempdir().unwrap();
        let first = FolderLock::acquire(dir.path()).unwrap();
        let e = FolderLock::acquire(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("another trace-bench run is writing to this folder")
                && e.contains(&format!("pid {}", std::process::id())),
            "{e}"
        );
        drop(first);
        FolderLock::acquire(dir.path()).expect("free again");
    }
}
