//! Whole files as they are: the SHA-256 of a file's bytes (so that a rerun can tell
//! which inputs changed) and a file's UTF-8 text (manifests, caches). Errors name the
//! file.

use std::io::Read;
use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};
use thiserror::Error;

/// Why a file could not be read.
#[derive(Debug, Error)]
pub enum ReadFileError {
    /// The operating system could not read it.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// It is not UTF-8 text.
    #[error("{} is not UTF-8 text (byte {offset})", path.display())]
    NotText {
        /// The file.
        path: PathBuf,
        /// Offset of the first invalid byte.
        offset: usize,
    },
}

/// The SHA-256 of the bytes of `path` as 64 lower-case hexadecimal digits, read in
/// blocks of 64 KiB (memory stays small for large maps and stacks). For a directory (a
/// Zarr store), the SHA-256 of its files in name order, each as its `/`-separated
/// relative path, a 0 byte, its length (8 bytes, little-endian) and its bytes: equal
/// for two directories holding the same files.
///
/// # Errors
/// [`ReadFileError::Io`] naming the file.
pub fn sha256_file(path: impl AsRef<Path>) -> Result<String, ReadFileError> {
    let path = path.as_ref();
    let mut hasher = Sha256::new();
    if path.is_dir() {
        let io = |source| ReadFileError::Io {
            path: path.to_path_buf(),
            source,
        };
        for (rel, file) in tree_files(path).map_err(io)? {
            let len = std::fs::metadata(&file).map_err(io)?.len();
            hasher.update(rel.as_bytes());
            hasher.update([0u8]);
            hasher.update(len.to_le_bytes());
            hash_into(&file, &mut hasher)?;
        }
    } else {
        hash_into(path, &mut hasher)?;
    }
    Ok(hex(&hasher.finalize()))
}

/// Feeds the bytes of the file `path` to `hasher`.
fn hash_into(path: &Path, hasher: &mut Sha256) -> Result<(), ReadFileError> {
    let io = |source| ReadFileError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path)
        .map_err(|e| explain_open_error(path, e))
        .map_err(io)?;
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = file.read(&mut buf).map_err(io)?;
        if n == 0 {
            return Ok(());
        }
        hasher.update(&buf[..n]);
    }
}

/// The files under the directory `dir` (links followed), as (`/`-separated relative
/// path, path), in name order.
fn tree_files(dir: &Path) -> std::io::Result<Vec<(String, PathBuf)>> {
    fn walk(dir: &Path, rel: &str, out: &mut Vec<(String, PathBuf)>) -> std::io::Result<()> {
        let mut entries: Vec<_> = std::fs::read_dir(dir)?.collect::<Result<_, _>>()?;
        entries.sort_by_key(std::fs::DirEntry::file_name);
        for e in entries {
            let name = e.file_name().to_string_lossy().into_owned();
            let rel = if rel.is_empty() {
                name
            } else {
                format!("{rel}/{name}")
            };
            let path = e.path();
            if path.is_dir() {
                walk(&path, &rel, out)?;
            } else {
                out.push((rel, path));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)?;
    Ok(out)
}

/// The SHA-256 of `bytes` as 64 lower-case hexadecimal digits.
#[must_use]
pub fn sha256_bytes(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

fn hex(bytes: &[u8]) -> String {
    use std::fmt::Write as _;
    bytes.iter().fold(String::with_capacity(64), |mut s, b| {
        let _ = write!(s, "{b:02x}");
        s
    })
}

/// Whether `a` and `b` resolve to the same canonical path (`./a`, `sub/../a` and a
/// symbolic link to `a` all do; a hard link does not: see [`same_file`]). `false` when
/// either cannot be resolved.
#[must_use]
pub fn same_path(a: impl AsRef<Path>, b: impl AsRef<Path>) -> bool {
    matches!(
        (std::fs::canonicalize(a.as_ref()), std::fs::canonicalize(b.as_ref())),
        (Ok(x), Ok(y)) if x == y
    )
}

/// Whether `a` and `b` name the same existing file: the same canonical path (so `./a`,
/// `sub/../a` and a symbolic link to `a` all match `a`), or, on Unix, the same device
/// and inode (a hard link). `false` when either cannot be resolved (a missing file is
/// the same as nothing).
#[must_use]
pub fn same_file(a: impl AsRef<Path>, b: impl AsRef<Path>) -> bool {
    let (a, b) = (a.as_ref(), b.as_ref());
    if same_path(a, b) {
        return true;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt as _;
        if let (Ok(x), Ok(y)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return x.dev() == y.dev() && x.ino() == y.ino();
        }
    }
    false
}

/// A symbolic link whose target does not exist (at any depth of links).
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("{} is a symbolic link to {}, which does not exist", link.display(), target.display())]
pub struct DanglingLink {
    /// The link.
    pub link: PathBuf,
    /// What it points to, as written in the link (`?` if it cannot be read).
    pub target: PathBuf,
}

/// `Some` when `path` is a symbolic link whose target (followed through every link)
/// does not exist; `None` for anything else, including a path that does not exist at
/// all or a link that resolves.
#[must_use]
pub fn dangling_link(path: impl AsRef<Path>) -> Option<DanglingLink> {
    let path = path.as_ref();
    let meta = std::fs::symlink_metadata(path).ok()?;
    if !meta.file_type().is_symlink() || std::fs::metadata(path).is_ok() {
        return None;
    }
    Some(DanglingLink {
        link: path.to_path_buf(),
        target: std::fs::read_link(path).unwrap_or_else(|_| PathBuf::from("?")),
    })
}

/// `error`, from opening `path`, with the dangling link named when `path` is one: a
/// "No such file or directory" that only says the link's name would hide that the file
/// exists as a link whose target is gone.
#[must_use]
pub fn explain_open_error(path: &Path, error: std::io::Error) -> std::io::Error {
    match dangling_link(path) {
        Some(d) if error.kind() == std::io::ErrorKind::NotFound => {
            std::io::Error::new(error.kind(), d.to_string())
        }
        _ => error,
    }
}

/// The entries of the directory `dir`, as `dir` joined with each name, in the order the
/// system lists them (links not followed; `.` and `..` left out).
///
/// # Errors
/// The operating-system error of listing the directory or reading an entry.
pub fn list_dir(dir: impl AsRef<Path>) -> std::io::Result<Vec<PathBuf>> {
    std::fs::read_dir(dir.as_ref())?
        .map(|e| e.map(|e| e.path()))
        .collect()
}

/// The length in bytes of the file `path` (links followed), or `None` when it cannot be
/// read; for a directory (a Zarr store), the total length of the files under it.
#[must_use]
pub fn file_len(path: impl AsRef<Path>) -> Option<u64> {
    let path = path.as_ref();
    let meta = std::fs::metadata(path).ok()?;
    if !meta.is_dir() {
        return Some(meta.len());
    }
    tree_files(path)
        .ok()?
        .iter()
        .map(|(_, p)| std::fs::metadata(p).ok().map(|m| m.len()))
        .sum()
}

/// The text of `path` (UTF-8; a leading byte-order mark is dropped).
///
/// # Errors
/// [`ReadFileError::Io`] or [`ReadFileError::NotText`] naming the file.
pub fn read_text(path: impl AsRef<Path>) -> Result<String, ReadFileError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| ReadFileError::Io {
        path: path.to_path_buf(),
        source: explain_open_error(path, source),
    })?;
    let text = String::from_utf8(bytes).map_err(|e| ReadFileError::NotText {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })?;
    Ok(text
        .strip_prefix('\u{feff}')
        .map(str::to_owned)
        .unwrap_or(text))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_known_strings() {
        // FIPS 180-2 test vectors ("abc" and the empty string).
        assert_eq!(
            sha256_bytes(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            sha256_bytes(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }

    #[test]
    fn file_hash_equals_byte_hash_across_blocks() {
        let dir =
            std::env::temp_dir().join(format!("flakescatter-io-files-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("big.bin");
        // Three and a half blocks of 64 KiB.
        let bytes: Vec<u8> = (0..(7u32 << 15)).map(|i| (i * 7 + 3) as u8).collect();
        std::fs::write(&p, &bytes).unwrap();
        assert_eq!(sha256_file(&p).unwrap(), sha256_bytes(&bytes));
        std::fs::write(&p, b"\xef\xbb\xbfname = 1\n").unwrap();
        assert_eq!(read_text(&p).unwrap(), "name = 1\n");
        std::fs::write(&p, b"ok\xff").unwrap();
        let e = read_text(&p).unwrap_err().to_string();
        assert!(e.contains("big.bin") && e.contains("byte 2"), "{e}");
        let missing = dir.join("missing.toml");
        assert!(
            sha256_file(&missing)
                .unwrap_err()
                .to_string()
                .contains("missing.toml")
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn directories_hash_their_files_by_name_and_content() {
        let dir = tempfile_dir("dirs");
        let (a, b) = (dir.join("a.zarr"), dir.join("b.zarr"));
        for d in [&a, &b] {
            std::fs::create_dir_all(d.join("height/c")).unwrap();
            std::fs::write(d.join("zarr.json"), b"{}").unwrap();
            std::fs::write(d.join("height/c/0"), b"12345").unwrap();
        }
        assert_eq!(file_len(&a), Some(7));
        // The hash of the files as documented, computed here from the bytes.
        let mut want = Vec::new();
        for (rel, bytes) in [("height/c/0", &b"12345"[..]), ("zarr.json", &b"{}"[..])] {
            want.extend_from_slice(rel.as_bytes());
            want.push(0);
            want.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
            want.extend_from_slice(bytes);
        }
        assert_eq!(sha256_file(&a).unwrap(), sha256_bytes(&want));
        assert_eq!(sha256_file(&a).unwrap(), sha256_file(&b).unwrap());
        // One byte of one chunk changed, or a file renamed: another hash.
        std::fs::write(b.join("height/c/0"), b"12346").unwrap();
        assert_ne!(sha256_file(&a).unwrap(), sha256_file(&b).unwrap());
        std::fs::write(b.join("height/c/0"), b"12345").unwrap();
        std::fs::rename(b.join("height/c/0"), b.join("height/c/1")).unwrap();
        assert_ne!(sha256_file(&a).unwrap(), sha256_file(&b).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    fn tempfile_dir(what: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("flakescatter-io-{what}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[cfg(unix)]
    #[test]
    fn same_file_and_dangling_links() {
        let dir =
            std::env::temp_dir().join(format!("flakescatter-io-links-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let a = dir.join("a.txt");
        std::fs::write(&a, b"1").unwrap();
        std::fs::write(dir.join("b.txt"), b"1").unwrap();
        std::fs::hard_link(&a, dir.join("hard.txt")).unwrap();
        std::os::unix::fs::symlink(&a, dir.join("soft.txt")).unwrap();
        std::os::unix::fs::symlink(dir.join("gone.txt"), dir.join("dangling.txt")).unwrap();
        // A link to the dangling link: dangling at depth 2.
        std::os::unix::fs::symlink(dir.join("dangling.txt"), dir.join("chain.txt")).unwrap();
        for same in ["hard.txt", "soft.txt", "sub/../a.txt", "a.txt"] {
            assert!(same_file(&a, dir.join(same)), "{same}");
        }
        // Equal bytes are another file; a missing file is the same as nothing.
        assert!(!same_file(&a, dir.join("b.txt")));
        assert!(same_path(&a, dir.join("soft.txt")) && same_path(&a, dir.join("sub/../a.txt")));
        assert!(!same_path(&a, dir.join("hard.txt")));
        assert!(!same_file(dir.join("gone.txt"), dir.join("gone.txt")));
        let d = dangling_link(dir.join("dangling.txt")).unwrap();
        assert_eq!(d.target, dir.join("gone.txt"));
        assert!(d.to_string().contains("which does not exist"), "{d}");
        assert!(dangling_link(dir.join("chain.txt")).is_some());
        for not in ["soft.txt", "a.txt", "gone.txt", "sub"] {
            assert!(dangling_link(dir.join(not)).is_none(), "{not}");
        }
        let mut listed = list_dir(&dir).unwrap();
        listed.sort();
        assert_eq!(listed.len(), 7, "{listed:?}");
        assert!(listed.contains(&dir.join("dangling.txt")));
        assert_eq!(file_len(&a), Some(1));
        // Reading through a dangling link names it and its target.
        let e = read_text(dir.join("dangling.txt")).unwrap_err().to_string();
        assert!(
            e.contains("dangling.txt is a symbolic link to") && e.contains("gone.txt"),
            "{e}"
        );
        let e = read_text(dir.join("gone.txt")).unwrap_err().to_string();
        assert!(!e.contains("symbolic link"), "{e}");
        assert_eq!(file_len(dir.join("dangling.txt")), None);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
