//! Guards for reading files that someone else wrote: only regular files are read, never
//! more than a bound; paths a scene file names stay inside its folder unless the user
//! allows otherwise; names and paths quoted in errors are escaped so an error stays one
//! line. The limits are documented for users in docs/SCENES.md ("Limits").

use anyhow::{bail, Context, Result};
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// Largest file read as a scene, mesh or glTF buffer: far above any scene that renders
/// at an interactive rate, far below what would exhaust the memory of a CI runner.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Most triangles a loaded scene may have, counting every instance of a shared mesh
/// (each instance is drawn and ray cast on its own). Checked from declared counts before
/// the triangles are read, so a small file cannot ask for gigabytes.
pub const MAX_SCENE_TRIANGLES: usize = 1 << 24;

/// Most vertices read from mesh data over a whole scene (each distinct mesh once): three
/// per triangle of `MAX_SCENE_TRIANGLES`, the most a triangle soup needs.
pub const MAX_SCENE_VERTICES: usize = 3 * MAX_SCENE_TRIANGLES;

/// How scene files may reach other files.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Let a scene file's mesh paths and glTF buffer URIs leave the scene file's folder
    /// (`--allow-outside-paths`). Off: only the folder and its subfolders, after symlinks.
    pub allow_outside_paths: bool,
}

/// At most this many characters of a name from a file are quoted in an error.
const NAME_MAX: usize = 80;

/// `s` as it may appear in a one-line error: control and other non-printing characters
/// escaped (`\n`, `\u{1b}`), clipped to a short length.
pub fn shown(s: &str) -> String {
    clip(&escape(s), NAME_MAX)
}

/// A path for a one-line error: escaped, not clipped (the user needs all of it).
pub fn shown_path(p: &Path) -> String {
    escape(&p.display().to_string())
}

/// A token quoted from a file that failed to parse: printable and at most `max` characters.
pub fn token(s: &str, max: usize) -> String {
    clip(&escape(s), max)
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        if c.is_control() || matches!(c, '\u{2028}' | '\u{2029}' | '\u{85}') {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

fn clip(s: &str, max: usize) -> String {
    if s.chars().count() <= max {
        s.to_owned()
    } else {
        let head: String = s.chars().take(max).collect();
        format!("{head}...")
    }
}

/// What a file system entry is when it is not a regular file.
fn not_regular(meta: &std::fs::Metadata) -> Option<&'static str> {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    if t.is_file() {
        None
    } else if t.is_dir() {
        Some("a folder")
    } else if t.is_fifo() {
        Some("a FIFO (named pipe)")
    } else if t.is_char_device() || t.is_block_device() {
        Some("a device")
    } else if t.is_socket() {
        Some("a socket")
    } else {
        Some("not a regular file")
    }
}

/// Checks, without opening it (a FIFO would block the open), that `path` is a regular
/// file (after symlinks). `label` names it in the error.
pub fn check_regular(path: &Path, label: &str) -> Result<std::fs::Metadata> {
    let meta = std::fs::metadata(path).with_context(|| format!("{label}: cannot read the file"))?;
    if let Some(kind) = not_regular(&meta) {
        bail!("{label}: is {kind}, not a regular file: refused before reading");
    }
    Ok(meta)
}

/// The bytes of the regular file `path`, refused before reading when it is not a regular
/// file or is larger than `MAX_FILE_BYTES`. `label` names it in errors.
pub fn read_file(path: &Path, label: &str) -> Result<Vec<u8>> {
    let meta = check_regular(path, label)?;
    if meta.len() > MAX_FILE_BYTES {
        bail!(
            "{label}: {} bytes is above the limit of {MAX_FILE_BYTES} bytes per input file",
            meta.len()
        );
    }
    let file =
        std::fs::File::open(path).with_context(|| format!("{label}: cannot read the file"))?;
    // Swapped for something else since the check: the same checks on what was opened.
    let opened = file
        .metadata()
        .with_context(|| format!("{label}: cannot read the file"))?;
    if let Some(kind) = not_regular(&opened) {
        bail!("{label}: is {kind}, not a regular file: refused before reading");
    }
    let mut bytes = Vec::with_capacity(opened.len().min(MAX_FILE_BYTES) as usize);
    file.take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .with_context(|| format!("{label}: cannot read the file"))?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        bail!("{label}: grew past the limit of {MAX_FILE_BYTES} bytes per input file while read");
    }
    Ok(bytes)
}

/// Resolves `rel`, a path written in a scene file, against the scene file's folder `dir`.
/// Unless `opts` allows it, the result must lie inside `dir` or its subfolders: an absolute
/// path or one that climbs out with `..` is refused without touching the file system, and
/// a path that leaves through a symlink is refused once resolved. `what` names the path
/// in errors ("object 2's mesh").
pub fn resolve_inside(dir: &Path, rel: &Path, opts: &LoadOptions, what: &str) -> Result<PathBuf> {
    let joined = dir.join(rel);
    if opts.allow_outside_paths {
        return Ok(joined);
    }
    let refuse = || {
        anyhow::anyhow!(
            "{what} '{}' is outside the scene file's folder: a scene may read only files in its \
             own folder and subfolders (pass --allow-outside-paths to allow it)",
            shown_path(rel)
        )
    };
    let mut depth = 0usize;
    for c in rel.components() {
        match c {
            Component::Prefix(_) | Component::RootDir => return Err(refuse()),
            Component::ParentDir => depth = depth.checked_sub(1).ok_or_else(refuse)?,
            Component::CurDir => {}
            Component::Normal(_) => depth += 1,
        }
    }
    let base = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let base = base
        .canonicalize()
        .with_context(|| format!("{}: cannot resolve the scene's folder", shown_path(dir)))?;
    let target = joined
        .canonicalize()
        .with_context(|| format!("{what} {}: cannot read the file", shown_path(&joined)))?;
    if !target.starts_with(&base) {
        return Err(refuse());
    }
    Ok(target)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_escaped_and_clipped() {
        assert_eq!(shown("a\nb\tc"), "a\\nb\\tc");
        assert_eq!(shown("\u{1b}[31m"), "\\u{1b}[31m");
        let long = "x".repeat(500);
        assert_eq!(shown(&long).chars().count(), NAME_MAX + 3);
        assert_eq!(token("abcdef", 3), "abc...");
    }

    #[test]
    fn paths_that_climb_out_are_refused_before_the_file_system() {
        let opts = LoadOptions::default();
        let dir = Path::new("/nonexistent-softshadow-dir");
        for p in ["../x.obj", "a/../../x.obj", "/etc/passwd"] {
            let e = format!(
                "{:#}",
                resolve_inside(dir, Path::new(p), &opts, "mesh").unwrap_err()
            );
            assert!(e.contains("outside the scene file's folder"), "{p}: {e}");
        }
        let allow = LoadOptions {
            allow_outside_paths: true,
        };
        assert_eq!(
            resolve_inside(dir, Path::new("../x.obj"), &allow, "mesh").unwrap(),
            dir.join("../x.obj")
        );
    }
}
