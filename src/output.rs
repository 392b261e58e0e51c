//! Every file rtdiff writes is written whole or not at all: into a temporary
//! file in the destination's folder, flushed to disk, then renamed over the
//! destination (an atomic replacement on POSIX file systems). A process killed
//! at any moment (SIGKILL included) leaves either the previous file or the new
//! one, never a truncated mix; at worst a hidden temporary file
//! (`.NAME.HOST.PID.N.tmp`) is left beside it, which [`remove_stale_temps`]
//! clears once its process is gone.
//!
//! Destinations that are not regular files (`/dev/stdout`, a named pipe,
//! `/dev/null`) are written in place: they cannot be replaced by a rename. A
//! symbolic link is followed, so the file it points to is replaced and the link
//! kept.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};

/// Write `bytes` to `path` atomically (see the module docs).
pub fn write(path: &Path, bytes: impl AsRef<[u8]>) -> Result<()> {
    write_with(path, |w| w.write_all(bytes.as_ref()))
}

/// Write the file `path` atomically with `fill`, which streams its contents
/// into a buffered writer (for files too large to assemble in memory).
pub fn write_with(path: &Path, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<()> {
    let mut f = AtomicFile::create(path)?;
    fill(&mut f).map_err(|e| Error::file(path, format!("cannot write: {e}")))?;
    f.commit()
}

/// Serialise `value` as pretty JSON (with a final newline) and write it atomically to `path`.
pub fn write_json<T: serde::Serialize + ?Sized>(path: &Path, value: &T) -> Result<()> {
    let mut s = serde_json::to_string_pretty(value).map_err(|e| Error::file(path, format!("cannot serialise: {e}")))?;
    s.push('\n');
    write(path, s)
}

/// A file being written: a temporary file beside the destination, renamed into
/// place by [`AtomicFile::commit`]. Dropped without a commit (an error, a
/// panic), it removes its temporary file and leaves the destination untouched.
pub struct AtomicFile {
    dest: PathBuf,
    /// The temporary file, `None` when the destination is written in place.
    tmp: Option<PathBuf>,
    file: Option<BufWriter<File>>,
}

static COUNTER: AtomicU64 = AtomicU64::new(0);

/// The marker every temporary file name ends with.
const TMP_SUFFIX: &str = ".tmp";

fn host() -> String {
    #[cfg(unix)]
    {
        let mut buf = [0u8; 256];
        // SAFETY: the buffer is valid for its length; gethostname writes at most that many bytes.
        if unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0 {
            let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
            let name: String = String::from_utf8_lossy(&buf[..end])
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() || c == '-' { c } else { '_' })
                .collect();
            if !name.is_empty() {
                return name;
            }
        }
    }
    "host".into()
}

impl AtomicFile {
    /// Start writing `path`. Fails (naming the file) when its folder does not
    /// exist or cannot be written.
    pub fn create(path: &Path) -> Result<Self> {
        // A link is followed, so that the file it names is the one replaced.
        let dest = match std::fs::symlink_metadata(path) {
            Ok(m) if m.file_type().is_symlink() => std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf()),
            _ => path.to_path_buf(),
        };
        if let Ok(m) = std::fs::metadata(&dest)
            && !m.is_file()
        {
            if m.is_dir() {
                return Err(Error::file(path, "cannot write: it is a folder"));
            }
            // A device or a pipe: written in place.
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(&dest)
                .map_err(|e| Error::file(path, format!("cannot write: {e}")))?;
            return Ok(Self { dest, tmp: None, file: Some(BufWriter::new(file)) });
        }
        let name = dest.file_name().ok_or_else(|| Error::file(path, "cannot write: not a file name"))?;
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = dir.join(format!(".{}.{}.{}.{n}{TMP_SUFFIX}", name.to_string_lossy(), host(), std::process::id()));
        let file = std::fs::OpenOptions::new().write(true).create_new(true).open(&tmp).map_err(|e| {
            let why = if e.kind() == std::io::ErrorKind::NotFound {
                format!("cannot write: the folder {} does not exist", dir.display())
            } else {
                format!("cannot write: {e}")
            };
            Error::file(path, why)
        })?;
        Ok(Self { dest, tmp: Some(tmp), file: Some(BufWriter::new(file)) })
    }

    /// Flush the contents to disk and rename the temporary file over the
    /// destination (then flush the folder's entry, where the system allows).
    pub fn commit(mut self) -> Result<()> {
        let file = self.file.take().expect("an uncommitted AtomicFile has its file");
        let err = |e: std::io::Error| Error::file(&self.dest, format!("cannot write: {e}"));
        let file = file.into_inner().map_err(|e| err(e.into_error()))?;
        let Some(tmp) = self.tmp.clone() else {
            return Ok(());
        };
        file.sync_all().map_err(err)?;
        drop(file);
        std::fs::rename(&tmp, &self.dest).map_err(err)?;
        self.tmp = None;
        #[cfg(unix)]
        if let Some(dir) = self.dest.parent() {
            let dir = if dir.as_os_str().is_empty() { Path::new(".") } else { dir };
            // Some file systems refuse to sync a folder; the rename itself is done.
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
        }
        Ok(())
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.file.as_mut().expect("an uncommitted AtomicFile has its file").write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.as_mut().expect("an uncommitted AtomicFile has its file").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if let Some(tmp) = &self.tmp {
            self.file = None;
            let _ = std::fs::remove_file(tmp);
        }
    }
}

/// Remove the temporary files that processes of this host killed while writing
/// into `dir` left behind (their process is gone); returns how many. Temporary
/// files of live processes and of other hosts (a shared folder) are left alone.
pub fn remove_stale_temps(dir: &Path) -> Result<usize> {
    let host = host();
    let mut removed = 0;
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, &e))?;
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(rest) = name.strip_prefix('.').and_then(|n| n.strip_suffix(TMP_SUFFIX)) else { continue };
        // NAME.HOST.PID.N: the last three dot-separated fields.
        let mut parts = rest.rsplitn(4, '.');
        let (Some(_n), Some(pid), Some(h), Some(_)) = (parts.next(), parts.next(), parts.next(), parts.next()) else {
            continue;
        };
        let Ok(pid) = pid.parse::<u32>() else { continue };
        if h == host && !process_alive(pid) && std::fs::remove_file(e.path()).is_ok() {
            removed += 1;
        }
    }
    Ok(removed)
}

fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    #[cfg(unix)]
    {
        let Ok(pid) = libc::pid_t::try_from(pid) else { return false };
        // SAFETY: signal 0 only checks that the process exists.
        let r = unsafe { libc::kill(pid, 0) };
        r == 0 || std::io::Error::last_os_error().raw_os_error() == Some(libc::EPERM)
    }
    #[cfg(not(unix))]
    {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("rtdiff-output-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn listing(d: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn replaces_the_file_and_leaves_nothing_beside_it() {
        let d = dir("replace");
        let p = d.join("a.txt");
        write(&p, "old").unwrap();
        write(&p, "new contents").unwrap();
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "new contents");
        assert_eq!(listing(&d), ["a.txt"]);
    }

    #[test]
    fn a_failed_fill_keeps_the_previous_file() {
        let d = dir("fail");
        let p = d.join("a.txt");
        write(&p, "old").unwrap();
        let e = write_with(&p, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk on fire"))
        })
        .unwrap_err()
        .to_string();
        assert!(e.contains("a.txt") && e.contains("disk on fire"), "{e}");
        assert_eq!(std::fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(listing(&d), ["a.txt"]);
    }

    #[test]
    fn a_missing_folder_is_named() {
        let d = dir("missing");
        let e = write(&d.join("no/such/a.txt"), "x").unwrap_err().to_string();
        assert!(e.contains("does not exist") && e.contains("no/such"), "{e}");
        let e = write(&d, "x").unwrap_err().to_string();
        assert!(e.contains("it is a folder"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn a_link_is_followed_and_a_pipe_written_in_place() {
        use std::os::unix::fs::FileTypeExt;
        let d = dir("link");
        write(&d.join("target.txt"), "old").unwrap();
        std::os::unix::fs::symlink(d.join("target.txt"), d.join("link.txt")).unwrap();
        write(&d.join("link.txt"), "new").unwrap();
        assert!(std::fs::symlink_metadata(d.join("link.txt")).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read_to_string(d.join("target.txt")).unwrap(), "new");
        // A named pipe (like /dev/stdout) is written, not replaced.
        let fifo = d.join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        write(&fifo, "through the pipe").unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe");
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    }

    #[test]
    fn stale_temps_of_dead_processes_are_removed_and_live_ones_kept() {
        let d = dir("stale");
        let h = host();
        // A pid that cannot be running (above the kernel's limit), one that is (ours), another host's.
        let dead = d.join(format!(".r.json.{h}.4194999.0.tmp"));
        let live = d.join(format!(".r.json.{h}.{}.0.tmp", std::process::id()));
        let other = d.join(".r.json.elsewhere.4194999.0.tmp");
        for p in [&dead, &live, &other] {
            std::fs::write(p, "x").unwrap();
        }
        assert_eq!(remove_stale_temps(&d).unwrap(), 1);
        assert!(!dead.exists() && live.exists() && other.exists());
    }
}
