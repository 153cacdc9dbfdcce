//! Atomic file output: every file the toolchain writes (recordings, models, tables, reports,
//! plots) is first written to a temporary file in the destination's folder, synced, and then
//! renamed over the destination. A reader, or a run interrupted at any point, sees either the
//! old file or the complete new one, never a truncated table; a failed write removes its
//! temporary file and leaves the destination untouched.

use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The folder a temporary file for `path` goes in (rename is atomic only within one file
/// system, so it must be the destination's own folder).
fn folder(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Writes `bytes` to `path` atomically. The file gets the permissions of the file it
/// replaces, or read-write for the owner and read for others when it is new (a temporary
/// file is created private, and a report or table must stay readable after the rename).
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut tmp = tempfile::NamedTempFile::new_in(folder(path))?;
    tmp.write_all(bytes)?;
    if let Some(p) = permissions_for(path) {
        tmp.as_file().set_permissions(p)?;
    }
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    Ok(())
}

/// The permissions a new version of `path` gets (see [`write`]); `None`: keep the temporary
/// file's own (only off Unix, where a new file's defaults are already shareable).
fn permissions_for(path: &Path) -> Option<std::fs::Permissions> {
    if let Ok(m) = std::fs::metadata(path) {
        return Some(m.permissions());
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        Some(std::fs::Permissions::from_mode(0o644))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Lets `produce` write a file at a temporary path (same folder, same extension, so writers
/// that pick a format by extension still work), then renames it over `path`. When `produce`
/// fails, the temporary file is removed and `path` is left as it was.
pub fn write_with<E>(path: &Path, produce: impl FnOnce(&Path) -> Result<(), E>) -> Result<(), E>
where
    E: From<std::io::Error>,
{
    let tmp = temp_path(path);
    let result = produce(&tmp).and_then(|()| {
        std::fs::File::open(&tmp)?.sync_all()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// `.<name>.<pid>.<n>.tmp.<ext>` beside `path`: hidden, unique per process and call, and with
/// the destination's extension last.
fn temp_path(path: &Path) -> PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| format!(".{}", e.to_string_lossy()))
        .unwrap_or_default();
    folder(path).join(format!(".{stem}.{}.{n}.tmp{ext}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn write_replaces_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("table.rs");
        std::fs::write(&p, "old").unwrap();
        write(&p, b"new").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new");
        assert_eq!(entries(dir.path()), ["table.rs"]);
    }

    /// A writer that dies half-way (here: writes part of the file, then fails) must leave the
    /// old destination byte for byte and no stray temporary file.
    #[test]
    fn an_interrupted_write_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("model.png");
        std::fs::write(&p, "old contents").unwrap();
        let r: std::io::Result<()> = write_with(&p, |tmp| {
            assert_eq!(tmp.extension().unwrap(), "png");
            std::fs::write(tmp, "half of the new")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old contents");
        assert_eq!(entries(dir.path()), ["model.png"]);
    }

    /// A new file is readable by others (the temporary file it was renamed from is private);
    /// a replaced file keeps its permissions.
    #[cfg(unix)]
    #[test]
    fn permissions_are_shareable_or_kept() {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("report.md");
        write(&p, b"a").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&p), 0o644);
        std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
        write(&p, b"b").unwrap();
        assert_eq!(mode(&p), 0o600);
    }

    #[test]
    fn write_into_a_missing_folder_fails_cleanly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("no/such/folder/x.json");
        assert!(write(&p, b"x").is_err());
        assert!(write_with(&p, |tmp| std::fs::write(tmp, "x")).is_err());
        assert_eq!(entries(dir.path()), Vec::<String>::new());
    }
}
